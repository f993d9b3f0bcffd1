#include "xpStereoRegistration.h"

#include "xpBoneCut.h"
#include "xpCTCoverage.h"
#include "xpEdgeAgreement.h"
#include "xpError.h"
#include "xpLinearizedRefinement.h"
#include "xpMutualInformation.h"
#include "xpPoseOptimizer.h"
#include "xpQualityGate.h"
#include "xpRayCaster.h"

#include <vtkSMPTools.h>

#include <algorithm>
#include <ctime>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <utility>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/** CPU seconds of all the process's threads since `start` (std::clock). */
double CPUSince(std::clock_t start)
{
  return static_cast<double>(std::clock() - start) / CLOCKS_PER_SEC;
}

template <typename T, typename Combine>
std::vector<T> Shrink(const std::vector<T>& in, int columns, int factor, Combine combine)
{
  const int rows = static_cast<int>(in.size() / columns), outColumns = columns / factor, outRows = rows / factor;
  std::vector<T> out(static_cast<size_t>(outColumns) * outRows);
  std::vector<T> block(static_cast<size_t>(factor) * factor);
  for (int r = 0; r < outRows; ++r)
    for (int c = 0; c < outColumns; ++c)
    {
      for (int y = 0; y < factor; ++y)
        for (int x = 0; x < factor; ++x)
          block[static_cast<size_t>(y) * factor + x] = in[static_cast<size_t>(r * factor + y) * columns + c * factor + x];
      out[static_cast<size_t>(r) * outColumns + c] = combine(block);
    }
  return out;
}

RegistrationView Half(const RegistrationView& item)
{
  RegistrationView half;
  half.view = item.view.Resampled(item.view.Columns() / 2, item.view.Rows() / 2);
  half.xray = ShrinkImage(item.xray, item.view.Columns(), 2);
  half.mask = item.mask.empty() ? item.mask : ShrinkMask(item.mask, item.view.Columns(), 2);
  return half;
}

/** The views at the coarse stages' size: halved when the registration runs a pyramid. */
std::vector<RegistrationView> AtCoarseSize(const std::vector<RegistrationView>& views, bool pyramid)
{
  std::vector<RegistrationView> coarse;
  for (const RegistrationView& item : views)
    coarse.push_back(pyramid ? Half(item) : item);
  return coarse;
}

/**
 * The objective trace of the 6-DOF stages and where each stage begins in it: a stage's wall time,
 * CPU time, cost and evaluations are taken when it ends (or the next begins).
 */
class StageTrace
{
public:
  explicit StageTrace(const SimilarityCost& sink) : Sink(sink) {}

  void Begin(const std::string& name, int imageDivisor, StageKind kind, bool secondEnd = false)
  {
    this->End();
    this->Time = Clock::now();
    this->Cost = this->Sink;
    this->CPU = std::clock();
    RegistrationStage stage;
    stage.name = name;
    stage.firstEvaluation = static_cast<int>(this->Objective.size());
    stage.imageDivisor = imageDivisor;
    stage.kind = kind;
    stage.secondEnd = secondEnd;
    this->Stages.push_back(stage);
    this->Open = true;
  }
  void End()
  {
    if (!this->Open)
      return;
    RegistrationStage& stage = this->Stages.back();
    stage.seconds = Since(this->Time);
    stage.cost = this->Sink - this->Cost;
    stage.cpuSeconds = CPUSince(this->CPU);
    stage.evaluations = static_cast<int>(this->Objective.size()) - stage.firstEvaluation;
    this->Open = false;
  }
  /** Evaluations of modelled DRRs in the open stage (xpLinearizedRefinement.h). */
  void AddModelEvaluations(int count) { this->Stages.back().modelEvaluations += count; }
  double Traced(double objective)
  {
    this->Objective.push_back(objective);
    return objective;
  }

  std::vector<double> Objective;
  std::vector<RegistrationStage> Stages;

private:
  const SimilarityCost& Sink; ///< the registration's running total
  Clock::time_point Time{};
  SimilarityCost Cost;
  std::clock_t CPU = 0;
  bool Open = false;
};

double TranslationApart(const Pose& a, const Pose& b)
{
  return (a.translation - b.translation).cwiseAbs().maxCoeff();
}

double RotationApart(const Pose& a, const Pose& b)
{
  return std::max({ std::abs(a.pitch - b.pitch), std::abs(a.roll - b.roll), std::abs(a.yaw - b.yaw) });
}

} // namespace

Eigen::Vector3i HalvingFactors(const AttenuationVolume& volume, double maxHalvedVoxelMM)
{
  Eigen::Vector3i factors;
  for (int a = 0; a < 3; ++a)
    factors[a] = 2.0 * volume.IndexToCT().linear().col(a).norm() <= maxHalvedVoxelMM ? 2 : 1;
  return factors;
}

std::array<int, 3> FinePlaneSteps(const AttenuationVolume& volume, const StereoRegistrationSettings& settings)
{
  if (settings.device == ComputeDevice::CUDA)
    return { { 1, 1, 1 } };
  if (settings.finePlaneStep > 0)
    return { { settings.finePlaneStep, settings.finePlaneStep, settings.finePlaneStep } };
  const Eigen::Vector3i halving = HalvingFactors(volume, settings.maxHalvedVoxelMM);
  return { { halving[0], halving[1], halving[2] } };
}

namespace
{

bool Agree(const Pose& a, const Pose& b, const StereoRegistrationSettings& settings)
{
  return TranslationApart(a, b) <= settings.maxSearchDisagreementMM &&
    RotationApart(a, b) <= settings.maxSearchDisagreementDegrees;
}

/** Two poses within twice the optimiser's stops of each other, in every translation and angle. */
bool WithinTwiceTheStops(const Pose& a, const Pose& b, const PoseOptimizerSettings& optimizer)
{
  return TranslationApart(a, b) <= 2.0 * optimizer.toleranceMM && RotationApart(a, b) <= 2.0 * optimizer.toleranceDegrees;
}

/** Two ends of searches with these settings on one peak: each stopped within about its
 *  tolerance of the peak, so they lie within twice the tolerances of each other, in every
 *  translation and angle. Both must have stopped there (converged), not on their budget. */
bool OnOnePeak(const PoseOptimizerResult& a, const PoseOptimizerResult& b, const PoseOptimizerSettings& optimizer)
{
  return a.converged && b.converged && WithinTwiceTheStops(a.pose, b.pose, optimizer);
}

/**
 * Fraction of the valid pixels where the X-ray shows attenuation (below 80 % of its open-field
 * level, its 99.5th percentile) but the DRR's ray meets no CT at all (full transmission): anatomy
 * the CT does not cover at this pose.
 */
double UncoveredFraction(const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr, const std::vector<uint8_t>& mask)
{
  std::vector<uint16_t> sorted = xray;
  const size_t rank = static_cast<size_t>(0.995 * (sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + rank, sorted.end());
  const double attenuated = 0.8 * sorted[rank];
  long long valid = 0, uncovered = 0;
  for (size_t i = 0; i < xray.size(); ++i)
  {
    if (!mask[i])
      continue;
    ++valid;
    uncovered += drr[i] >= 4095 && xray[i] < attenuated;
  }
  return valid > 0 ? static_cast<double>(uncovered) / valid : 0.0;
}

/** The rays a shadow casts, kept for the DRRs they are: each view's line integrals at every
 *  pixel (as a similarity of the volume with every ray cast renders them), and their cost. */
struct ShadowRays
{
  std::vector<std::vector<float>> integrals;
  SimilarityCost* cost = nullptr; ///< where given, the shadow's DRRs, rays and time are added
};

/** ANDs into each view's mask the shadow of the volume at `ctToRoom` (rays with any
 *  attenuation), widened by `marginMM` on the panel; `kept`, where given, keeps its rays. */
void AndShadow(std::vector<RegistrationView>& views, const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  double marginMM, ComputeDevice device, ShadowRays* kept = nullptr)
{
  for (RegistrationView& item : views)
  {
    const int columns = item.view.Columns(), rows = item.view.Rows();
    std::vector<float> integrals(static_cast<size_t>(columns) * rows, 0.0f);
    RayCastSettings rayCast;
    rayCast.device = device;
    const Clock::time_point start = Clock::now();
    const long long rays = RenderLineIntegrals(
      volume, ctToRoom, item.view.source, DetectorGrid::TopRowFirst(item.view), nullptr, integrals.data(), rayCast);
    if (kept && kept->cost)
    {
      kept->cost->drrs += 1;
      kept->cost->rays += rays;
      kept->cost->renderSeconds += Since(start);
    }
    std::vector<uint8_t> shadow(integrals.size());
    for (size_t i = 0; i < shadow.size(); ++i)
      shadow[i] = integrals[i] > 0.0f;
    shadow = DilateMask(shadow, columns, rows,
      static_cast<int>(std::ceil(marginMM / std::min(item.view.pixelSpacing[0], item.view.pixelSpacing[1]))));
    if (item.mask.empty())
      item.mask = std::move(shadow);
    else
      for (size_t i = 0; i < shadow.size(); ++i)
        item.mask[i] &= shadow[i];
    if (kept)
      kept->integrals.push_back(std::move(integrals));
  }
}

/** AndShadow, then the pixels within the same margin of the shadow of the bone's cut faces left out
 *  (xpBoneCut.h): there the X-ray shows the bone running on where its DRR ends. */
void AndShadowLessCuts(std::vector<RegistrationView>& views, const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  double marginMM, const std::vector<Eigen::Vector3d>& cutPoints, ComputeDevice device, ShadowRays* kept = nullptr)
{
  AndShadow(views, volume, ctToRoom, marginMM, device, kept);
  for (RegistrationView& item : views)
  {
    LeaveOutAroundPoints(item.mask, item.view, cutPoints, ctToRoom, marginMM);
    if (std::count(item.mask.begin(), item.mask.end(), 1) == 0)
      throw InputError("view " + item.view.name, "the bone's cut ends leave nothing of its shadow to register");
  }
}

/** Leaves out of `item.mask` the pixels whose rays cross the body beyond the CT's end faces `ends`. */
void AndCoverage(RegistrationView& item, const CTCoverage& coverage, const Eigen::Isometry3d& ctToRoom, uint8_t ends)
{
  if (ends == 0)
    return;
  const std::vector<uint8_t> covered = coverage.Mask(ctToRoom, item.view, ends);
  for (size_t i = 0; i < covered.size(); ++i)
    item.mask[i] &= covered[i];
}

/** How far two searches' ends lie apart, and the worse one's objective over the better one's. */
struct Disagreement
{
  double mm = 0.0, degrees = 0.0, objectiveRatio = 1.0;
};

Disagreement Between(const PoseOptimizerResult& a, const PoseOptimizerResult& b)
{
  return { TranslationApart(a.pose, b.pose), RotationApart(a.pose, b.pose), std::min(a.value, b.value) / std::max(a.value, b.value) };
}

} // namespace

PoseOptimizerSettings SearchStageOptimizer(
  const ScheduledStage& stage, const PoseOptimizerResult* firstEnd, const StereoRegistrationSettings& settings)
{
  PoseOptimizerSettings optimizer = stage.optimizer;
  if (!firstEnd)
    return optimizer;
  optimizer.stopWhen = [end = *firstEnd, settings](const Pose& pose, double value)
  { return Agree(pose, end.pose, settings) && value >= settings.sameOptimumObjectiveRatio * end.value; };
  // A track that ends on the first one's peak joins it (RunStages): a converged run that ends
  // there is such an end, and a restart from it would climb the same peak again.
  if (firstEnd->converged && stage.joinsFirstTrack)
    optimizer.endsRestarts = [end = firstEnd->pose, stops = stage.optimizer](const Pose& pose, double)
    { return WithinTwiceTheStops(pose, end, stops); };
  return optimizer;
}

std::vector<uint16_t> ShrinkImage(const std::vector<uint16_t>& image, int columns, int factor)
{
  return Shrink(image, columns, factor, [](const std::vector<uint16_t>& b)
    {
      double sum = 0.0;
      for (uint16_t v : b)
        sum += v;
      return static_cast<uint16_t>(std::lround(sum / b.size()));
    });
}

std::vector<uint8_t> ShrinkMask(const std::vector<uint8_t>& mask, int columns, int factor)
{
  return Shrink(mask, columns, factor,
    [](const std::vector<uint8_t>& b) { return static_cast<uint8_t>(std::all_of(b.begin(), b.end(), [](uint8_t v) { return v != 0; })); });
}

namespace
{

/** Reports a stage's progress as a fraction of the whole registration; each stage owns a slice
 *  of [0, 1] and approaches its end as its evaluations mount (their count is not known ahead). */
class ProgressReporter
{
public:
  explicit ProgressReporter(const RegistrationObserver& observer) : Observer(observer) {}

