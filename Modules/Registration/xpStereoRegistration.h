/**
 * @file xpStereoRegistration.h
 * @brief The whole method of Method.md on prepared inputs: pre-alignment, entropy masks,
 *        6-DOF masked mutual-information alignment (coarse to fine) and the quality gate.
 */
#ifndef xpStereoRegistration_h
#define xpStereoRegistration_h

#include "vtkXPRegistrationModule.h"

#include "xpCTCoverage.h"
#include "xpEntropyMask.h"
#include "xpPoseOptimizer.h"
#include "xpPreAlignment.h"
#include "xpQualityGate.h"
#include "xpRegistrationSchedule.h"
#include "xpStereoSimilarity.h"

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace xp
{

struct StereoRegistrationSettings
{
  /** Register the CT with its table or its body alone, whichever the X-rays' edges match better
   *  near where the body alone pre-aligned (TableChoice; vtkXPStereoRegistrationFilter). false:
   *  the CT as given. */
  bool chooseTable = false;
  bool entropyMask = true;       ///< exclude low-information regions (Method.md, stage 2)
  bool pyramid = true;           ///< half resolution first, when the images are at least 256x192
  /** Every X-ray's 3x3 median is what the registration sees (xpImageLevels.h, Median3x3):
   *  heavy-tailed noise decided the masks and the pose of processed pelvis X-rays (Algorithms.md). */
  bool medianFilter = true;
  /** After the median, every X-ray is smoothed by a Gaussian whose sd at the isocentre is this
   *  fraction of the CT's finest voxel spacing (0.41: the sd of trilinear interpolation's
   *  kernel, the finest detail a DRR of that CT shows). Finer detail in the X-ray is noise to
   *  the registration: on a thick body's starved interior it drowned what the masks keep and
   *  moved the pose (Algorithms.md). 0 = off. */
  double xraySmoothingPerVoxel = 0.41;
  /** ... and more where the X-ray is noisy: until the noise of its ranks (RankNoiseLevels, after
   *  the median) would be down to this many of their 4096 levels, up to twice the sd above. A
   *  Gaussian of sd s pixels leaves 1 / (2 sqrt(pi) s) of white noise. Read noise on a thick
   *  body's starved interior left the held-out peak too flat to pass the gate and some results
   *  millimetres off (Algorithms.md, "A verdict...", 10); the CT's sd alone suits X-rays whose
   *  noise is finer than their anatomy. 0 = the CT's sd alone. */
  double xrayNoiseLevels = 20.0;
  /** Register the X-rays' ranks with the open field bright (RankedXRays in the .cxx): every
   *  later step sees the same image whatever the X-ray's bit depth and grey-level mapping. */
  bool rankedXRays = true;
  /** The half-size stages render from a CT halved along each index axis whose halved spacing
   *  stays within this (mm; HalvingFactors); coarser voxels blur the bone edges the coarse
   *  search follows. */
  double maxHalvedVoxelMM = 2.5;
  /** A volume whose outer surface is bone (a bone cut out of a CT, zero around it) is matched
   *  only within its shadow, widened on the panel by the first margin (mm) for the search and
   *  by the second, at the search's end, for the refinement: the soft tissue and the other
   *  bones that the X-ray shows around it are no part of it. */
  bool detectBoneOnly = true;
  double boneShadowSearchMarginMM = 15.0, boneShadowFineMarginMM = 5.0;
  /** ... less the same margin about the shadow of the faces where the crop cut the bone
   *  (xpBoneCut.h): the X-ray shows it running on there. */
  bool leaveOutBoneCuts = true;
  /** A bone's 6-DOF stages maximise the correlation of both images' structure (less a low-pass
   *  of this sd, mm on the panel; xpStereoSimilarity.h), not MI; 0 = MI. */
  double boneCorrelationHighPassMM = 10.0;
  /** gate, bones: four refinements restarted 2 mm and 2 degrees around the result must all end
   *  within these of it (restarts_disagree). */
  double maxRestartsApartMM = 0.5, maxRestartsApartDegrees = 0.5;
  /** gate, bones: the held-out check on correlation (its own scale) judges the turned neighbours
   *  too, at this least lead; the body's limits were measured on MI and do not carry over. */
  double boneMinPeakMargin = 0.075;
  /** Where the search starts (the misalignment's terms: Room mm and degrees about the
   *  isocentre); the gate's maxTranslation and maxRotation bound the change from it. */
  Pose initialPose;
  int bins = 32;                 ///< MI histogram bins
  /** Where the DRRs' rays are cast: every stage's similarity and shadow (xpRayCaster.h). */
  ComputeDevice device = ComputeDevice::CPU;
  /** MI on equalised levels (xpStereoSimilarity.h); false: on 12-bit transmission as it is. */
  bool equalizedLevels = true;
  /** The full-resolution refinement removes shading wider than this (mm on the panel) from
   *  both images' ranks (xpImageLevels.h): scatter, heel and couch shade an X-ray, and MI would
   *  trade pose for shading. At 20 mm a couch's slab still leaned the physics simulator's pelvis
   *  by +0.4 to +0.8 mm along ty; at 5 mm only the edges of such plateaus are left (Algorithms.md,
   *  "A verdict...", 7). 0 = off. The coarse stages keep the shading, which helps them travel. */
  double fineHighPassMM = 5.0;
  /** The refinement (and the landscape, which reads its objective) renders the DRR's rays on
   *  every this-th pixel of rows and columns and interpolates the rest
   *  (StereoSimilarity::SetRenderStride); 1: all; 0: RenderStrideFor the CT and the views, per
   *  panel axis. */
  int fineRenderStride = 0;
  /** The refinement's rays (and the polish's, the landscape's and the gate's, which read its
   *  objective) sample every this-th voxel plane along their dominant axis
   *  (StereoSimilarity::SetPlaneSteps); 1: every plane (the default); 0: per CT index axis, 2
   *  where the half-size stages halve it (HalvingFactors with maxHalvedVoxelMM: 1 mm voxels,
   *  not the 1.5 mm thorax's or 2 mm phantom's), else 1. The GPU samples every plane. With 0 a
   *  user's pelvis registration took 0.78x the time, with the same successes on seed 14's
   *  matrix but three more accurate results failed at the gate's limits; on the eight cells that
   *  moved, at 30 trials, 183 successes of 240 against 184 and one `ok` 2.57 mm off (Algorithms.md,
   *  "Every second voxel plane in the refinement"). */
  int finePlaneStep = 1;
  /** The same for the coarse searches' half-size DRRs (of the half-resolution CT where used);
   *  every ray by default: at stride 2 the coarser searches left the refinement more to do, and
   *  the whole registration gained little (Performance.md). */
  int searchRenderStride = 1;
  /** The coarse searches travel on quarter-size images first (from the half-size CT), then go
   *  on at half size from where they stopped, when the quarter is at least 128x96: a
   *  quarter-size pair casts a fifth of the rays. Off in the standard schedule, where it cost
   *  accurate results and accuracy on the generalisation matrix (Algorithms.md, "The economy
   *  schedule"); the economy schedule travels so with its own stops. */
  bool quarterSizeTravel = false;
  /** The schedule of the searches and the refinement (MakeSchedule): the economy one (the
   *  default: quarter-size travel, looser stops, one restart) or the standard one it replaced
   *  (Algorithms.md, "The schedule"). */
  ScheduleChoice schedule = ScheduleChoice::Economy;
  /** Rounds at most of moving the refinement's end to the vertex of the objective's parabola
   *  along each axis, through its values landscapeNear either side (MoveToParabolaVertex: 12
   *  evaluations and one more a round; the landscape reads the last round's), until a round moves
   *  less than the refinement's stop (PolishToVertex); 0: the refinement's end as it is. The
   *  refinement's small simplex stops on a bump of the noisy objective near its start; one round
   *  made no cell of the generalisation matrix worse; up to 6 brought noisy pelvis results nearer
   *  but turned as many verdicts at the gate's limits as it mended (Algorithms.md, "Registration",
   *  3). Not for a bone-only volume (its restarts judge the end). */
  int vertexPolishRounds = 1;
  /** Before the full-size refinement, one on half-size images of the same high-passed objective
   *  (steps and stops twice the refinement's), from the searches' ends: the climb from the
   *  searches' objective to the refinement's is made on a quarter of the pixels, and the
   *  full-size refinement starts near its end (MakeSchedule). With a pyramid only. */
  bool halfSizeRefinement = false;
  /** The full-size refinement climbs a first-order model of the DRRs' line integrals, their
   *  slopes rendered once a round (xpLinearizedRefinement.h): fewer full-size renderings than a
   *  simplex that renders every evaluation where that one creeps (the pelvis), more where it is
   *  short (the thorax); on the simulator's shaded and noisy pelvis X-rays its ends lean along ty
   *  and more of them fail the gate (Algorithms.md, "The linearized refinement"): off. */
  bool linearizedRefinement = false;
  /** After the quarter-size travel, the half-size searches maximise the refinement's high-passed
   *  objective (fineHighPassMM) instead of the shaded one: on X-rays whose shading the DRR does not
   *  model (scatter, heel, a couch) the shaded objective's peak lies about a millimetre from the
   *  refinement's, which the full-size refinement then climbs at full cost (MakeSchedule). With
   *  quarter-size travel only: the travel keeps the shading. */
  bool highPassAfterTravel = false;
  /** Pixels whose rays cross the body beyond the CT's end faces may see anatomy the CT does not
   *  have: leave them out (xpCTCoverage.h), with this margin (mm) for the pose still to come. */
  bool coverageMask = true;
  double coverageMarginMM = 4.0;
  /** ... but only beyond a face where the X-ray shows that anatomy: its rays' upper quarter more
   *  attenuated than the DRR predicts by this fraction of the X-ray's range (xpCTCoverage.h,
   *  MeasureAnatomyBeyondEndFaces); a CT as long as the X-ray's anatomy keeps its end rays.
   *  0 = always leave them out. */
  double coverageMinExcess = 0.015;
  int maxEvaluations = 400;      ///< per 6-DOF stage
  /** The coarse searches' optimiser (xpPoseOptimizer.h). BOBYQA fits a quadratic to the smooth
   *  shrunk images' objective and climbs it in half of Nelder-Mead's evaluations (Algorithms.md,
   *  "The searches' BOBYQA"). */
  PoseOptimizerMethod optimizer = PoseOptimizerMethod::BOBYQA;
  /** The refinements' and restarts' optimiser: on the bumpy full-size objective Nelder-Mead ends
   *  nearer than BOBYQA (Algorithms.md, "The refinement stays Nelder-Mead"). */
  PoseOptimizerMethod refinementOptimizer = PoseOptimizerMethod::NelderMead;
  double maxTranslation = 50.0;  ///< gate: largest correction accepted (mm)
  double maxRotation = 10.0;     ///< gate: and degrees
  /** gate: each view must keep at least this many valid pixels per joint-histogram cell
   *  (bins x bins): 2 = 2048 pixels with 32 bins, 1 % of a 512x384 view. */
  double minValidPixelsPerCell = 2.0;
  /** gate: and at least this fraction of the view's pixels. */
  double minValidFraction = 0.05;
  /** gate: MI / H(X-ray) each view must reach at the result, on the ranked X-ray. A floor for
   *  X-rays that show nothing of the CT, not the test of another patient: noise dilutes it (the
   *  processed pelvis's accurate results explain 0.040-0.090, another patient's X-rays 0.006-0.094)
   *  and the held-out peak and the halves decide those (Algorithms.md). */
  double minExplained = 0.025;
  double maxViewResidual = 1.0;  ///< gate: mm (at the isocentre) a view's own 2D registration may still move
  double maxViewResidualDegrees = 1.0; ///< gate: and degrees it may still turn in its plane
  /** gate: mm (at the isocentre) that the 2D registrations of a view's two halves may end apart. */
  double maxHalvesApartMM = 1.0;
  /** gate: ... and this far where the result's held-out peak is clear (peakMargin at least
   *  clearPeakMargin): another anatomy costs both checks at once, noise mostly the halves. On
   *  seed 14's stored matrix runs 25 results failed on halves 1.01-1.24 mm apart alone with
   *  leads of 0.174-0.314, all within 0.86 mm of the truth; a pelvis stretched by 10 % that
   *  failed on its halves alone led by up to 0.176, its halves 2.67 mm apart or more where it
   *  led by 0.14 or more: the halves' 1.25 mm keeps it out (Algorithms.md, "A verdict...", 3). */
  double maxHalvesApartClearPeakMM = 1.25;
  double clearPeakMargin = 0.17;
  /** The halves' 2D searches start with steps of this size (mm at the isocentre). The halves of
   *  an anatomy 10 % longer than the CT's lie 3-7 mm from the whole's result; searches that
   *  started with the view residual's 0.5 mm steps stayed in the nearest local optimum and
   *  ended 0.5 mm apart, and such results ended `ok` up to 7 mm off. */
  double halvesSearchStepMM = 3.0;
  /** gate: largest fraction of a view's valid pixels that may show attenuation where the final
   *  DRR's ray meets no CT (X-ray anatomy the CT does not cover at the result). */
  double maxUncovered = 0.2;
  /** gate: a second coarse search starts from the pre-alignment moved 1.5 mm and 1.5 degrees
   *  along the roll/lateral valley. When it ends farther than these (mm, degrees) from the first
   *  one's end, about as well, both ends are refined at full resolution, and the result fails if
   *  the refined ends are farther apart than maxSearchDisagreementMM or maxRefinedApartDegrees.
   *  The same distances stop the second search and the second end's refinement where they meet
   *  the first's. 0 mm = no second search. The 0.5 degrees are the refined ends' own limit: ends
   *  nearer than that can never fail the result as apart, and refining both of them cost up to
   *  157 full-size evaluations (Algorithms.md, "Where the evaluations go"). */
  double maxSearchDisagreementMM = 0.5;
  double maxSearchDisagreementDegrees = 0.5;
  /** gate: refined ends farther apart than maxSearchDisagreementMM or this (degrees), about as
   *  well, fail the result: 0.5 degrees is the rotational tolerance the result is asked to keep
   *  (two refinements of one optimum ended 0.20-0.21 degrees apart on the matrix's noisiest
   *  pelvis cells; Algorithms.md). */
  double maxRefinedApartDegrees = 0.5;
  /** Coarse ends apart are both refined when the worse one reaches this fraction of the better
   *  one's objective; a clearly worse end is a local optimum the better search left behind. */
  double refineBothObjectiveRatio = 0.95;
  /** The second coarse search stops once it evaluates a pose that agrees with the first one's
   *  end (within the distances above) and reaches this fraction of its objective. */
  double sameOptimumObjectiveRatio = 0.99;
  /** With quarter-size travel: when the second search's quarter-size travel meets the first
   *  one's quarter-size end (the stop above), or one of its runs ends within twice the travel's
   *  tolerances of it (2 mm, 1 degree; no restart follows that run), the second search ends there
   *  (its half-size stage is not run) and the searches' end is the first one's
   *  (ScheduledStage::joinsFirstTrack); false: it goes on at half size and stops there at the
   *  first one's half-size end. */
  bool secondSearchJoins = true;
  /** gate: refined ends apart fail the result when the worse one reaches this fraction of the
   *  better one's objective: two optima the images cannot tell apart. On the pelvis a stall on
   *  the roll/lateral valley ends a few percent lower (Algorithms.md). */
  double ambiguousObjectiveRatio = 0.99;
  /** The landscape around the result (MeasureUncertainty and UncertaintyFromProbes in the
   *  .cxx): the refinement's objective `landscapeNear...` either side along each axis gives the
   *  uncertainty (the vertex polish's own evaluations there, where it ran; about the result
   *  otherwise); a held-out similarity (the ROI, the CT's coverage and its shadow without the
   *  entropy mask, half size) `landscapeCheck...` either side must score below the result. */
  double landscapeNearMM = 1.5, landscapeNearDegrees = 1.0;
  double landscapeCheckMM = 3.0, landscapeCheckDegrees = 1.5;
  /** The held-out similarity keeps only the CT's shadow at the result, widened by this (mm on the
   *  panel; about the 3 mm check's shift at the panel): its outline and what lies within. */
  double heldOutShadowMarginMM = 5.0;
  /** ... and removes shading wider than this (mm on the panel) from both images' ranks, as the
   *  refinement does with fineHighPassMM; its own setting, so that the check's scale (the leads
   *  minPeakMargin was calibrated on) stays when the refinement's changes. */
  double heldOutHighPassMM = 20.0;
  /** gate: the result's least relative lead over the translated held-out neighbours (the turned
   *  ones are recorded, not judged): on the 10-trial matrix 0.18 and more for every accurate
   *  result of the right anatomy, at most 0.13 for the near anatomy and another patient, and at
   *  most 0.10 where no other check failed them; the scenarios' 150 trials 0.22 and more
   *  (Algorithms.md). */
  double minPeakMargin = 0.14;
  /** The held-out check judges the turned neighbours as well (a bone's, ForBone); they are then
   *  measured whatever heldOutTurns says. */
  bool heldOutJudgesTurns = false;
  /** The held-out similarity measured at the turned neighbours too (pitch, roll and yaw
   *  landscapeCheckDegrees either side): recorded in peakLeads, not judged unless
   *  heldOutJudgesTurns. false (the default): the six evaluations that no check reads are not
   *  made, and their leads are NaN. */
  bool heldOutTurns = false;
  /** gate: per-axis uncertainty (the distance over which the objective falls by 5 %). */
  double maxUncertaintyMM = 3.0;
  double maxUncertaintyDegrees = 1.5;
};

/** Where a stage of the 6-DOF search starts in the objective trace, and what it cost. */
struct RegistrationStage
{
  std::string name;
  int firstEvaluation = 0;
  double seconds = 0.0; ///< wall time of the stage
  SimilarityCost cost;  ///< its DRRs, rays, rendering and metric time
  double cpuSeconds = 0.0; ///< CPU time of the process's threads during the stage
  int evaluations = 0;   ///< its stereo similarity evaluations in the trace
  /** The linearized refinement's evaluations of modelled DRRs (rendering nothing; not in the
   *  trace nor in `evaluations`). */
  int modelEvaluations = 0;
  int imageDivisor = 1;  ///< its images' size: the registration's divided by this per side
  /** The scheduled stage it traces (the landscape's held-out check and its evaluation at the
   *  result are the landscape's); what the trace's evaluations served, by kind. */
  StageKind kind = StageKind::Gate;
  /** A refinement of the second search's end (where both ends are refined): the robustness
   *  check's share of the refinement. */
  bool secondEnd = false;
};

/**
 * The CT's table, chosen for by the X-rays (StereoRegistrationSettings::chooseTable): a room's
 * X-rays show its couch, or nothing, and a renderer's may show the CT's own table; no single
 * choice suits all three (Algorithms.md, "The CT's table"). Both CTs, with the table and the
 * body alone (xpBodyMask.h), are pre-aligned to the X-rays, and the one whose DRRs' edges match
 * theirs better there (the refinement's high-passed objective: a couch where the CT's table was
 * casts a like shadow, but not its edges) is registered.
 */
struct TableChoice
{
  double tableCM3 = 0.0; ///< the CT outside the body above BodyMaskSettings::tableHU (0: no table, nothing chosen)
  /** Each CT's high-passed objective (PreAlignedCT; when a table was found): the body alone's at
   *  its pre-alignment; the CT with its table's where two rounds of the pre-alignment take it
   *  from there (StereoRegistrationInStages::HighPassedObjectiveOf). */
  double withTable = 0.0, bodyOnly = 0.0;
  bool keptTable = true; ///< the DRRs were rendered from the CT with its table
  /** Wall time of the choice beside the registration's own stages: the body's segmentation and
   *  volume (none where a session kept them), and the CT with its table taken to the body's pose
   *  and compared there. The pre-alignment of the CT registered is prealignSeconds. */
  double seconds = 0.0;
};

struct StereoRegistrationResult
{
  std::optional<TableChoice> table; ///< with chooseTable
  bool ok = false;
  std::string device = "cpu"; ///< where the rays were cast: ComputeDeviceDescription
  std::vector<GateFailure> failures; ///< why the gate failed (xpQualityGate.h); empty when ok
  std::vector<std::string> Reasons() const; ///< the failures' messages
  Pose start;        ///< the settings' initial pose, where the search began
  /** The volume is a bone cut out of a CT (OuterSurfaceIsBone): only the bone's shadow is matched. */
  bool boneOnly = false;
  /** With boneOnly: the voxels on the faces where the crop cut the bone (0: none cut, or
   *  leaveOutBoneCuts off). */
  long long cutFaceVoxels = 0;
  /** With boneOnly: the farthest end of the refinements restarted around the result. */
  double restartsApartMM = -1.0, restartsApartDegrees = -1.0;
  Pose misalignment;
  Pose correction;                   ///< misalignment.Inverse(): what the table should do
  PreAlignmentResult prealignment;
  double objective = 0.0;
  std::vector<double> mutualInformation; ///< per view at the result
  std::vector<double> explained;         ///< MI / H(X-ray) per view
  std::vector<double> uncovered;         ///< per view: valid pixels showing anatomy where the CT has none
  std::vector<double> viewResidualMM;    ///< per view: its own 2D registration's remaining shift (mm at the isocentre)
  std::vector<double> halvesApartMM;     ///< per view: its halves' 2D registrations apart (mm at the isocentre)
  std::vector<double> validFraction;     ///< of each mask
  std::vector<double> xraySmoothingPixels; ///< each X-ray's smoothing sd (pixels; 0: none)
  std::vector<double> xrayRankNoise; ///< each X-ray's noise on its ranks before the smoothing (RankNoiseLevels, of 4096 levels)
  /** Per view: the median distance from the DRR's edges at the result to the X-ray's nearest edge,
   *  within the held-out region (mm at the isocentre; -1 where either has none), and the same
   *  with the DRR's edges moved EdgeShiftMM: the chance level (xpEdgeAgreement.h). */
  std::vector<double> edgeDistanceMM, edgeDistanceShiftedMM;
  /** Per view: correlation of the X-ray's ranks with the DRR at the start pose, and whether the
   *  X-ray was taken as bright = attenuation (log, processed) and turned over for that. */
  std::vector<double> xrayCorrelation;
  std::vector<bool> xrayInverted;
  std::vector<EndFaceEvidence> endFaces; ///< per view: anatomy beyond the CT's ends, faces left out
  std::vector<std::vector<uint8_t>> masks;     ///< the masks used, in the DRR planes
  std::vector<std::vector<float>> entropyMaps; ///< empty without entropy masks
  std::vector<std::vector<uint16_t>> drrs;     ///< masked 12-bit DRRs at the result
  long long drrCount = 0;
  RenderStride searchRenderStride, fineRenderStride; ///< as used
  std::array<int, 3> finePlaneSteps{ { 1, 1, 1 } };   ///< as used, per CT index axis
  int evaluations = 0;
  bool converged = false;
  double searchDisagreementMM = 0.0;     ///< between the two searches' ends (refined, when both were)
  double searchDisagreementDegrees = 0.0;
  double searchObjectiveRatio = 1.0;     ///< the worse of those two ends' objectives over the better
  /** Per axis tx, ty, tz (mm), pitch, roll, yaw (degrees); infinite where the result is no
   *  maximum along that axis. */
  std::array<double, 6> uncertainty{};
  double peakMargin = 0.0;               ///< least lead of the result over its translated held-out neighbours
  /** Each neighbour's lead: axis a (tx, ty, tz, pitch, roll, yaw) at -step in [2a], +step in [2a + 1];
   *  NaN where not measured (the turned ones unless heldOutTurns or heldOutJudgesTurns). */
  std::array<double, 12> peakLeads{};
  std::vector<double> objectiveTrace;    ///< every 6-DOF evaluation's objective, in order
  std::vector<RegistrationStage> stages; ///< the stages of that trace
  RegistrationSchedule schedule;         ///< the stages as they were scheduled (MakeSchedule)
  double prealignSeconds = 0.0, maskSeconds = 0.0, fineSeconds = 0.0;
  /** CPU time of the process's threads in those steps, and the quality gate's wall and CPU time
   *  (its per-view checks): with the wall time, how busy the cores were. */
  double prealignCPUSeconds = 0.0, maskCPUSeconds = 0.0, gateSeconds = 0.0, gateCPUSeconds = 0.0;
  SimilarityCost prealignCost; ///< the pre-alignment's
};

/** Where a running registration stands, for progress bars and logs. */
struct RegistrationProgress
{
  std::string stage;      ///< "pre-alignment", "coarse search", ..., "done"
  int evaluations = 0;    ///< of this stage so far
  double objective = 0.0; ///< the last evaluation's
  double fraction = 0.0;  ///< of the whole registration, an estimate rising to 1 at "done"
};
using RegistrationObserver = std::function<void(const RegistrationProgress&)>;

/**
 * Whether the volume is a bone cut out of a CT: the median HU of its outer surface (non-air
 * voxels beside air) above 300; a body's surface is skin, near 0 HU.
 */
VTKXPREGISTRATION_EXPORT bool OuterSurfaceIsBone(const AttenuationVolume& volume);

/** Per index axis of the CT, 2 where twice its spacing is at most `maxHalvedVoxelMM`, else 1:
 *  the factors AttenuationVolume::Halved takes for the half-size stages. */
VTKXPREGISTRATION_EXPORT Eigen::Vector3i HalvingFactors(const AttenuationVolume& volume, double maxHalvedVoxelMM);

/** The refinement's plane steps per CT index axis (StereoRegistrationSettings::finePlaneStep):
 *  the setting on every axis, or with 0 the halving factors; every plane on the GPU. */
VTKXPREGISTRATION_EXPORT std::array<int, 3> FinePlaneSteps(const AttenuationVolume& volume, const StereoRegistrationSettings& settings);

/**
 * The stages a registration with `settings` runs: pre-alignment, masks, the searches (track 0
 * from the pre-alignment, track 1 the robustness search, each on half-size images, or on quarter
 * then half with quarterSizeTravel), the refinement, the polish (or a bone's restarts), the
 * landscape and the gate. `pyramid`: the images are at least 256x192 and settings.pyramid is on
 * (else every stage runs at the registration's size); `quarter`: the quarter-size images would be
 * at least 128x96; `boneOnly`: the volume is a bone (OuterSurfaceIsBone), with `settings` already
 * the bone's.
 */
VTKXPREGISTRATION_EXPORT RegistrationSchedule MakeSchedule(
  const StereoRegistrationSettings& settings, bool pyramid, bool quarter, bool boneOnly);

/**
 * The optimiser a search stage runs: `stage.optimizer`, and on track 1 (`firstEnd`: track 0's
 * end at the stage's image size) two ends of its own. It stops as soon as it evaluates a pose that
 * agrees with firstEnd (settings.maxSearchDisagreementMM and Degrees) at no less than
 * settings.sameOptimumObjectiveRatio of its value; and where the stage joins the first track
 * (ScheduledStage::joinsFirstTrack) and firstEnd converged, no restart follows a run that ends
 * within twice the stage's stops of firstEnd (PoseOptimizerSettings::endsRestarts), since a
 * restart from the first track's peak climbs it again. Both keep copies of what they compare.
 */
VTKXPREGISTRATION_EXPORT PoseOptimizerSettings SearchStageOptimizer(
  const ScheduledStage& stage, const PoseOptimizerResult* firstEnd, const StereoRegistrationSettings& settings);

/**
 * Registers a CT to stereo X-rays. `views` carry the X-rays (any bit depth, row 0 first) and, in
 * `mask`, the user ROIs (empty = whole image). Misalignments act about `isocenter` after
 * `plannedCTToRoom`. `observer`, when set, hears of every evaluation. The steps: pre-alignment
 * (xpPreAlignment.h), validity masks (entropy, ROI, CT coverage), a coarse search from two starts,
 * the refinement of its ends and the quality gate (xpQualityGate.h). Throws xp::InputError when
 * a mask leaves nothing to register or a gate limit is invalid.
 */
VTKXPREGISTRATION_EXPORT StereoRegistrationResult RegisterStereo(const AttenuationVolume& volume,
  const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& isocenter, const std::vector<RegistrationView>& views,
  const StereoRegistrationSettings& settings = {}, const RegistrationObserver& observer = {});

/** Where a registration's pre-alignment ended (StereoRegistrationInStages::PreAlign). */
struct PreAlignedCT
{
  PreAlignmentResult prealignment; ///< its pose about the room's isocentre
  /** The refinement's objective there (its high-pass, full size, the ROIs only): the views'
   *  edges, without the shading a couch or table casts. Two CTs of one patient pre-aligned to
   *  the same X-rays compare by it (StereoRegistrationSettings::chooseTable). */
  double highPassedObjective = 0.0;
};

/**
 * RegisterStereo in two steps: PreAlign() runs the schedule's first stage, Finish() the rest
 * and gives the result RegisterStereo would. Between them, HighPassedObjectiveOf compares another
 * CT of the patient (the same with its table) at the pre-aligned pose, and the better one is
 * finished. Throws as RegisterStereo does.
 */
class VTKXPREGISTRATION_EXPORT StereoRegistrationInStages
{
public:
  StereoRegistrationInStages(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
    const Eigen::Vector3d& isocenter, const std::vector<RegistrationView>& views, const StereoRegistrationSettings& settings = {},
    const RegistrationObserver& observer = {});
  ~StereoRegistrationInStages();
  PreAlignedCT PreAlign();           ///< once, first
  /** After PreAlign: PreAlignedCT::highPassedObjective of `other`, another CT of the patient (the
   *  same one with its table, say), on this registration's X-rays as its pre-alignment prepared
   *  them, where `rounds` of the pre-alignment take `other` from `pose` (about the room's
   *  isocentre; 0: at `pose`). Counts no evaluation or rendering of this registration. */
  double HighPassedObjectiveOf(const AttenuationVolume& other, const Pose& pose, int rounds);
  StereoRegistrationResult Finish(); ///< once, after PreAlign
private:
  class Run;
  std::unique_ptr<Run> Stages;
};

/** Box average by an integer factor of a columns-wide image; for masks, a pixel is valid only
 *  when all it covers are. */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> ShrinkImage(const std::vector<uint16_t>& image, int columns, int factor);
VTKXPREGISTRATION_EXPORT std::vector<uint8_t> ShrinkMask(const std::vector<uint8_t>& mask, int columns, int factor);

} // namespace xp

#endif
