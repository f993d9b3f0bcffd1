/**
 * @file xpPose.h
 * @brief Patient pose conventions of Coordinates.md: misalignment, table correction, CT to Room.
 *
 * A Pose acts on Room points about the isocentre: p' = R (p - iso) + iso + t, with
 * R = Rz(yaw) * Ry(roll) * Rx(pitch); pitch about X (lateral), roll about Y (longitudinal),
 * yaw about Z (vertical); translations in mm, angles in degrees.
 */
#ifndef xpPose_h
#define xpPose_h

#include "vtkXPGeometryModule.h"

#include <Eigen/Geometry>
#include <array>
#include <optional>
#include <string>

namespace xp
{

struct VTKXPGEOMETRY_EXPORT Pose
{
  Eigen::Vector3d translation = Eigen::Vector3d::Zero(); ///< lateral, longitudinal, vertical (mm)
  double pitch = 0.0;                                    ///< about X, degrees
  double roll = 0.0;                                     ///< about Y, degrees
  double yaw = 0.0;                                      ///< about Z, degrees

  Eigen::Matrix3d Rotation() const;

  /** The angle of the whole rotation about its own axis, degrees in [0, 180]. */
  double RotationAngle() const;

  /** The Room-to-Room transform p -> R (p - iso) + iso + t. */
  Eigen::Isometry3d ToTransform(const Eigen::Vector3d& isocenter) const;

  /** The pose of a rigid Room-to-Room transform about `isocenter` (angles in (-180, 180]). */
  static Pose FromTransform(const Eigen::Isometry3d& transform, const Eigen::Vector3d& isocenter);

  /** The inverse motion in the same terms: the table correction of a misalignment. */
  Pose Inverse() const;

  /** The pose from / as (tx, ty, tz, pitch, roll, yaw): mm and degrees, the order of --pose. */
  static Pose FromParameters(const double parameters[6]);
  std::array<double, 6> Parameters() const;

  /** Parses "tx,ty,tz,pitch,roll,yaw"; throws xp::InputError naming `field`. */
  static Pose Parse(const std::string& text, const std::string& field);

  std::string ToString() const;
};

/** R = Rz(yaw) Ry(roll) Rx(pitch), angles in degrees. */
VTKXPGEOMETRY_EXPORT Eigen::Matrix3d RotationFromAngles(double pitch, double roll, double yaw);

/** DICOM Patient Position (0018,5100) values that xpose supports (couch angle 0). */
enum class PatientPosition
{
  HFS,
  HFP,
  FFS,
  FFP
};

/** "HFS" -> PatientPosition::HFS; throws xp::InputError naming `origin` for others. */
VTKXPGEOMETRY_EXPORT PatientPosition ParsePatientPosition(const std::string& text, const std::string& origin);
VTKXPGEOMETRY_EXPORT std::string ToString(PatientPosition position);

/** Rotation taking CT (DICOM LPS) directions to Room directions; HFS: X = x, Y = z, Z = -y. */
VTKXPGEOMETRY_EXPORT Eigen::Matrix3d PatientToRoomRotation(PatientPosition position);

/**
 * The planned CTToRoom transform: CT point `isoInCT` (LPS mm) lands on the Room isocentre, axes
 * per the patient position.
 */
VTKXPGEOMETRY_EXPORT Eigen::Isometry3d PlannedCTToRoom(
  PatientPosition position, const Eigen::Vector3d& isoInCT, const Eigen::Vector3d& roomIsocenter);

/**
 * The planned set-up of a patient: how the CT sits in the room before any misalignment. Every
 * command and filter that places a CT computes its planned transform here.
 */
struct VTKXPGEOMETRY_EXPORT PatientSetup
{
  PatientPosition position = PatientPosition::HFS;      ///< the CT's DICOM Patient Position
  std::optional<Eigen::Vector3d> isocenterInCT;          ///< LPS mm; none = the CT's centre
  Eigen::Vector3d roomIsocenter = Eigen::Vector3d::Zero(); ///< Room mm, the geometry's isocentre

  /** The CT point at the isocentre: isocenterInCT, or `ctCenter` when none is set. */
  Eigen::Vector3d IsocenterInCT(const Eigen::Vector3d& ctCenter) const;
  /** PlannedCTToRoom of this set-up for a CT whose centre is `ctCenter`. */
  Eigen::Isometry3d PlannedCTToRoom(const Eigen::Vector3d& ctCenter) const;
  /** "HFS, CT point (x, y, z) at room (x, y, z)" or "..., the CT's centre at ...". */
  std::string Describe() const;
  bool operator==(const PatientSetup& other) const;
  bool operator!=(const PatientSetup& other) const { return !(*this == other); }
};

/** CTToRoom of a misaligned patient: the misalignment applied after the planned set-up. */
VTKXPGEOMETRY_EXPORT Eigen::Isometry3d MisalignedCTToRoom(const Eigen::Isometry3d& plannedCTToRoom,
  const Pose& misalignment, const Eigen::Vector3d& roomIsocenter);

/**
 * The misalignment in the CT's own coordinates (LPS mm): the anatomy at planned CT point p is
 * found at CT point MisalignmentInCT * p. It is the room misalignment conjugated by the planned
 * set-up, a rotation by the same angle about the CT point at the isocentre plus a translation:
 * what a DICOM Spatial Registration from the CT's Frame of Reference carries.
 */
VTKXPGEOMETRY_EXPORT Eigen::Isometry3d MisalignmentInCT(const Eigen::Isometry3d& plannedCTToRoom,
  const Pose& misalignment, const Eigen::Vector3d& roomIsocenter);

} // namespace xp

#endif