  void Begin(const std::string& stage, double from, double to)
  {
    this->Stage = stage;
    this->From = from;
    this->To = to;
    this->Evaluations = 0;
    this->Report(0.0, from);
  }
  void Evaluated(double objective)
  {
    ++this->Evaluations;
    this->Report(objective, this->From + (this->To - this->From) * (1.0 - std::exp(-this->Evaluations / 100.0)));
  }
  void Done() { this->Report(0.0, 1.0, "done"); }

private:
  void Report(double objective, double fraction, const std::string& stage = {})
  {
    if (this->Observer)
      this->Observer({ stage.empty() ? this->Stage : stage, this->Evaluations, objective, fraction });
  }

  /** A copy: a registration in stages (StereoRegistrationInStages) outlives the call that gave
   *  it, and a default observer is a temporary. */
  const RegistrationObserver Observer;
  std::string Stage;
  double From = 0.0, To = 0.0;
  int Evaluations = 0;
};

/** Step 2a: which of the CT's end faces each view sees anatomy beyond, at the pre-alignment, on
 *  the pre-alignment's images (their DRRs show the CT's ends as sharply as the full ones). The
 *  excess is a fraction of the X-ray's own range (`xrays`, as they came, at the similarity's
 *  size): ranks would stretch a thin body's faint attenuation into a large share of the range. */
std::vector<EndFaceEvidence> MeasureEndFaces(StereoSimilarity& similarity, const std::vector<std::vector<uint16_t>>& xrays,
  const Pose& pose, const CTCoverage& coverage, const Eigen::Isometry3d& ctToRoom, double minExcess)
{
  similarity.Evaluate(pose);
  std::vector<EndFaceEvidence> faces;
  for (size_t v = 0; v < similarity.Views().size(); ++v)
  {
    const RegistrationView& item = similarity.Views()[v];
    faces.push_back(MeasureAnatomyBeyondEndFaces(
      xrays[v], similarity.LastDRR(v), item.mask, coverage.EndFaces(ctToRoom, item.view), minExcess));
  }
  return faces;
}

/** Step 2b: the entropy mask AND the user ROI of each view (the content), and that AND the CT's
 *  coverage at `ctToRoom` (what is registered). Throws xp::InputError when a view keeps nothing. */
struct ValidityMasks
{
  std::vector<std::vector<uint8_t>> content;
  std::vector<RegistrationView> masked; ///< the views with the validity masks
  std::vector<std::vector<float>> entropyMaps; ///< empty without entropy masks
  std::vector<double> validFraction;           ///< of each view's pixels
};

ValidityMasks BuildValidityMasks(const std::vector<RegistrationView>& views,
  const std::vector<std::vector<uint16_t>>& maskSource, const StereoRegistrationSettings& settings,
  const CTCoverage& coverage, const Eigen::Isometry3d& ctToRoom, const std::vector<EndFaceEvidence>& endFaces)
{
  ValidityMasks masks;
  masks.masked = views;
  for (size_t v = 0; v < views.size(); ++v)
  {
    const RegistrationView& item = views[v];
    const uint8_t* roi = item.mask.empty() ? nullptr : item.mask.data();
    std::vector<uint8_t> mask;
    if (settings.entropyMask)
    {
      EntropyMaskSettings entropySettings;
      entropySettings.maxValue = std::max<int>(entropySettings.binWidth,
        *std::max_element(maskSource[v].begin(), maskSource[v].end()));
      EntropyMaskResult entropy =
        ComputeEntropyMask(maskSource[v].data(), item.view.Columns(), item.view.Rows(), roi, entropySettings);
      mask = std::move(entropy.mask);
      masks.entropyMaps.push_back(std::move(entropy.entropy));
    }
    else
    {
      mask = roi ? item.mask : std::vector<uint8_t>(item.xray.size(), 1);
    }
    RegistrationView& masked = masks.masked[v];
    masked.mask = std::move(mask);
    masks.content.push_back(masked.mask);
    if (settings.coverageMask)
      AndCoverage(masked, coverage, ctToRoom, endFaces[v].facesToLeaveOut);
    const long long valid = std::count(masked.mask.begin(), masked.mask.end(), 1);
    if (valid == 0)
    {
      throw InputError("view " + item.view.name, "the validity mask is empty: nothing left to register");
    }
    masks.validFraction.push_back(static_cast<double>(valid) / masked.mask.size());
  }
  return masks;
}

/** Per axis, the pose `step` along it (mm for tx, ty, tz; degrees for pitch, roll, yaw) from `center`. */
Pose Moved(const Pose& center, int axis, double step)
{
  std::array<double, 6> p = center.Parameters();
  p[axis] += step;
  return Pose::FromParameters(p.data());
}

/**
 * Step 4a: the landscape around the result. Per axis, the refinement's objective at poses
 * `landscapeNear` either side gives its curvature c = (2 f0 - f+ - f-) / h^2, and the uncertainty
 * is the distance over which a parabola of that curvature falls by 5 % of f0: sqrt(0.1 f0 / c);
 * infinite where a neighbour scores higher (no maximum). After a vertex polish its probes give
 * the curvature instead (UncertaintyFromProbes). Then a check the optimiser never saw:
 * `heldOut` (the ROI and the CT's coverage without the entropy mask, half size) at the result
 * and at poses `landscapeCheck` either side along each axis (same ranks and high-pass as the
 * refinement). The right anatomy peaks at the
 * right pose under any reasonable similarity; a pose that only the optimised, masked objective
 * favours (another patient's X-rays, an anatomy no pose fits) is beaten by a neighbour there.
 * The peak margin is the least relative lead of the result over the translated neighbours: the
 * turned ones are not judged, since smooth shading (the heel effect) moves a rounded head's
 * held-out peak along roll by more than the 1.5 degree probe while its result is right to 0.3
 * degree (Algorithms.md, "A verdict...", 2); they are measured only where judged (a bone) or
 * asked for (heldOutTurns), to be recorded.
 */
std::array<double, 6> MeasureUncertainty(
  const std::function<double(const Pose&)>& objective, const Pose& result, double atResult, const StereoRegistrationSettings& settings)
{
  AxisProbes probes;
  probes.atCenter = atResult;
  probes.stepMM = settings.landscapeNearMM;
  probes.stepDegrees = settings.landscapeNearDegrees;
  for (int a = 0; a < 6; ++a)
  {
    probes.below[a] = objective(Moved(result, a, -probes.Step(a)));
    probes.above[a] = objective(Moved(result, a, probes.Step(a)));
  }
  return UncertaintyFromProbes(probes, atResult);
}

/** Step 4a, second half: the result's leads over its neighbours on the held-out similarity. */
struct PeakLeads
{
  double margin = 0.0;           ///< StereoRegistrationResult::peakMargin
  std::array<double, 12> leads{}; ///< StereoRegistrationResult::peakLeads
};

PeakLeads MeasurePeakLeads(const std::function<double(const Pose&)>& heldOut, const Pose& result, const StereoRegistrationSettings& settings)
{
  PeakLeads out;
  const double check = heldOut(result);
  out.margin = std::numeric_limits<double>::infinity();
  out.leads.fill(std::numeric_limits<double>::quiet_NaN());
  const int axes = settings.heldOutJudgesTurns || settings.heldOutTurns ? 6 : 3;
  for (int a = 0; a < axes; ++a)
    for (double sign : { -1.0, 1.0 })
    {
      const double neighbour = heldOut(Moved(result, a, sign * (a < 3 ? settings.landscapeCheckMM : settings.landscapeCheckDegrees)));
      const double lead = check > 0.0 ? (check - neighbour) / check : -1.0;
      out.leads[2 * a + (sign > 0.0 ? 1 : 0)] = lead;
      if (a < 3 || settings.heldOutJudgesTurns)
        out.margin = std::min(out.margin, lead);
    }
  return out;
}

/** How far the DRR's edges move for the edge measure's chance level (mm at the isocentre). */
constexpr double EdgeShiftMM = 3.0;

/** Step 4c: the DRR's edges against the X-ray's at the result, at full size over the held-out
 *  check's region (the ROI, the CT's coverage and its shadow; xpEdgeAgreement.h), both as
 *  equalised levels; the X-ray as the reader sees it in the overlay, before its smoothing (a
 *  thin rim blurred in one image only puts its edges a pixel apart). Not a gate check: a figure
 *  to read beside the overlay. */
struct EdgeDistances
{
  std::vector<double> mm, shiftedMM; ///< StereoRegistrationResult::edgeDistanceMM, edgeDistanceShiftedMM
};

EdgeDistances MeasureEdges(
  const std::function<double(const Pose&)>& evaluate, StereoSimilarity& atFullSize, const Pose& pose, const Eigen::Vector3d& isocenter)
{
  EdgeDistances result;
  evaluate(pose); // atFullSize's DRRs at the pose
  for (size_t v = 0; v < atFullSize.Views().size(); ++v)
  {
    const RegistrationView& item = atFullSize.Views()[v];
    const double mmPerPixel = item.view.pixelSpacing[0] * (item.view.source - isocenter).norm() / item.view.SourceToPanelDistance();
    const int shift = std::max(1, static_cast<int>(std::lround(EdgeShiftMM / mmPerPixel)));
    const EdgeAgreement edges =
      MeasureEdgeAgreement(atFullSize.XRayLevels(v), atFullSize.LastDRRLevels(v), item.mask, item.view.Columns(), item.view.Rows(), shift);
    result.mm.push_back(edges.medianPixels < 0.0 ? -1.0 : edges.medianPixels * mmPerPixel);
    result.shiftedMM.push_back(edges.shiftedMedianPixels < 0.0 ? -1.0 : edges.shiftedMedianPixels * mmPerPixel);
  }
  return result;
}

/** Step 4b: what each view says about the result: the information its final DRR explains, the
 *  anatomy the CT leaves uncovered, and how far its own 2D registration would still move. */
ViewEvidence MeasureView(StereoSimilarity& fine, size_t v, const std::vector<uint16_t>& openFieldBright, const Eigen::Vector3d& isocenter,
  const StereoRegistrationSettings& settings, JointHistogram& histogram)
{
  const RegistrationView& item = fine.Views()[v];
  ViewEvidence evidence;
  evidence.name = item.view.name;
  evidence.validPixels = std::count(item.mask.begin(), item.mask.end(), 1);
  evidence.pixels = static_cast<long long>(item.mask.size());
  histogram.Compute(fine.XRayLevels(v).data(), fine.LastDRRLevels(v).data(), static_cast<long long>(item.xray.size()),
    item.mask.data(), item.mask.data());
  evidence.explained = histogram.FixedEntropy() > 0 ? histogram.MutualInformation() / histogram.FixedEntropy() : 0.0;
  evidence.uncovered = UncoveredFraction(openFieldBright, fine.LastDRR(v), item.mask);
  // The 2D search's first steps are half the residual allowed: steps of the pre-alignment's size
  // miss the narrow optimum of high-passed levels and the search shrinks back onto its start.
  const double mmPerPixel = item.view.pixelSpacing[0] * (item.view.source - isocenter).norm() / item.view.SourceToPanelDistance();
  const Motion2D residual = Register2D(fine.XRayLevels(v), fine.LastDRRLevels(v), item.view.Columns(), item.view.Rows(),
    item.view.Project(isocenter), item.mask.data(), settings.bins, 0.5 * settings.maxViewResidual / mmPerPixel);
  evidence.residualMM = residual.shift.norm() * mmPerPixel;
  evidence.residualDegrees = residual.rotation;
  // Each half of the valid pixels registered on its own (HalvesApart): a rigid fit of the right
  // anatomy leaves both where the whole is, while an anatomy that no rigid pose fits (another
  // person, or one 10 % longer) pulls them apart. Their searches start with wider steps than the
  // residual's (halvesSearchStepMM): each half's own optimum may lie millimetres away. The DRR
  // moves over the X-ray's half and brings in the masks' blanks, which often hold a half where
  // it starts (a 10 % longer pelvis whose halves "agreed" to 0.09 mm at a result 4.07 mm off);
  // so the halves are also registered at once, the X-ray stretched along each panel axis under
  // the DRR (StretchedHalvesApart), and the view's halves are as far apart as the larger says.
  const double stepPixels = settings.halvesSearchStepMM / mmPerPixel;
  const double separately = HalvesApart(fine.XRayLevels(v), fine.LastDRRLevels(v), item.mask, item.view.Columns(),
    item.view.Rows(), item.view.Project(isocenter), settings.bins, stepPixels);
  const double together = StretchedHalvesApart(fine.LastDRRLevels(v), WholePanelLevels(item, fine.Levels()), item.mask,
    item.view.Columns(), item.view.Rows(), settings.bins, stepPixels);
  evidence.halvesApartMM = mmPerPixel * std::max(separately, together);
  return evidence;
}

/** The entropy mask's bins (32 levels wide) span two noise sd: structure finer than the noise is
 *  not information. */
constexpr double EntropyLevelsPerNoiseSigma = 16.0;

/**
 * What share of an image's noise sd its neighbour differences still see once the image is
 * smoothed by a Gaussian of sd `sigmaPixels`: the smoothing makes neighbours alike (correlation
 * exp(-1 / (4 sigma^2)) at one pixel), so their differences shrink more than the noise does. The
 * entropy mask scales its levels by it, so that its bins stay two noise sd wide; without it the
 * mask took smoothed noise for structure (on the processed pelvis it kept many pixels the DRR
 * explained almost nothing of; Algorithms.md).
 */
double NeighbourNoiseShare(double sigmaPixels)
{
  return sigmaPixels > 0.0 ? std::sqrt(1.0 - std::exp(-1.0 / (4.0 * sigmaPixels * sigmaPixels))) : 1.0;
}

/** A smoothing sd under this many pixels leaves an image as it is (its kernel's side weights
 *  are under 0.4 %): skipped. */
constexpr double LeastSmoothingPixels = 0.3;

/** A noisy X-ray is smoothed at most this many times the CT's sd
 *  (StereoRegistrationSettings::xrayNoiseLevels): the noise's gain falls with the sd and the
 *  anatomy's loss grows (1.2 of a voxel, three times the CT's sd, left the noisy pelvis from
 *  plastimatch 6 of 10 `ok` at 0.43 mm; Algorithms.md). */
constexpr double MaxNoiseSmoothing = 2.0;

/** The views with each X-ray replaced by its 3x3 median (Median3x3). */
std::vector<RegistrationView> MedianFiltered(std::vector<RegistrationView> views)
{
  for (RegistrationView& item : views)
    item.xray = Median3x3(item.xray, item.view.Columns(), item.view.Rows());
  return views;
}

/**
 * The X-rays smoothed to the CT's resolution (GaussianSmoothed,
 * StereoRegistrationSettings::xraySmoothingPerVoxel), and a noisy one more, by the noise of its
 * ranks (RankNoiseLevels, xrayNoiseLevels; `sigmas` and `rankNoise` get each view's): what every
 * later step sees. Ranked X-rays
 * are smoothed at the largest power-of-two scale that fits 16 bits: ranks do not change with
 * scale, and the averages keep the levels between the stored ones.
 */
std::vector<RegistrationView> SmoothedToTheCT(std::vector<RegistrationView> views, const AttenuationVolume& volume,
  const Eigen::Vector3d& roomIsocenter, const StereoRegistrationSettings& settings, std::vector<double>& sigmas,
  std::vector<double>& rankNoise)
{
  for (RegistrationView& item : views)
  {
    const int columns = item.view.Columns(), rows = item.view.Rows();
    const double atTheCT =
      settings.xraySmoothingPerVoxel * volume.MinimumSpacing() / PixelSpacingAtIsocenter(item.view, roomIsocenter);
    const double noise = item.xray.empty() ? 0.0 : RankNoiseLevels(item.xray, columns, rows, item.mask);
    rankNoise.push_back(noise);
    // A Gaussian of sd s pixels leaves 1 / (2 sqrt(pi) s) of white noise's sd.
    const double sigma = settings.xrayNoiseLevels > 0.0
      ? std::clamp(noise / (2.0 * std::sqrt(M_PI) * settings.xrayNoiseLevels), atTheCT, MaxNoiseSmoothing * atTheCT)
      : atTheCT;
    if (!(sigma >= LeastSmoothingPixels && std::isfinite(sigma)) || item.xray.empty())
    {
      sigmas.push_back(0.0);
      continue;
    }
    int scale = 1;
    const int largest = std::max<int>(1, *std::max_element(item.xray.begin(), item.xray.end()));
    while (settings.rankedXRays && 2 * scale * largest <= 65535)
      scale *= 2;
    item.xray = GaussianSmoothed(item.xray, columns, rows, sigma, scale);
    sigmas.push_back(sigma);
  }
  return views;
}

/** Each X-ray as the registration sees it (RankedXRays). */
struct WorkingXRays
{
  /** Ranks over the ROI, 0..4095, the open field bright: what MI bins. */
  std::vector<RegistrationView> ranked;
  /** The ranks re-spaced so that one noise sd is the same number of levels everywhere
   *  (NoiseScaledLevels): what the entropy mask bins. */
  std::vector<std::vector<uint16_t>> noiseScaled;
  /** The X-rays' own values with the open field bright (a log image turned over): the
   *  uncovered-anatomy check's "below 80 % of the open field". Not ranks, nor the DRR's
   *  distribution: that lacks the anatomy the CT does not have, which the check looks for. */
  std::vector<std::vector<uint16_t>> openFieldBright;
  /** Per view: the ranks' correlation with the DRR at the start, and whether they were turned
   *  over for it (StereoRegistrationResult::xrayCorrelation, xrayInverted). */
  std::vector<double> correlation;
  std::vector<bool> inverted;
  long long drrs = 0; ///< rendered for the polarity
};

/** Pearson correlation of an X-ray's levels with its DRR over the valid pixels (empty mask: all). */
double CorrelationWithDRR(const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr, const std::vector<uint8_t>& mask)
{
  return PearsonCorrelation(xray.data(), drr.data(), xray.size(), mask.empty() ? nullptr : mask.data());
}

/**
 * Step 0: any monotone grey-level mapping of an X-ray (raw 12 or 16 bits, log, windowed, gamma)
 * gives the same ranks up to ties, so nothing later depends on how the panel or a workstation
 * encoded it. The polarity is read from the images themselves: the X-ray's ranks correlate with
 * the DRR at the start pose positively when bright means transmission (raw) and negatively when
 * bright means attenuation (log, "for presentation"); the body's thickness decides that sign,
 * which a start some centimetres off does not reverse. The entropy mask needs levels on which
 * noise has one size (on ranks a thick body's noisy interior spreads over many levels, and the
 * mask kept noise-picked blobs of it): NoiseScaledLevels.
 */
WorkingXRays RankedXRays(const std::vector<RegistrationView>& views, const AttenuationVolume& volume,
  const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& isocenter, const Pose& start, bool pyramid,
  ComputeDevice device, const std::vector<double>& smoothingPixels)
{
  WorkingXRays working;
  working.ranked = views;
  for (RegistrationView& item : working.ranked)
    item.xray = EqualizedLevels(item.xray, item.mask);
  StereoSimilarity probe(volume, plannedCTToRoom, isocenter, AtCoarseSize(working.ranked, pyramid), 32, { false, 0.0 });
  probe.SetDevice(device);
  probe.Evaluate(start);
  working.drrs = probe.RenderedDRRs();
  for (size_t v = 0; v < working.ranked.size(); ++v)
  {
    RegistrationView& item = working.ranked[v];
    const double correlation = CorrelationWithDRR(probe.Views()[v].xray, probe.LastDRR(v), probe.Views()[v].mask);
    working.correlation.push_back(correlation);
    working.inverted.push_back(correlation < 0.0);
    if (correlation < 0.0)
      for (uint16_t& level : item.xray)
        level = static_cast<uint16_t>(RankLevels - 1 - level);
    working.noiseScaled.push_back(NoiseScaledLevels(item.xray, item.view.Columns(), item.view.Rows(), item.mask,
      EntropyLevelsPerNoiseSigma * NeighbourNoiseShare(smoothingPixels[v]), 8.0));
    std::vector<uint16_t> values = views[v].xray;
    if (correlation < 0.0)
    {
      const uint16_t brightest = values.empty() ? 0 : *std::max_element(values.begin(), values.end());
      for (uint16_t& value : values)
        value = static_cast<uint16_t>(brightest - value);
    }
    working.openFieldBright.push_back(std::move(values));
  }
  return working;
}

/**
 * The settings for a bone cut out of a CT. Around it the X-ray shows soft tissue and bones the
 * volume never had, and the bone runs on beyond the cut: no end-face evidence, no uncovered
 * anatomy, and its shadow is a few percent of a large field, where the information is (the
 * entropy mask would halve a few thousand pixels). Its turns are probed by what moves its ends
 * as far as the translations' probes: 1.5 degrees turn a 70 mm bone's ends 0.9 mm, under a
 * pixel of the held-out similarity.
 */
StereoRegistrationSettings ForBone(StereoRegistrationSettings settings, const AttenuationVolume& volume)
{
  const Eigen::Matrix3d axes = volume.IndexToCT().linear();
  const Eigen::Vector3d spacing(axes.col(0).norm(), axes.col(1).norm(), axes.col(2).norm());
  const double radiusMM = 0.5 * volume.StoredDimensions().cast<double>().cwiseProduct(spacing).maxCoeff();
  const double degreesPerMM = 180.0 / M_PI / std::max(radiusMM, 1.0);
  settings.landscapeCheckDegrees = std::max(settings.landscapeCheckDegrees, settings.landscapeCheckMM * degreesPerMM);
  settings.landscapeNearDegrees = std::max(settings.landscapeNearDegrees, settings.landscapeNearMM * degreesPerMM);
  settings.entropyMask = false;
  settings.coverageMask = false;
  // An intensifier's radiograph of a bone was calibrated with the CT's sd alone.
  settings.xrayNoiseLevels = 0.0;
  settings.heldOutJudgesTurns = true;
  settings.minPeakMargin = settings.boneMinPeakMargin;
  // Half a bone is an end and half a shaft, which slides along itself: searched with wide steps
  // the metacarpal's halves ended 1.2-9.8 mm apart (0.5 mm steps: mostly under 1 mm). The
  // halves check of a bone stays local; its restarts test the pose.
  settings.halvesSearchStepMM = 0.5 * settings.maxViewResidual;
  // A bone's leads are a correlation's, on another scale: no clear peak widens its halves' limit.
  settings.maxHalvesApartClearPeakMM = settings.maxHalvesApartMM;
  settings.maxUncovered = 1.0;
  settings.minValidFraction = 0.0;
  return settings;
}

} // namespace

bool OuterSurfaceIsBone(const AttenuationVolume& volume)
{
  const Eigen::Vector3i d = volume.StoredDimensions();
  // 32 slices tell the surface's median as well as all of them: a body CT's full scan cost 0.5 s
  // of every registration. The slices on both cores, their values gathered in any order: the
  // median is the same.
  const int sliceStep = std::max(1, d[2] / 32);
  const int slices = (d[2] + sliceStep - 1) / sliceStep;
  std::vector<float> surface;
  std::mutex gathered;
  vtkSMPTools::For(0, slices, 1,
    [&](int first, int last)
    {
      std::vector<float> found;
      for (int n = first; n < last; ++n)
      {
        const int k = n * sliceStep;
        // Voxels on the stored box's faces beside the CT's own faces are cut, not surface.
        if (k == 0 || k + 1 >= d[2])
          continue;
        for (int j = 1; j + 1 < d[1]; ++j)
          for (int i = 1; i + 1 < d[0]; ++i)
          {
            const float mu = volume.StoredAt(i, j, k);
            if (mu > 0.0f &&
              (volume.StoredAt(i - 1, j, k) == 0.0f || volume.StoredAt(i + 1, j, k) == 0.0f ||
                volume.StoredAt(i, j - 1, k) == 0.0f || volume.StoredAt(i, j + 1, k) == 0.0f ||
                volume.StoredAt(i, j, k - 1) == 0.0f || volume.StoredAt(i, j, k + 1) == 0.0f))
              found.push_back(mu);
          }
      }
      const std::lock_guard<std::mutex> lock(gathered);
      surface.insert(surface.end(), found.begin(), found.end());
    });
  if (surface.size() < 100)
    return false;
  std::nth_element(surface.begin(), surface.begin() + surface.size() / 2, surface.end());
  const double hu = 1000.0 * (surface[surface.size() / 2] / volume.MuWater() - 1.0);
  return hu > 300.0;
}

std::vector<std::string> StereoRegistrationResult::Reasons() const
{
  return GateMessages(this->failures);
}

namespace
{

/** The searches' ends and how they compare: what the refinement starts from. */
struct SearchEnds
{
  std::vector<Pose> ends; ///< better first; two when both are refined
  Disagreement disagreement;
};

/** The refinement's ends, better first, and what the gate reads of them. */
struct Refined
{
  std::vector<PoseOptimizerResult> ends;
  Disagreement disagreement; ///< between the two refined ends, when there were two
  bool ambiguous = false;    ///< two ends apart and about as good (GateEvidence::ambiguous)
};

/** A bone's restarts around the result: the farthest end from it. */
struct Restarts
{
  double apartMM = 0.0, apartDegrees = 0.0;
};

/** The gate's reading of the result: each view's evidence and the failures. */
struct GateOutcome
{
  std::vector<ViewEvidence> views;
  std::vector<GateFailure> failures;
};

/**
 * One registration: its inputs prepared (step 0), then the stages of its schedule in order, each
 * returning what it found; Run() keeps that in the result. The similarities of the stages are
 * built when a stage first needs them and counted into one cost.
 */
class StereoRegistrationRun
{
public:
  StereoRegistrationRun(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
    const Eigen::Vector3d& roomIsocenter, const std::vector<RegistrationView>& givenViews,
    const StereoRegistrationSettings& requested, const RegistrationObserver& observer)
    : Volume(volume), PlannedCTToRoom(plannedCTToRoom), RoomIsocenter(roomIsocenter), Isocenter(roomIsocenter),
      Progress(observer), Trace(Cost)
  {
    this->Result.device = ComputeDeviceDescription(requested.device);
    this->Result.boneOnly = requested.detectBoneOnly && OuterSurfaceIsBone(volume);
    // A bone turns about its own centre: about an isocentre some centimetres away, each turn would
    // also move it, and the optimiser's steps and the landscape's probes would mix the two. Poses
    // are about the volume's centre at the start inside, and about the isocentre outside.
    this->Settings = this->Result.boneOnly ? ForBone(requested, volume) : requested;
    this->UnsmoothedViews = this->Settings.medianFilter ? MedianFiltered(givenViews) : givenViews;
    this->InputViews =
      SmoothedToTheCT(this->UnsmoothedViews, volume, roomIsocenter, this->Settings, this->Result.xraySmoothingPixels,
        this->Result.xrayRankNoise);
    if (this->Result.boneOnly)
    {
      this->Isocenter = MisalignedCTToRoom(plannedCTToRoom, requested.initialPose, roomIsocenter) * volume.IndexToCT() *
        (0.5 * (volume.Dimensions().cast<double>() - Eigen::Vector3d::Ones()));
      this->Settings.initialPose = Pose::FromTransform(requested.initialPose.ToTransform(roomIsocenter), this->Isocenter);
    }
    const RegistrationView& first = this->InputViews[0];
    this->Pyramid = this->Settings.pyramid && first.view.Columns() >= 256 && first.view.Rows() >= 192;
    const bool quarter = this->Pyramid && first.view.Columns() >= 512 && first.view.Rows() >= 384;
    this->CorrelationMM = this->Result.boneOnly ? this->Settings.boneCorrelationHighPassMM : 0.0;
    this->Result.schedule = MakeSchedule(this->Settings, this->Pyramid, quarter, this->Result.boneOnly);
    this->Result.start = requested.initialPose;
  }

