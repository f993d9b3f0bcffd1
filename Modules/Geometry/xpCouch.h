/**
 * @file xpCouch.h
 * @brief The treatment couch: which motions it has and their limits, the couch motion that
 *        brings a treatment target back to its planned place from an estimated misalignment, what
 *        stays uncorrected, and the clinic's action levels (Coordinates.md, "The couch").
 *
 * A couch motion is in the terms of a correction (xpPose.h): applied to the misaligned patient
 * it gives p'' = R_c (p' - c) + c + t_c, R_c = Rz(yaw) Ry(roll) Rx(pitch), c the couch's rotation
 * centre. A 6-DOF couch without limits carries out the exact correction; a 4-DOF couch (three
 * translations and the isocentric rotation, yaw) and a 6-DOF top with pitch and roll limits
 * turn as close to the correction's rotation as they can, and translate so that the target
 * lands exactly where the plan put it.
 */
#ifndef xpCouch_h
#define xpCouch_h

#include "xpPose.h"

#include <limits>
#include <string>
#include <vector>

namespace xp
{

/** The couch's degrees of freedom. */
enum class CouchMotions
{
  SixDOF, ///< translations, pitch, roll and yaw (a robot or a hexapod top)
  FourDOF ///< translations and yaw (most linac couches)
};

/** "6dof" / "4dof"; throws xp::InputError naming `field` for any other word. */
VTKXPGEOMETRY_EXPORT CouchMotions ParseCouchMotions(const std::string& text, const std::string& field);
VTKXPGEOMETRY_EXPORT std::string CouchMotionsName(CouchMotions motions);
/** The motions by name: lateral, longitudinal, vertical, pitch, roll, yaw (those it has). */
VTKXPGEOMETRY_EXPORT std::vector<std::string> CouchMotionList(CouchMotions motions);

struct VTKXPGEOMETRY_EXPORT CouchDescription
{
  CouchMotions motions = CouchMotions::SixDOF;
  /** The largest pitch and the largest roll it turns, each way, degrees; infinite: no limit. */
  double pitchRollLimitDegrees = std::numeric_limits<double>::infinity();
  /** The point it rotates about (Room mm); none: the isocentre. */
  std::optional<Eigen::Vector3d> rotationCenter;

  /** Throws xp::InputError naming `field` for a limit that is negative, NaN or beyond 180
   *  degrees, or a centre that is not finite. */
  void Validate(const std::string& field) const;
  /** "6dof, pitch and roll within +-3 deg, about the isocentre" and the like. */
  std::string Describe() const;
  bool operator==(const CouchDescription& other) const;
};

/** The clinic's protocol: when no move is needed, and when the patient is set up again. */
struct VTKXPGEOMETRY_EXPORT ActionLevels
{
  /** Within both (translation length and rotation angle of the couch motion), no move is
   *  needed; 0: every motion is a move. */
  double actionMM = 0.0, actionDegrees = 0.0;
  /** Beyond either (CouchMotion::uncorrectedAt100MM, the uncorrected rotation's angle), the
   *  patient is set up again; infinite: no such limit. */
  double maxUncorrectedMM = std::numeric_limits<double>::infinity();
  double maxUncorrectedDegrees = std::numeric_limits<double>::infinity();

  /** Throws xp::InputError naming the option (--action-level-mm, ...) for a negative or NaN
   *  value, or a maximum of 0. */
  void Validate() const;
};

enum class CouchAction
{
  NoneNeeded, ///< the motion is within both action levels
  Move,       ///< move the couch by the motion
  SetUpAgain  ///< what the couch cannot correct is beyond the protocol's limits
};
VTKXPGEOMETRY_EXPORT std::string CouchActionName(CouchAction action); ///< none_needed, move, set_up_again

struct VTKXPGEOMETRY_EXPORT CouchMotion
{
  CouchDescription couch;
  Eigen::Vector3d rotationCenter = Eigen::Vector3d::Zero(); ///< Room mm, c
  Eigen::Vector3d target = Eigen::Vector3d::Zero();         ///< Room mm, the target's planned place
  Pose motion; ///< translation t_c and angles of R_c (its translation is t_c, about c, not the isocentre)
  /** The misalignment left after the couch moves, in the terms of `misalignment` (about the
   *  isocentre): rotation R_c R. */
  Pose uncorrected;
  double uncorrectedAt50MM = 0.0, uncorrectedAt100MM = 0.0; ///< 2 r sin(angle / 2), r = 50, 100 mm
  /** The limits that decided: "no_pitch", "no_roll" (a 4-DOF couch), "pitch_limit", "roll_limit". */
  std::vector<std::string> limitedBy;
  CouchAction action = CouchAction::Move;
  std::string actionReason; ///< why the action, in words

  /** The couch motion as a Room-to-Room transform: p -> R_c (p - c) + c + t_c. */
  Eigen::Isometry3d Transform() const;
  double TranslationLength() const { return this->motion.translation.norm(); }
  /** Two lines: "couch (4dof, ...): move by (x, y, z) mm, pitch .. roll .. yaw .. deg" and what
   *  stays uncorrected, with the limits that decided. */
  std::string Describe() const;
  /** One line for a log: "4dof move (x, y, z) mm, pitch .. roll .. yaw .. deg, 1.20 deg uncorrected". */
  std::string Summary() const;
};

/**
 * The couch motion for an estimated `misalignment` (about `isocenter`, Room mm) that puts
 * `target` (Room mm, where the plan puts the target) back exactly, within the couch's motions
 * and limits, leaving the smallest rotation uncorrected; and the action `levels` decide.
 */
VTKXPGEOMETRY_EXPORT CouchMotion PlanCouchMotion(const Pose& misalignment, const Eigen::Vector3d& isocenter,
  const Eigen::Vector3d& target, const CouchDescription& couch, const ActionLevels& levels);

} // namespace xp

#endif
