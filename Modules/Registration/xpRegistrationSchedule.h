/**
 * @file xpRegistrationSchedule.h
 * @brief A registration as a schedule of stages: what each stage does, on which images and
 *        within which budget. MakeSchedule (xpStereoRegistration.h) gives the default one.
 */
#ifndef xpRegistrationSchedule_h
#define xpRegistrationSchedule_h

#include "vtkXPRegistrationModule.h"

#include "xpPoseOptimizer.h"

#include <optional>
#include <string>
#include <vector>

namespace xp
{

/** Which schedule a registration runs (MakeSchedule). */
enum class ScheduleChoice
{
  Standard, ///< the searches and refinement as the accuracy tables were measured with
  Economy   ///< fewer evaluations: looser searches, a robustness search at quarter size, a looser refinement
};

/** "standard", "economy"; throws xp::InputError naming `field` otherwise. */
VTKXPREGISTRATION_EXPORT ScheduleChoice ParseScheduleChoice(const std::string& name, const std::string& field);
VTKXPREGISTRATION_EXPORT const char* ScheduleChoiceName(ScheduleChoice choice);

/** What a stage of the registration does (RegisterStereo runs them in the schedule's order). */
enum class StageKind
{
  PreAlignment, ///< 5+1 DOF: the views' 2D/2D registrations (xpPreAlignment.h)
  Masks,        ///< entropy masks AND ROIs AND the CT's coverage at the pre-alignment
  Search,       ///< a 6-DOF search on shrunk images: a track's travel or its end
  Refinement,   ///< each end the searches leave, refined at the registration's size
  Polish,       ///< rounds of moving the refinement's end to its parabolas' vertex
  Restarts,     ///< a bone's refinements restarted around the result (the gate's evidence)
  Landscape,    ///< the objective and a held-out similarity around the result
  Gate          ///< each view's own checks and the quality gate (xpQualityGate.h)
};

/** "pre-alignment", "masks", "search", "refinement", "polish", "restarts", "landscape", "gate". */
VTKXPREGISTRATION_EXPORT const char* StageKindName(StageKind kind);
/** The kind StageKindName names `name`; none for any other name. */
VTKXPREGISTRATION_EXPORT std::optional<StageKind> StageKindNamed(const std::string& name);

/** One stage of a registration's schedule: what it does, on which images, within which budget. */
struct ScheduledStage
{
  StageKind kind = StageKind::Search;
  std::string name; ///< as the objective trace, result.json and the progress name it
  /** Its images: the registration's size divided by this per side (1, 2 or 4); those at 2 and 4
   *  are rendered from the CT halved along the axes HalvingFactors allows. */
  int imageDivisor = 1;
  /** Searches: 0 is the search from the pre-alignment; 1 the robustness search from the
   *  pre-alignment moved along the roll/lateral valley. A track's later stage goes on from where
   *  its earlier one ended; the searches' ends are chosen after a track's last stage. */
  int track = 0;
  /** Searches, refinement and restarts: the optimiser, its first steps, its stop on change (mm,
   *  degrees) and its evaluation budget. */
  PoseOptimizerSettings optimizer;
  /** A search: a track 1 stage stops at the first pose that agrees with track 0's end at the
   *  same image size, about as high (so that the two objectives compare). The refinement: the
   *  second end's refinement stops likewise at the first end's. */
  bool stopAtFirstEnd = false;
  /** A track 1 search: when it stopped at track 0's end at this size (stopAtFirstEnd), or ended
   *  converged within twice its optimiser's tolerances of it (both on one peak), the track ends
   *  there: its later stages are not run, and the searches' end is track 0's alone (the two
   *  tracks' distance at this size is the searches' disagreement). A second climb from beside
   *  where the first began at the next size retraces the first's. */
  bool joinsFirstTrack = false;
  /** Searches: shading wider than this removed from the DRRs and the X-rays (sd, mm on the panel,
   *  as StereoRegistrationSettings::fineHighPassMM); 0 keeps it. */
  double highPassMM = 0.0;
  /** The refinement: each round renders the slopes of the DRRs' line integrals about its pose
   *  and the optimiser climbs the objective of their first-order model, which renders nothing
   *  (xpLinearizedRefinement.h); false: every evaluation renders. */
  bool linearized = false;
  int rounds = 0; ///< pre-alignment: most iterations; polish: rounds; restarts: how many
  double progressFrom = 0.0, progressTo = 1.0; ///< its share of the progress reported
};

/** A registration's stages in the order they run: data, recorded in result.json (`schedule`)
 *  and printed by `xpose bench register`. */
struct RegistrationSchedule
{
  std::vector<ScheduledStage> stages;
};

/** One line per stage: its kind, name, image size, steps, stops and budget (for consoles). */
VTKXPREGISTRATION_EXPORT std::string DescribeSchedule(const RegistrationSchedule& schedule);

} // namespace xp

#endif