  StereoRegistrationResult Run()
  {
    this->RunStages();
    return this->Finish();
  }

  /** The schedule's stages in order from the first not yet run, up to and including the next of
   *  kind `last` (to the end without). Only the pre-alignment may end a call: the stages after
   *  it share what they found. */
  void RunStages(std::optional<StageKind> last = std::nullopt)
  {
    const std::vector<ScheduledStage>& stages = this->Result.schedule.stages;
    std::array<std::optional<PoseOptimizerResult>, 2> trackEnds;
    std::map<int, PoseOptimizerResult> firstTrackEnds; // track 0's end at each image size
    std::optional<Disagreement> joined; // where the second track met the first and ended (joinsFirstTrack)
    SearchEnds searchEnds;
    Refined refined;
    Clock::time_point sixDOFStart{};
    for (size_t s = this->NextStage; s < stages.size(); ++s)
    {
      this->NextStage = s + 1;
      const ScheduledStage& stage = stages[s];
      this->Progress.Begin(stage.name, stage.progressFrom, stage.progressTo);
      switch (stage.kind)
      {
        case StageKind::PreAlignment:
        {
          const Clock::time_point start = Clock::now();
          const std::clock_t cpuStart = std::clock();
          this->Result.prealignment = this->PreAlign(stage);
          this->Result.prealignSeconds = Since(start);
          this->Result.prealignCPUSeconds = CPUSince(cpuStart);
          this->Result.prealignCost = this->Cost;
          break;
        }
        case StageKind::Masks:
        {
          const Clock::time_point start = Clock::now();
          const std::clock_t cpuStart = std::clock();
          this->BuildMasks(this->Result.prealignment.pose);
          this->Result.maskSeconds = Since(start);
          this->Result.maskCPUSeconds = CPUSince(cpuStart);
          break;
        }
        case StageKind::Search:
        {
          if (!trackEnds[0] && !trackEnds[1])
            sixDOFStart = Clock::now();
          std::optional<PoseOptimizerResult>& track = trackEnds[stage.track];
          const auto firstEnd = firstTrackEnds.find(stage.imageDivisor);
          const bool meetsFirst = stage.stopAtFirstEnd && firstEnd != firstTrackEnds.end();
          if (!(joined && stage.track == 1)) // a joined second track has ended
          {
            const PoseOptimizerResult found = this->Search(stage, track ? track->pose : this->TrackStart(stage.track),
              meetsFirst ? &firstEnd->second : nullptr);
            this->Result.evaluations += found.evaluations;
            track = found;
            if (stage.track == 0)
              firstTrackEnds[stage.imageDivisor] = found;
            if (meetsFirst && stage.joinsFirstTrack && (found.reachedTarget || OnOnePeak(found, firstEnd->second, stage.optimizer)))
              joined = Between(firstEnd->second, found);
          }
          if (s + 1 == stages.size() || stages[s + 1].kind != StageKind::Search)
          {
            this->Trace.End();
            searchEnds = joined ? ChooseSearchEnds(*trackEnds[0], std::nullopt) : ChooseSearchEnds(*trackEnds[0], trackEnds[1]);
            if (joined)
              searchEnds.disagreement = *joined;
            this->Result.searchDisagreementMM = searchEnds.disagreement.mm;
            this->Result.searchDisagreementDegrees = searchEnds.disagreement.degrees;
            this->Result.searchObjectiveRatio = searchEnds.disagreement.objectiveRatio;
            for (auto& [key, similarity] : this->Searches)
              this->Result.drrCount += similarity->RenderedDRRs();
          }
          break;
        }
        case StageKind::Refinement:
          refined = this->Refine(stage, refined.ends.empty() ? searchEnds.ends : PosesOf(refined.ends));
          if (refined.ends.size() == 2)
          {
            this->Result.searchDisagreementMM = refined.disagreement.mm;
            this->Result.searchDisagreementDegrees = refined.disagreement.degrees;
            this->Result.searchObjectiveRatio = refined.disagreement.objectiveRatio;
          }
          break;
        case StageKind::Polish:
          refined.ends.front() = this->Polish(stage, refined.ends.front());
          break;
        case StageKind::Restarts:
        {
          const Restarts restarts = this->Restart(stage, refined.ends.front());
          this->Result.restartsApartMM = restarts.apartMM;
          this->Result.restartsApartDegrees = restarts.apartDegrees;
          break;
        }
        case StageKind::Landscape:
        {
          const PoseOptimizerResult& end = refined.ends.front();
          this->MeasureAround(stage, end);
          this->Result.drrCount += this->Fine->RenderedDRRs();
          for (auto& [divisor, similarity] : this->ShrunkRefinements)
            this->Result.drrCount += similarity->RenderedDRRs();
          this->Result.converged = end.converged;
          this->Result.misalignment = this->AboutIsocenter(end.pose);
          this->Result.correction = this->Result.misalignment.Inverse();
          this->Result.mutualInformation = this->Fine->LastMutualInformation();
          this->Result.fineSeconds = Since(sixDOFStart);
          break;
        }
        case StageKind::Gate:
        {
          const Clock::time_point start = Clock::now();
          const std::clock_t cpuStart = std::clock();
          this->Keep(this->Judge(refined));
          this->Result.gateSeconds = Since(start);
          this->Result.gateCPUSeconds = CPUSince(cpuStart);
          break;
        }
      }
      if (last && stage.kind == *last)
        return;
    }
  }

  /** The result, once every stage has run. */
  StereoRegistrationResult Finish()
  {
    this->Trace.End();
    this->Result.objectiveTrace = std::move(this->Trace.Objective);
    this->Result.stages = std::move(this->Trace.Stages);
    this->Result.prealignment.pose = this->AboutIsocenter(this->Result.prealignment.pose);
    this->Progress.Done();
    return std::move(this->Result);
  }

  /** After RunStages(StageKind::PreAlignment): where it ended (about the room's isocentre) and
   *  the refinement's objective there. */
  PreAlignedCT PreAligned()
  {
    PreAlignedCT aligned;
    aligned.prealignment = this->Result.prealignment;
    aligned.prealignment.pose = this->AboutIsocenter(this->Result.prealignment.pose);
    aligned.highPassedObjective = this->HighPassedObjectiveAt(this->Result.prealignment.pose);
    return aligned;
  }

  /** After RunStages(StageKind::PreAlignment): HighPassedObjectiveAt for another CT of the
   *  patient where `rounds` of the pre-alignment take it from `aboutRoomIsocenter` (a pose about
   *  the room's isocentre; 0 rounds: there), on this registration's X-rays as its pre-alignment
   *  prepared them. Its renderings count to no stage of this registration. */
  double HighPassedObjectiveOf(const AttenuationVolume& other, const Pose& aboutRoomIsocenter, int rounds)
  {
    const Pose start = Pose::FromTransform(aboutRoomIsocenter.ToTransform(this->RoomIsocenter), this->Isocenter);
    const auto stage = std::find_if(this->Result.schedule.stages.begin(), this->Result.schedule.stages.end(),
      [](const ScheduledStage& s) { return s.kind == StageKind::PreAlignment; });
    if (rounds <= 0 || stage == this->Result.schedule.stages.end())
      return this->HighPassedObjectiveAt(start, &other);
    // The pre-alignment's own similarity, of the other CT (halved as this one was).
    std::unique_ptr<AttenuationVolume> halved;
    if (stage->imageDivisor > 1 && this->HalfVolume)
      halved = std::make_unique<AttenuationVolume>(other.Halved(HalvingFactors(other, this->Settings.maxHalvedVoxelMM)));
    const std::unique_ptr<StereoSimilarity> similarity = this->Similarity(halved ? *halved : other,
      Shrunk(this->Working.ranked, stage->imageDivisor), { this->Settings.equalizedLevels, 0.0 }, false);
    const PreAlignmentResult refined = xp::PreAlign(*similarity, start, this->Isocenter, rounds);
    return this->HighPassedObjectiveAt(refined.pose, &other);
  }

private:
  /** After the pre-alignment: the refinement's objective (its high-pass, full size, the X-rays'
   *  ROIs only) at `pose`, of this registration's CT or `other`: what the views' edges say,
   *  without the shading. */
  double HighPassedObjectiveAt(const Pose& pose, const AttenuationVolume* other = nullptr)
  {
    const std::unique_ptr<StereoSimilarity> similarity = this->Similarity(other ? *other : this->Volume, this->Working.ranked,
      { this->Settings.equalizedLevels, this->Settings.fineHighPassMM, this->CorrelationMM }, other == nullptr);
    return similarity->Evaluate(pose);
  }

  Pose AboutIsocenter(const Pose& pose) const
  {
    return Pose::FromTransform(pose.ToTransform(this->Isocenter), this->RoomIsocenter);
  }
  Eigen::Isometry3d CTToRoom(const Pose& pose) const
  {
    return MisalignedCTToRoom(this->PlannedCTToRoom, pose, this->Isocenter);
  }
  /** The CT the stages at `divisor` render: halved for shrunk images where HalvingFactors allows. */
  const AttenuationVolume& VolumeFor(int divisor) const
  {
    return divisor > 1 && this->HalfVolume ? *this->HalfVolume : this->Volume;
  }
  static std::vector<RegistrationView> Shrunk(std::vector<RegistrationView> views, int divisor)
  {
    for (int d = divisor; d > 1; d /= 2)
      views = AtCoarseSize(views, true);
    return views;
  }
  /** A similarity of this registration, its rays cast where the settings say and its cost
   *  counted (unless `counted` is false: another CT's, for a comparison). */
  std::unique_ptr<StereoSimilarity> Similarity(
    const AttenuationVolume& volume, const std::vector<RegistrationView>& views, const SimilarityLevels& levels, bool counted = true)
  {
    auto similarity = std::make_unique<StereoSimilarity>(
      volume, this->PlannedCTToRoom, this->Isocenter, views, this->Settings.bins, levels);
    similarity->SetDevice(this->Settings.device);
    if (counted)
      similarity->SetCostSink(&this->Cost);
    return similarity;
  }
  /** Every evaluation of a 6-DOF stage: traced, heard, and counted into `evaluations` when set. */
  std::function<double(const Pose&)> Traced(StereoSimilarity& similarity, int* evaluations = nullptr)
  {
    return [this, &similarity, evaluations](const Pose& p)
    {
      const double value = this->Trace.Traced(similarity.Evaluate(p));
      if (evaluations)
        ++*evaluations;
      this->Progress.Evaluated(value);
      return value;
    };
  }

  /** Step 1 (with step 0, the X-rays' ranks): the 5+1-DOF pre-alignment with the user ROIs only,
   *  at the stage's size. Shrunk images are rendered from a CT halved along each axis whose
   *  voxels stay fine enough: their pixels are twice as wide, and a ray takes half the samples
   *  (a CT of thick slices halves its pixels only). */
  PreAlignmentResult PreAlign(const ScheduledStage& stage)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    const Eigen::Vector3i halving = HalvingFactors(this->Volume, settings.maxHalvedVoxelMM);
    if (this->Pyramid && halving != Eigen::Vector3i::Ones())
      this->HalfVolume = std::make_unique<AttenuationVolume>(this->Volume.Halved(halving));
    const AttenuationVolume& coarseVolume = this->VolumeFor(stage.imageDivisor);
    if (this->Result.boneOnly && settings.leaveOutBoneCuts)
      this->CutPoints = CutFacePoints(this->Volume);
    this->Result.cutFaceVoxels = static_cast<long long>(this->CutPoints.size());
    std::vector<RegistrationView> startViews = this->InputViews;
    if (this->Result.boneOnly)
      AndShadowLessCuts(startViews, coarseVolume, this->CTToRoom(settings.initialPose), settings.boneShadowSearchMarginMM,
        this->CutPoints, settings.device);
    if (settings.rankedXRays)
    {
      this->Working = RankedXRays(startViews, coarseVolume, this->PlannedCTToRoom, this->Isocenter, settings.initialPose,
        stage.imageDivisor > 1, settings.device, this->Result.xraySmoothingPixels);
      this->Result.xrayCorrelation = this->Working.correlation;
      this->Result.xrayInverted = this->Working.inverted;
      this->Result.drrCount += this->Working.drrs;
    }
    else
    {
      this->Working.ranked = startViews;
      for (const RegistrationView& item : startViews)
        this->Working.openFieldBright.push_back(item.xray);
      this->Working.noiseScaled = this->Working.openFieldBright;
    }
    this->PreAlignment = this->Similarity(
      coarseVolume, Shrunk(this->Working.ranked, stage.imageDivisor), { settings.equalizedLevels, 0.0 });
    PreAlignmentResult prealignment;
    // A bone's start is already near (a given pose, the previous frame's, or the global search's,
    // refined on both views at once): the 2D/2D steps, each view alone in a field of other bones,
    // turned the third metacarpal 25 degrees away from a good start.
    if (stage.rounds == 0)
    {
      prealignment.pose = settings.initialPose;
      prealignment.objective = this->PreAlignment->Evaluate(settings.initialPose);
    }
    else
      prealignment = xp::PreAlign(*this->PreAlignment, settings.initialPose, this->Isocenter, stage.rounds);
    this->Result.drrCount += this->PreAlignment->RenderedDRRs();
    return prealignment;
  }

  /** Step 2: which CT end faces each view sees anatomy beyond (on the pre-alignment's images), then
   *  entropy masks AND ROIs AND the CT's coverage at the pre-alignment. */
  void BuildMasks(const Pose& prealigned)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    this->Coverage = std::make_unique<CTCoverage>(this->Volume, settings.coverageMarginMM);
    if (settings.coverageMask)
    {
      std::vector<std::vector<uint16_t>> asTheyCame;
      for (const RegistrationView& item : AtCoarseSize(this->InputViews, this->Pyramid))
        asTheyCame.push_back(item.xray);
      this->Result.endFaces = MeasureEndFaces(*this->PreAlignment, asTheyCame, prealigned, *this->Coverage,
        this->CTToRoom(prealigned), settings.coverageMinExcess);
    }
    ValidityMasks masks = BuildValidityMasks(this->Working.ranked, this->Working.noiseScaled, settings, *this->Coverage,
      this->CTToRoom(prealigned), this->Result.endFaces);
    this->Content = std::move(masks.content);
    this->Masked = std::move(masks.masked);
    this->Result.entropyMaps = std::move(masks.entropyMaps);
    this->Result.validFraction = std::move(masks.validFraction);
  }

  /** Where a search track starts: the pre-alignment, or (track 1) it moved along the roll/lateral
   *  valley, which two views see least: a landscape with two optima there cannot give a
   *  trustworthy result. Two independent starts, not the first end moved: a search from the first
   *  end can stall on the valley's flat floor short of it. */
  Pose TrackStart(int track) const
  {
    Pose start = this->Result.prealignment.pose;
    if (track == 1)
    {
      start.roll += 1.5;
      start.translation[0] += 1.5;
    }
    return start;
  }

  /** The similarity a search stage maximises: the masked views shrunk by its divisor, every ray
   *  cast at quarter size, the search's stride otherwise; the stage's high-pass (none by default:
   *  the shading helps them travel). */
  StereoSimilarity& SearchSimilarity(const ScheduledStage& stage)
  {
    const int divisor = stage.imageDivisor;
    std::unique_ptr<StereoSimilarity>& similarity = this->Searches[{ divisor, stage.highPassMM }];
    if (!similarity)
    {
      const std::vector<RegistrationView> views = Shrunk(this->Masked, divisor);
      const AttenuationVolume& volume = this->VolumeFor(divisor);
      similarity = this->Similarity(volume, views, { this->Settings.equalizedLevels, stage.highPassMM, this->CorrelationMM });
      if (divisor <= 2)
      {
        const int stride = this->Settings.searchRenderStride;
        this->Result.searchRenderStride = stride > 0 ? RenderStride{ stride, stride }
                                                     : RenderStrideFor(volume, views, this->PlannedCTToRoom, this->Isocenter);
        similarity->SetRenderStride(this->Result.searchRenderStride);
      }
    }
    return *similarity;
  }

  /** Step 3a: one search stage from `from`. A track 1 stage stops once it evaluates a pose that
   *  agrees with track 0's end at the same image size (`firstEnd`) about as high: the rest of its
   *  travel would only polish the same optimum. */
  PoseOptimizerResult Search(const ScheduledStage& stage, const Pose& from, const PoseOptimizerResult* firstEnd)
  {
    this->Trace.Begin(stage.name, stage.imageDivisor, stage.kind);
    return MaximizePose(this->Traced(this->SearchSimilarity(stage)), from, SearchStageOptimizer(stage, firstEnd, this->Settings));
  }

  /** The ends to refine, better first. Ends far apart matter only when both are about as good;
   *  a clearly worse end is a local optimum that the better search left behind. */
  SearchEnds ChooseSearchEnds(PoseOptimizerResult first, std::optional<PoseOptimizerResult> second) const
  {
    SearchEnds chosen;
    chosen.ends = { first.pose };
    if (!second)
      return chosen;
    if (second->value > first.value)
      std::swap(first, *second);
    chosen.disagreement = Between(first, *second);
    chosen.ends = { first.pose };
    if (!Agree(first.pose, second->pose, this->Settings) && second->value >= this->Settings.refineBothObjectiveRatio * first.value)
      chosen.ends.push_back(second->pose);
    return chosen;
  }

  /**
   * Step 3b: each end refined at the stage's size on the masks taken again there. The
   * pre-alignment leaves the angles the views see least a few degrees off (pitch of 3.6 degrees
   * moves a pelvis CT's end faces 3.5 mm at 56 mm from the isocentre): the coverage is taken again
   * where the search ended, before the refinement that it would otherwise bias. A stall on the
   * shrunk images' flatter valley floor comes back at full resolution or shows its lower
   * objective: only ends that stay apart there and are equally good within ambiguousObjectiveRatio
   * mean the images do not fix the pose.
   */
  Refined Refine(const ScheduledStage& stage, const std::vector<Pose>& ends)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    if (!this->Fine)
      this->PrepareRefinement(ends.front());
    StereoSimilarity& similarity = this->RefinementSimilarity(stage.imageDivisor);
    Refined refined;
    for (size_t e = 0; e < ends.size(); ++e)
    {
      const std::string name = e == 0 ? stage.name : stage.name + " from the second search's end";
      this->Trace.Begin(name, stage.imageDivisor, stage.kind, e > 0);
      if (e > 0)
        this->Progress.Begin(name, stage.progressTo, stage.progressTo + 0.5 * (stage.progressTo - stage.progressFrom));
      // The second end's refinement stops at the first pose that agrees with the first end's,
      // about as high: from there it would only polish the same optimum again.
      PoseOptimizerSettings optimizer = stage.optimizer;
      if (e > 0 && stage.stopAtFirstEnd)
      {
        const PoseOptimizerResult first = refined.ends.front();
        optimizer.stopWhen = [first, &settings](const Pose& pose, double value)
        { return Agree(pose, first.pose, settings) && value >= settings.sameOptimumObjectiveRatio * first.value; };
      }
      if (stage.linearized)
      {
        const LinearizedRefinementResult end = MaximizeOnLinearizedDRRs(similarity, this->Traced(similarity), ends[e], optimizer);
        this->Trace.AddModelEvaluations(end.modelEvaluations);
        refined.ends.push_back(end);
      }
      else
        refined.ends.push_back(MaximizePose(this->Traced(similarity), ends[e], optimizer));
      this->Result.evaluations += refined.ends.back().evaluations;
    }
    this->Trace.End();
    if (refined.ends.size() == 2)
    {
      const PoseOptimizerResult &a = refined.ends[0], &b = refined.ends[1];
      refined.disagreement = Between(a, b);
      const double worse = std::min(a.value, b.value), better = std::max(a.value, b.value);
      const bool apart = !(TranslationApart(a.pose, b.pose) <= settings.maxSearchDisagreementMM &&
        RotationApart(a.pose, b.pose) <= settings.maxRefinedApartDegrees);
      refined.ambiguous = apart && worse >= settings.ambiguousObjectiveRatio * better;
      if (b.value > a.value)
        std::swap(refined.ends[0], refined.ends[1]);
    }
    return refined;
  }

  /** Before the first refinement stage: the masks taken again where the searches ended
   *  (`searchedPose`, the better end), and the full-size similarity the refinement, the polish and
   *  the gate read. */
  void PrepareRefinement(const Pose& searchedPose)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    if (settings.coverageMask)
    {
      const Eigen::Isometry3d searched = this->CTToRoom(searchedPose);
      for (size_t v = 0; v < this->Masked.size(); ++v)
      {
        RegistrationView& item = this->Masked[v];
        item.mask = this->Content[v];
        AndCoverage(item, *this->Coverage, searched, this->Result.endFaces[v].facesToLeaveOut);
        if (std::count(item.mask.begin(), item.mask.end(), 1) == 0)
          throw InputError("view " + item.view.name, "the CT covers none of the valid pixels: nothing left to register");
      }
    }
    if (this->Result.boneOnly)
      AndShadowLessCuts(this->Masked, this->Volume, this->CTToRoom(searchedPose), settings.boneShadowFineMarginMM,
        this->CutPoints, settings.device);
    this->Fine = this->Similarity(
      this->Volume, this->Masked, { settings.equalizedLevels, settings.fineHighPassMM, this->CorrelationMM });
    this->Result.fineRenderStride = settings.fineRenderStride > 0
      ? RenderStride{ settings.fineRenderStride, settings.fineRenderStride }
      : RenderStrideFor(this->Volume, this->Masked, this->PlannedCTToRoom, this->Isocenter);
    this->Fine->SetRenderStride(this->Result.fineRenderStride);
    this->Result.finePlaneSteps = FinePlaneSteps(this->Volume, settings);
    this->Fine->SetPlaneSteps(this->Result.finePlaneSteps);
  }

  /** The refinement's objective at `divisor`: the full-size one (Fine), or the same high-passed
   *  levels on the masked views shrunk, from the CT the searches at that size render, at the stride
   *  RenderStrideFor gives them. */
  StereoSimilarity& RefinementSimilarity(int divisor)
  {
    if (divisor == 1)
      return *this->Fine;
    std::unique_ptr<StereoSimilarity>& similarity = this->ShrunkRefinements[divisor];
    if (!similarity)
    {
      const std::vector<RegistrationView> views = Shrunk(this->Masked, divisor);
      const AttenuationVolume& volume = this->VolumeFor(divisor);
      similarity = this->Similarity(volume, views, { this->Settings.equalizedLevels, this->Settings.fineHighPassMM, this->CorrelationMM });
      similarity->SetRenderStride(RenderStrideFor(volume, views, this->PlannedCTToRoom, this->Isocenter));
    }
    return *similarity;
  }

  static std::vector<Pose> PosesOf(const std::vector<PoseOptimizerResult>& ends)
  {
    std::vector<Pose> poses;
    for (const PoseOptimizerResult& end : ends)
      poses.push_back(end.pose);
    return poses;
  }

  /** Step 3c: the refinement's small simplex stops on the first bump of a noisy objective near
   *  where it started; the parabolas span the landscape's 3 mm and 2 degrees and read the peak's
   *  shape, round after round until one moves less than the refinement's stop (PolishToVertex). */
  PoseOptimizerResult Polish(const ScheduledStage& stage, PoseOptimizerResult end)
  {
    this->Trace.Begin(stage.name, stage.imageDivisor, stage.kind);
    const VertexPolish polish = PolishToVertex(this->Traced(*this->Fine, &this->Result.evaluations), end.pose, end.value,
      this->Settings.landscapeNearMM, this->Settings.landscapeNearDegrees, stage.rounds, stage.optimizer.toleranceMM,
      stage.optimizer.toleranceDegrees);
    end.pose = polish.pose;
    end.value = polish.value;
    if (polish.rounds > 0)
      this->PolishProbes = polish.probes; // the landscape reads the peak's curvature from them
    this->Trace.End();
    return end;
  }

  /** Step 3c for a bone: refinements from 2 mm and 2 degrees around the result, each axis's sign
   *  changing from start to start (rotations about the bone's centre): they must all come back. */
  Restarts Restart(const ScheduledStage& stage, const PoseOptimizerResult& end)
  {
    this->Trace.Begin(stage.name, stage.imageDivisor, stage.kind);
    const auto objective = this->Traced(*this->Fine);
    Restarts restarts;
    for (int k = 0; k < stage.rounds; ++k)
    {
      std::array<double, 6> p = end.pose.Parameters();
      for (int a = 0; a < 6; ++a)
        p[a] += ((k < 2 ? k : a + k) % 2 == 0 ? 2.0 : -2.0);
      const PoseOptimizerResult again = MaximizePose(objective, Pose::FromParameters(p.data()), stage.optimizer);
      this->Result.evaluations += again.evaluations;
      restarts.apartMM = std::max(restarts.apartMM, TranslationApart(again.pose, end.pose));
      restarts.apartDegrees = std::max(restarts.apartDegrees, RotationApart(again.pose, end.pose));
    }
    this->Trace.End();
    return restarts;
  }

  /** Step 4a: the landscape around the result (MeasureLandscape) on the refinement's objective
   *  and on a held-out similarity, and the edges' agreement (MeasureEdges). */
  void MeasureAround(const ScheduledStage& stage, const PoseOptimizerResult& end)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    this->Trace.Begin(stage.name, stage.imageDivisor, stage.kind);
    // The ROI and the CT's coverage, without the entropy mask: pixels the optimiser never saw,
    // but none that no pose of this CT can explain.
    const Eigen::Isometry3d resultCTToRoom = this->CTToRoom(end.pose);
    std::vector<RegistrationView> wholeViews;
    for (size_t v = 0; v < this->Working.ranked.size(); ++v)
    {
      RegistrationView item = this->Working.ranked[v];
      if (item.mask.empty())
        item.mask.assign(item.xray.size(), 1);
      if (settings.coverageMask && !this->Result.endFaces.empty())
        AndCoverage(item, *this->Coverage, resultCTToRoom, this->Result.endFaces[v].facesToLeaveOut);
      wholeViews.push_back(item);
    }
    // Where no ray meets the CT there is only what it does not hold: open field shaded by the
    // heel effect and scatter, a couch. Beyond the outline's margin that is no evidence about
    // the pose, and it flattened the peak of a rounded head along roll (Algorithms.md).
    // Its rays are the DRRs at the result, every pixel of them (below, "at the result").
    ShadowRays atTheResult;
    atTheResult.cost = &this->Cost;
    if (this->Result.boneOnly)
      AndShadowLessCuts(wholeViews, this->Volume, resultCTToRoom, settings.boneShadowFineMarginMM, this->CutPoints,
        settings.device, &atTheResult);
    else
      AndShadow(wholeViews, this->Volume, resultCTToRoom, settings.heldOutShadowMarginMM, settings.device, &atTheResult);
    this->Result.drrCount += static_cast<long long>(wholeViews.size());
    const int heldOutDivisor = this->Pyramid ? 2 : 1;
    const std::unique_ptr<StereoSimilarity> heldOut = this->Similarity(this->VolumeFor(heldOutDivisor),
      Shrunk(wholeViews, heldOutDivisor), { settings.equalizedLevels, settings.heldOutHighPassMM, this->CorrelationMM });
    // The polish's probes, a step either side of where it started, are the landscape's own
    // (landscapeNear): their curvature is read, not measured again around the polished end.
    this->Result.uncertainty = this->PolishProbes
      ? UncertaintyFromProbes(*this->PolishProbes, end.value)
      : MeasureUncertainty(this->Traced(*this->Fine, &this->Result.evaluations), end.pose, end.value, settings);
    this->Trace.Begin("held-out check", heldOutDivisor, StageKind::Landscape);
    const PeakLeads leads = MeasurePeakLeads(this->Traced(*heldOut, &this->Result.evaluations), end.pose, settings);
    this->Result.peakMargin = leads.margin;
    this->Result.peakLeads = leads.leads;
    this->Result.drrCount += heldOut->RenderedDRRs();
    // Equalised levels on both sides: the DRR's transmission at 12 bits is quantised where a
    // thick body lets little through, and its steps would be edges.
    for (size_t v = 0; v < wholeViews.size(); ++v)
      wholeViews[v].xray = this->UnsmoothedViews[v].xray;
    this->Trace.Begin("at the result", 1, StageKind::Landscape);
    const std::unique_ptr<StereoSimilarity> atFullSize = this->Similarity(this->Volume, wholeViews, { true, 0.0 });
    // Its DRRs are the shadow's line integrals on its pixels (the same rays, every one cast):
    // measured, not rendered again.
    for (size_t v = 0; v < wholeViews.size(); ++v)
      for (size_t i = 0; i < wholeViews[v].mask.size(); ++i)
        if (!wholeViews[v].mask[i])
          atTheResult.integrals[v][i] = 0.0f;
    const auto measured = [this, &atFullSize, &atTheResult](const Pose&)
    {
      const double value = this->Trace.Traced(atFullSize->ObjectiveOf(atTheResult.integrals));
      ++this->Result.evaluations;
      this->Progress.Evaluated(value);
      return value;
    };
    const EdgeDistances edges = MeasureEdges(measured, *atFullSize, end.pose, this->Isocenter);
    this->Result.edgeDistanceMM = edges.mm;
    this->Result.edgeDistanceShiftedMM = edges.shiftedMM;
    // The refinement's objective and DRRs at the result: what the gate reads. After the polish
    // its last evaluation was the result's, and no other pose has been evaluated on it since.
    this->Result.objective = this->PolishProbes ? end.value : this->Traced(*this->Fine, &this->Result.evaluations)(end.pose);
    this->Trace.End();
  }

  /** The gate's reading in the result, with each view's DRR and mask at the result. */
  void Keep(const GateOutcome& gate)
  {
    for (size_t v = 0; v < gate.views.size(); ++v)
    {
      this->Result.drrs.push_back(this->Fine->LastDRR(v));
      this->Result.masks.push_back(this->Masked[v].mask);
      const ViewEvidence& view = gate.views[v];
      this->Result.explained.push_back(view.explained);
      this->Result.uncovered.push_back(view.uncovered);
      this->Result.viewResidualMM.push_back(view.residualMM);
      this->Result.halvesApartMM.push_back(view.halvesApartMM);
    }
    this->Result.failures = gate.failures;
    this->Result.ok = this->Result.failures.empty();
  }

  /** Step 4b: what each view says at the result (MeasureView, one thread per view: each reads only
   *  its own images), and the gate's verdict on all the evidence. */
  GateOutcome Judge(const Refined& refined)
  {
    const StereoRegistrationSettings& settings = this->Settings;
    const PoseOptimizerResult& end = refined.ends.front();
    GateEvidence evidence;
    evidence.ambiguous = refined.ambiguous;
    if (this->Result.boneOnly)
    {
      evidence.restartsApartMM = this->Result.restartsApartMM;
      evidence.restartsApartDegrees = this->Result.restartsApartDegrees;
    }
    evidence.misalignment = end.pose; // the gate's motion limits: about the same centre as the start
    evidence.start = settings.initialPose;
    evidence.converged = end.converged;
    evidence.stopReason = end.stopReason;
    evidence.searchApartMM = this->Result.searchDisagreementMM;
    evidence.searchApartDegrees = this->Result.searchDisagreementDegrees;
    evidence.uncertainty = this->Result.uncertainty;
    evidence.peakMargin = this->Result.peakMargin;
    GateOutcome gate;
    gate.views.resize(this->Masked.size());
    vtkSMPTools::For(size_t{ 0 }, this->Masked.size(), size_t{ 1 },
      [&](size_t first, size_t last)
      {
        JointHistogram histogram(settings.bins);
        for (size_t v = first; v < last; ++v)
          gate.views[v] = MeasureView(*this->Fine, v, this->Working.openFieldBright[v], this->Isocenter, settings, histogram);
      });
    evidence.views = gate.views;
    gate.failures = CheckQuality(evidence, settings);
    return gate;
  }

  const AttenuationVolume& Volume;
  const Eigen::Isometry3d PlannedCTToRoom;
  const Eigen::Vector3d RoomIsocenter;
  Eigen::Vector3d Isocenter; ///< what poses turn about: the room's isocentre, or a bone's centre
  StereoRegistrationSettings Settings; ///< the requested ones, or a bone's (ForBone)
  ProgressReporter Progress;
  SimilarityCost Cost; ///< every similarity's DRRs and times
  StageTrace Trace;
  StereoRegistrationResult Result;
  bool Pyramid = false;
  double CorrelationMM = 0.0;
  std::vector<RegistrationView> UnsmoothedViews, InputViews;
  std::unique_ptr<AttenuationVolume> HalfVolume;
  std::vector<Eigen::Vector3d> CutPoints;
  WorkingXRays Working;
  std::unique_ptr<CTCoverage> Coverage;
  std::vector<std::vector<uint8_t>> Content; ///< each view's entropy mask AND ROI
  std::vector<RegistrationView> Masked;      ///< the ranked views with their validity masks
  std::unique_ptr<StereoSimilarity> PreAlignment, Fine;
  /** The searches' similarities by image divisor and high-pass (ScheduledStage::highPassMM). */
  std::map<std::pair<int, double>, std::unique_ptr<StereoSimilarity>> Searches;
  std::map<int, std::unique_ptr<StereoSimilarity>> ShrunkRefinements; ///< the refinement's objective on shrunk images, by divisor
  /** The vertex polish's last round's evaluations, where it ran: the landscape's curvature. */
  std::optional<AxisProbes> PolishProbes;
  size_t NextStage = 0; ///< the first stage of the schedule not yet run
};

/** What RegisterStereo refuses before any work: views that do not match their panels, fewer
 *  than two, gate limits out of range. */
void CheckRegistrationInputs(const std::vector<RegistrationView>& givenViews, const StereoRegistrationSettings& requested)
{
  if (givenViews.size() < 2)
  {
    throw InputError("registration", "a stereo registration needs at least two views");
  }
  for (const RegistrationView& item : givenViews)
  {
    const size_t pixels = static_cast<size_t>(item.view.Columns()) * item.view.Rows();
    if (item.xray.size() != pixels || (!item.mask.empty() && item.mask.size() != pixels))
      throw InputError("view " + item.view.name, "the X-ray (" + std::to_string(item.xray.size()) + " pixels) or its ROI (" +
          std::to_string(item.mask.size()) + ") does not match the geometry's " + std::to_string(item.view.Columns()) + "x" +
          std::to_string(item.view.Rows()) + " panel");
  }
  ValidateGateLimits(requested);
}

} // namespace

StereoRegistrationResult RegisterStereo(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& roomIsocenter, const std::vector<RegistrationView>& givenViews, const StereoRegistrationSettings& requested,
  const RegistrationObserver& observer)
{
  CheckRegistrationInputs(givenViews, requested);
  return StereoRegistrationRun(volume, plannedCTToRoom, roomIsocenter, givenViews, requested, observer).Run();
}

/** The run, under the name the header declares. */
class StereoRegistrationInStages::Run : public StereoRegistrationRun
{
  using StereoRegistrationRun::StereoRegistrationRun;
};

StereoRegistrationInStages::StereoRegistrationInStages(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& isocenter, const std::vector<RegistrationView>& views, const StereoRegistrationSettings& settings,
  const RegistrationObserver& observer)
{
  CheckRegistrationInputs(views, settings);
  this->Stages = std::make_unique<Run>(volume, plannedCTToRoom, isocenter, views, settings, observer);
}

StereoRegistrationInStages::~StereoRegistrationInStages() = default;

PreAlignedCT StereoRegistrationInStages::PreAlign()
{
  this->Stages->RunStages(StageKind::PreAlignment);
  return this->Stages->PreAligned();
}

double StereoRegistrationInStages::HighPassedObjectiveOf(const AttenuationVolume& other, const Pose& pose, int rounds)
{
  return this->Stages->HighPassedObjectiveOf(other, pose, rounds);
}

StereoRegistrationResult StereoRegistrationInStages::Finish()
{
  this->Stages->RunStages();
  return this->Stages->Finish();
}

} // namespace xp
