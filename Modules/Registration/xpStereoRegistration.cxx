#include "xpStereoRegistration.h"

#include "xpBoneCut.h"
#include "xpCTCoverage.h"
#include "xpEdgeAgreement.h"
#include "xpError.h"
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
#include <memory>

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

/** Starts a stage of the 6-DOF search; the previous one, if any, ends here. */
/** When the running stage began, and what the similarities had cost by then. */
struct StageStart
{
  const SimilarityCost& sink; ///< the registration's running total
  Clock::time_point time{};
  SimilarityCost cost;
  std::clock_t cpu = 0; ///< the process's CPU time, all threads
};

/** Closes the running stage (its wall time and cost), if any. */
void EndStage(StereoRegistrationResult& result, const StageStart& stageStart)
{
  if (result.stages.empty())
    return;
  result.stages.back().seconds = std::chrono::duration<double>(Clock::now() - stageStart.time).count();
  result.stages.back().cost = stageStart.sink - stageStart.cost;
  result.stages.back().cpuSeconds = static_cast<double>(std::clock() - stageStart.cpu) / CLOCKS_PER_SEC;
}

void BeginStage(StereoRegistrationResult& result, const char* name, StageStart& stageStart)
{
  EndStage(result, stageStart);
  stageStart.time = Clock::now();
  stageStart.cost = stageStart.sink;
  stageStart.cpu = std::clock();
  result.stages.push_back({ name, static_cast<int>(result.objectiveTrace.size()) });
}

double Traced(StereoRegistrationResult& result, double objective)
{
  result.objectiveTrace.push_back(objective);
  return objective;
}

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

namespace
{

bool Agree(const Pose& a, const Pose& b, const StereoRegistrationSettings& settings)
{
  return TranslationApart(a, b) <= settings.maxSearchDisagreementMM &&
    RotationApart(a, b) <= settings.maxSearchDisagreementDegrees;
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

/** ANDs into each view's mask the shadow of the volume at `ctToRoom` (rays with any
 *  attenuation), widened by `marginMM` on the panel. */
void AndShadow(std::vector<RegistrationView>& views, const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  double marginMM, ComputeDevice device)
{
  for (RegistrationView& item : views)
  {
    const int columns = item.view.Columns(), rows = item.view.Rows();
    std::vector<float> integrals(static_cast<size_t>(columns) * rows, 0.0f);
    RayCastSettings rayCast;
    rayCast.device = device;
    RenderLineIntegrals(volume, ctToRoom, item.view.source, DetectorGrid::TopRowFirst(item.view), nullptr, integrals.data(), rayCast);
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
  }
}

/** AndShadow, then the pixels within the same margin of the shadow of the bone's cut faces left out
 *  (xpBoneCut.h): there the X-ray shows the bone running on where its DRR ends. */
void AndShadowLessCuts(std::vector<RegistrationView>& views, const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  double marginMM, const std::vector<Eigen::Vector3d>& cutPoints, ComputeDevice device)
{
  AndShadow(views, volume, ctToRoom, marginMM, device);
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

void RecordDisagreement(StereoRegistrationResult& result, const PoseOptimizerResult& a, const PoseOptimizerResult& b)
{
  result.searchDisagreementMM = TranslationApart(a.pose, b.pose);
  result.searchDisagreementDegrees = RotationApart(a.pose, b.pose);
  result.searchObjectiveRatio = std::min(a.value, b.value) / std::max(a.value, b.value);
}

} // namespace

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

  const RegistrationObserver& Observer;
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
};

ValidityMasks BuildValidityMasks(const std::vector<RegistrationView>& views,
  const std::vector<std::vector<uint16_t>>& maskSource, const StereoRegistrationSettings& settings,
  const CTCoverage& coverage, const Eigen::Isometry3d& ctToRoom, StereoRegistrationResult& result)
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
      result.entropyMaps.push_back(std::move(entropy.entropy));
    }
    else
    {
      mask = roi ? item.mask : std::vector<uint8_t>(item.xray.size(), 1);
    }
    RegistrationView& masked = masks.masked[v];
    masked.mask = std::move(mask);
    masks.content.push_back(masked.mask);
    if (settings.coverageMask)
      AndCoverage(masked, coverage, ctToRoom, result.endFaces[v].facesToLeaveOut);
    const long long valid = std::count(masked.mask.begin(), masked.mask.end(), 1);
    if (valid == 0)
    {
      throw InputError("view " + item.view.name, "the validity mask is empty: nothing left to register");
    }
    result.validFraction.push_back(static_cast<double>(valid) / masked.mask.size());
  }
  return masks;
}

/** The refinement's optimiser: steps and tolerances ten times finer than the accuracy asked. */
PoseOptimizerSettings RefinementSettings(const StereoRegistrationSettings& settings)
{
  PoseOptimizerSettings fine;
  fine.method = settings.refinementOptimizer;
  fine.maxEvaluations = settings.maxEvaluations;
  // No restart here: the coarse search's restarts already escaped the valley's stalls, and on 14
  // pelvis trials a restart of the refinement cost a third of the time and changed the median
  // mTRE by 0.006 mm.
  fine.maxRestarts = 0;
  fine.initialStepMM = 0.25;
  fine.initialStepDegrees = 0.15;
  fine.toleranceMM = 0.05;
  fine.toleranceDegrees = 0.03;
  return fine;
}

/**
 * Step 3a: the coarse search, run twice, the second time from the pre-alignment moved along the
 * roll/lateral valley (roll turns about the axis perpendicular to both central rays, which two
 * views see least): a landscape with two optima there cannot give a trustworthy result. Two
 * independent starts, not the first end moved: a search from the first end can stall on the
 * valley's flat floor short of it. Returns the ends to refine, better first.
 */
std::vector<Pose> SearchFromTwoStarts(StereoSimilarity& similarity, StereoSimilarity* quarter, const Pose& start,
  const StereoRegistrationSettings& settings, bool halfResolution, StereoRegistrationResult& result, ProgressReporter& progress,
  StageStart& stageStart)
{
  PoseOptimizerSettings searchSettings = RefinementSettings(settings);
  searchSettings.method = settings.optimizer;
  searchSettings.initialStepMM = 2.0;
  searchSettings.initialStepDegrees = 1.0;
  searchSettings.toleranceMM = 0.1;
  searchSettings.toleranceDegrees = 0.05;
  searchSettings.maxRestarts = 3; // stalls happen in the long coarse travel; restarts are cheap here
  // Every evaluation, at either size, is traced and heard.
  const auto tracedOn = [&](StereoSimilarity* measure)
  {
    return [&result, &progress, measure](const Pose& p)
    {
      const double value = Traced(result, measure->Evaluate(p));
      progress.Evaluated(value);
      return value;
    };
  };
  const auto objective = tracedOn(&similarity);
  const auto quarterObjective = tracedOn(quarter);
  // The travel on quarter-size images (2 mm pixels at the isocentre at 512x384) stops at twice
  // the search's tolerances; the half-size search goes on from it with a quarter of its simplex.
  PoseOptimizerSettings travelSettings = searchSettings;
  travelSettings.toleranceMM = 2.0 * searchSettings.toleranceMM;
  travelSettings.toleranceDegrees = 2.0 * searchSettings.toleranceDegrees;
  // One search: its travel at quarter size when there is one, its end at half (or full) size.
  const auto search = [&](const Pose& from, const char* travelName, const char* name, const PoseOptimizerSettings& endSettings)
  {
    Pose travelled = from;
    int travelEvaluations = 0;
    PoseOptimizerSettings own = endSettings;
    if (quarter)
    {
      BeginStage(result, travelName, stageStart);
      const PoseOptimizerResult travel = MaximizePose(quarterObjective, from, travelSettings);
      travelled = travel.pose;
      travelEvaluations = travel.evaluations;
      own.initialStepMM = 0.25 * endSettings.initialStepMM;
      own.initialStepDegrees = 0.25 * endSettings.initialStepDegrees;
    }
    BeginStage(result, name, stageStart);
    PoseOptimizerResult found = MaximizePose(objective, travelled, own);
    found.evaluations += travelEvaluations;
    return found;
  };
  const char* name = halfResolution ? "coarse search (half resolution)" : "coarse search";
  progress.Begin(name, 0.1, 0.45);
  PoseOptimizerResult first = search(start, "coarse search (quarter resolution)", name, searchSettings);
  result.evaluations += first.evaluations;
  if (!(settings.maxSearchDisagreementMM > 0.0))
    return { first.pose };
  Pose moved = start;
  moved.roll += 1.5;
  moved.translation[0] += 1.5;
  progress.Begin("second coarse search", 0.45, 0.7);
  // Once the second search stands where the first ended, about as high, it has found the same
  // optimum: the rest of its travel would only polish it. (Judged at the size the first ended:
  // the quarter-size travel's objective is on another scale.)
  PoseOptimizerSettings secondSettings = searchSettings;
  secondSettings.stopWhen = [&](const Pose& pose, double value)
  { return Agree(pose, first.pose, settings) && value >= settings.sameOptimumObjectiveRatio * first.value; };
  PoseOptimizerResult second = search(moved, "second coarse search (quarter resolution)", "second coarse search", secondSettings);
  result.evaluations += second.evaluations;
  if (second.value > first.value)
    std::swap(first, second);
  RecordDisagreement(result, first, second);
  // Ends far apart matter only when both are about as good; a clearly worse end is a local
  // optimum that the better search left behind. Comparable ends far apart are refined both.
  if (!Agree(first.pose, second.pose, settings) && second.value >= settings.refineBothObjectiveRatio * first.value)
    return { first.pose, second.pose };
  return { first.pose };
}

/**
 * Step 4a: the landscape around the result. Per axis, the refinement's objective at poses
 * `landscapeNear` either side gives its curvature c = (2 f0 - f+ - f-) / h^2, and the uncertainty
 * is the distance over which a parabola of that curvature falls by 5 % of f0: sqrt(0.1 f0 / c);
 * infinite where a neighbour scores higher (no maximum). Then a check the optimiser never saw:
 * `heldOut` (the ROI and the CT's coverage without the entropy mask, half size) at the result
 * and at poses `landscapeCheck` either side along each axis (same ranks and high-pass as the
 * refinement). The right anatomy peaks at the
 * right pose under any reasonable similarity; a pose that only the optimised, masked objective
 * favours (another patient's X-rays, an anatomy no pose fits) is beaten by a neighbour there.
 * The peak margin is the least relative lead of the result over the translated neighbours: the
 * turned ones are recorded, not judged, since smooth shading (the heel effect) moves a rounded
 * head's held-out peak along roll by more than the 1.5 degree probe while its result is right to
 * 0.3 degree (Algorithms.md, "A verdict...", 2).
 */
void MeasureLandscape(const std::function<double(const Pose&)>& objective, StereoSimilarity& heldOut, const Pose& result,
  double atResult, const StereoRegistrationSettings& settings, StereoRegistrationResult& out)
{
  const std::array<double, 6> center = result.Parameters();
  const auto moved = [&](int axis, double step)
  {
    std::array<double, 6> p = center;
    p[axis] += step;
    return Pose::FromParameters(p.data());
  };
  for (int a = 0; a < 6; ++a)
  {
    const double h = a < 3 ? settings.landscapeNearMM : settings.landscapeNearDegrees;
    const double below = objective(moved(a, -h)), above = objective(moved(a, h));
    const double curvature = (2.0 * atResult - below - above) / (h * h);
    const bool peak = atResult >= below && atResult >= above && curvature > 0.0 && atResult > 0.0;
    out.uncertainty[a] = peak ? std::sqrt(0.1 * atResult / curvature) : std::numeric_limits<double>::infinity();
  }
  const double check = heldOut.Evaluate(result);
  out.peakMargin = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 6; ++a)
    for (double sign : { -1.0, 1.0 })
    {
      const double neighbour = heldOut.Evaluate(moved(a, sign * (a < 3 ? settings.landscapeCheckMM : settings.landscapeCheckDegrees)));
      const double lead = check > 0.0 ? (check - neighbour) / check : -1.0;
      out.peakLeads[2 * a + (sign > 0.0 ? 1 : 0)] = lead;
      if (a < 3 || settings.heldOutJudgesTurns)
        out.peakMargin = std::min(out.peakMargin, lead);
    }
  out.drrCount += heldOut.RenderedDRRs();
}

/** How far the DRR's edges move for the edge measure's chance level (mm at the isocentre). */
constexpr double EdgeShiftMM = 3.0;

/** Step 4c: the DRR's edges against the X-ray's at the result, at full size over the held-out
 *  check's region (the ROI, the CT's coverage and its shadow; xpEdgeAgreement.h), both as
 *  equalised levels; the X-ray as the reader sees it in the overlay, before its smoothing (a
 *  thin rim blurred in one image only puts its edges a pixel apart). Not a gate check: a figure
 *  to read beside the overlay. */
void MeasureEdges(StereoSimilarity& atFullSize, const Pose& pose, const Eigen::Vector3d& isocenter, StereoRegistrationResult& result)
{
  atFullSize.Evaluate(pose);
  for (size_t v = 0; v < atFullSize.Views().size(); ++v)
  {
    const RegistrationView& item = atFullSize.Views()[v];
    const double mmPerPixel = item.view.pixelSpacing[0] * (item.view.source - isocenter).norm() / item.view.SourceToPanelDistance();
    const int shift = std::max(1, static_cast<int>(std::lround(EdgeShiftMM / mmPerPixel)));
    const EdgeAgreement edges =
      MeasureEdgeAgreement(atFullSize.XRayLevels(v), atFullSize.LastDRRLevels(v), item.mask, item.view.Columns(), item.view.Rows(), shift);
    result.edgeDistanceMM.push_back(edges.medianPixels < 0.0 ? -1.0 : edges.medianPixels * mmPerPixel);
    result.edgeDistanceShiftedMM.push_back(edges.shiftedMedianPixels < 0.0 ? -1.0 : edges.shiftedMedianPixels * mmPerPixel);
  }
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
  // Each half of the valid pixels (left and right of their median column, then above and below
  // their median row) registered on its own: a rigid fit of the right anatomy leaves both where
  // the whole is, while an anatomy that no rigid pose fits (another person, or one 10 % longer)
  // pulls the halves apart, each towards its own part. The medians, not the view's centre: a
  // bone's shadow may lie anywhere in a large field. Their searches start with wider steps than
  // the residual's (halvesSearchStepMM): each half's own optimum may lie millimetres away.
  const int columns = item.view.Columns(), rows = item.view.Rows();
  std::vector<int> validColumns, validRows;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (item.mask[static_cast<size_t>(r) * columns + c])
        validColumns.push_back(c), validRows.push_back(r);
  if (validColumns.empty())
    return evidence;
  std::nth_element(validColumns.begin(), validColumns.begin() + validColumns.size() / 2, validColumns.end());
  std::nth_element(validRows.begin(), validRows.begin() + validRows.size() / 2, validRows.end());
  const int medianColumn = validColumns[validColumns.size() / 2], medianRow = validRows[validRows.size() / 2];
  for (int split = 0; split < 2; ++split)
  {
    Eigen::Vector2d shifts[2];
    for (int side = 0; side < 2; ++side)
    {
      std::vector<uint8_t> half = item.mask;
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < columns; ++c)
          if ((split == 0 ? c >= medianColumn : r >= medianRow) != (side == 1))
            half[static_cast<size_t>(r) * columns + c] = 0;
      shifts[side] = Register2D(fine.XRayLevels(v), fine.LastDRRLevels(v), columns, rows, item.view.Project(isocenter),
        half.data(), settings.bins, settings.halvesSearchStepMM / mmPerPixel).shift;
    }
    evidence.halvesApartMM = std::max(evidence.halvesApartMM, (shifts[0] - shifts[1]).norm() * mmPerPixel);
  }
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
 * mask took smoothed noise for structure (the processed pelvis kept 30 k pixels whose DRR
 * explained 4-5 % of the X-ray).
 */
double NeighbourNoiseShare(double sigmaPixels)
{
  return sigmaPixels > 0.0 ? std::sqrt(1.0 - std::exp(-1.0 / (4.0 * sigmaPixels * sigmaPixels))) : 1.0;
}

/** A smoothing sd under this many pixels leaves an image as it is (its kernel's side weights
 *  are under 0.4 %): skipped. */
constexpr double LeastSmoothingPixels = 0.3;

/** The views with each X-ray replaced by its 3x3 median (Median3x3). */
std::vector<RegistrationView> MedianFiltered(std::vector<RegistrationView> views)
{
  for (RegistrationView& item : views)
    item.xray = Median3x3(item.xray, item.view.Columns(), item.view.Rows());
  return views;
}

/**
 * The X-rays smoothed to the CT's resolution (GaussianSmoothed,
 * StereoRegistrationSettings::xraySmoothingPerVoxel): what every later step sees. Ranked X-rays
 * are smoothed at the largest power-of-two scale that fits 16 bits: ranks do not change with
 * scale, and the averages keep the levels between the stored ones.
 */
std::vector<RegistrationView> SmoothedToTheCT(std::vector<RegistrationView> views, const AttenuationVolume& volume,
  const Eigen::Vector3d& roomIsocenter, const StereoRegistrationSettings& settings, StereoRegistrationResult& result)
{
  for (RegistrationView& item : views)
  {
    const int columns = item.view.Columns(), rows = item.view.Rows();
    const double sigma =
      settings.xraySmoothingPerVoxel * volume.MinimumSpacing() / PixelSpacingAtIsocenter(item.view, roomIsocenter);
    if (!(sigma >= LeastSmoothingPixels && std::isfinite(sigma)) || item.xray.empty())
    {
      result.xraySmoothingPixels.push_back(0.0);
      continue;
    }
    int scale = 1;
    const int largest = std::max<int>(1, *std::max_element(item.xray.begin(), item.xray.end()));
    while (settings.rankedXRays && 2 * scale * largest <= 65535)
      scale *= 2;
    item.xray = GaussianSmoothed(item.xray, columns, rows, sigma, scale);
    result.xraySmoothingPixels.push_back(sigma);
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
};

/** Pearson correlation of an X-ray's levels with its DRR over the valid pixels (empty mask: all). */
double CorrelationWithDRR(const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr, const std::vector<uint8_t>& mask)
{
  return PearsonCorrelation(xray.data(), drr.data(), mask.empty() ? nullptr : mask.data(), xray.size());
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
  ComputeDevice device, StereoRegistrationResult& result)
{
  WorkingXRays working;
  working.ranked = views;
  for (RegistrationView& item : working.ranked)
    item.xray = EqualizedLevels(item.xray, item.mask);
  StereoSimilarity probe(volume, plannedCTToRoom, isocenter, AtCoarseSize(working.ranked, pyramid), 32, { false, 0.0 });
  probe.SetDevice(device);
  probe.Evaluate(start);
  result.drrCount += probe.RenderedDRRs();
  for (size_t v = 0; v < working.ranked.size(); ++v)
  {
    RegistrationView& item = working.ranked[v];
    const double correlation = CorrelationWithDRR(probe.Views()[v].xray, probe.LastDRR(v), probe.Views()[v].mask);
    result.xrayCorrelation.push_back(correlation);
    result.xrayInverted.push_back(correlation < 0.0);
    if (correlation < 0.0)
      for (uint16_t& level : item.xray)
        level = static_cast<uint16_t>(RankLevels - 1 - level);
    working.noiseScaled.push_back(NoiseScaledLevels(item.xray, item.view.Columns(), item.view.Rows(), item.mask,
      EntropyLevelsPerNoiseSigma * NeighbourNoiseShare(result.xraySmoothingPixels[v]), 8.0));
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
  settings.heldOutJudgesTurns = true;
  settings.minPeakMargin = settings.boneMinPeakMargin;
  // Half a bone is an end and half a shaft, which slides along itself: searched with wide steps
  // the metacarpal's halves ended 1.2-9.8 mm apart (0.5 mm steps: mostly under 1 mm). The
  // halves check of a bone stays local; its restarts test the pose.
  settings.halvesSearchStepMM = 0.5 * settings.maxViewResidual;
  settings.maxUncovered = 1.0;
  settings.minValidFraction = 0.0;
  return settings;
}

} // namespace

bool OuterSurfaceIsBone(const AttenuationVolume& volume)
{
  const Eigen::Vector3i d = volume.StoredDimensions();
  const auto at = [&](int i, int j, int k)
  { return i < 0 || j < 0 || k < 0 || i >= d[0] || j >= d[1] || k >= d[2] ? 0.0f : volume.StoredAt(i, j, k); };
  std::vector<float> surface;
  // 32 slices tell the surface's median as well as all of them: a body CT's full scan cost 0.5 s
  // of every registration.
  const int sliceStep = std::max(1, d[2] / 32);
  for (int k = 0; k < d[2]; k += sliceStep)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i)
      {
        const float mu = volume.StoredAt(i, j, k);
        // Voxels on the stored box's faces beside the CT's own faces are cut, not surface.
        if (mu > 0.0f && i > 0 && j > 0 && k > 0 && i + 1 < d[0] && j + 1 < d[1] && k + 1 < d[2] &&
          (at(i - 1, j, k) == 0.0f || at(i + 1, j, k) == 0.0f || at(i, j - 1, k) == 0.0f || at(i, j + 1, k) == 0.0f ||
            at(i, j, k - 1) == 0.0f || at(i, j, k + 1) == 0.0f))
          surface.push_back(mu);
      }
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

StereoRegistrationResult RegisterStereo(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& roomIsocenter, const std::vector<RegistrationView>& givenViews, const StereoRegistrationSettings& requested,
  const RegistrationObserver& observer)
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
  StereoRegistrationResult result;
  result.device = ComputeDeviceDescription(requested.device);
  result.boneOnly = requested.detectBoneOnly && OuterSurfaceIsBone(volume);
  // A bone turns about its own centre: about an isocentre some centimetres away, each turn would
  // also move it, and the optimiser's steps and the landscape's probes would mix the two. Poses
  // are about the volume's centre at the start inside, and about the isocentre outside.
  Eigen::Vector3d isocenter = roomIsocenter;
  StereoRegistrationSettings settings = result.boneOnly ? ForBone(requested, volume) : requested;
  const std::vector<RegistrationView> unsmoothedViews = settings.medianFilter ? MedianFiltered(givenViews) : givenViews;
  const std::vector<RegistrationView> inputViews = SmoothedToTheCT(unsmoothedViews, volume, roomIsocenter, settings, result);
  if (result.boneOnly)
  {
    isocenter = MisalignedCTToRoom(plannedCTToRoom, requested.initialPose, roomIsocenter) * volume.IndexToCT() *
      (0.5 * (volume.Dimensions().cast<double>() - Eigen::Vector3d::Ones()));
    settings.initialPose = Pose::FromTransform(requested.initialPose.ToTransform(roomIsocenter), isocenter);
  }
  const auto aboutIsocenter = [&](const Pose& pose) { return Pose::FromTransform(pose.ToTransform(isocenter), roomIsocenter); };
  ProgressReporter progress(observer);
  SimilarityCost cost; // every similarity below adds its DRRs and times here
  const bool pyramid = settings.pyramid && inputViews[0].view.Columns() >= 256 && inputViews[0].view.Rows() >= 192;
  const double correlationMM = result.boneOnly ? settings.boneCorrelationHighPassMM : 0.0;

  // 1. Pre-alignment (5+1 DOF) with the user ROIs only. Half-size images are rendered from a
  // half-resolution CT along each axis whose voxels stay fine enough: their pixels are twice as
  // wide, and a ray takes half the samples (a CT of thick slices halves its pixels only).
  Clock::time_point start = Clock::now();
  std::clock_t cpuStart = std::clock();
  progress.Begin("pre-alignment", 0.0, 0.1);
  const Eigen::Vector3i halving = HalvingFactors(volume, settings.maxHalvedVoxelMM);
  const bool halveCT = pyramid && halving != Eigen::Vector3i::Ones();
  const AttenuationVolume halfVolume = halveCT ? volume.Halved(halving) : AttenuationVolume();
  const AttenuationVolume& coarseVolume = halveCT ? halfVolume : volume;
  result.start = requested.initialPose;
  std::vector<RegistrationView> shadowed;
  const std::vector<Eigen::Vector3d> cutPoints =
    result.boneOnly && settings.leaveOutBoneCuts ? CutFacePoints(volume) : std::vector<Eigen::Vector3d>();
  result.cutFaceVoxels = static_cast<long long>(cutPoints.size());
  if (result.boneOnly)
  {
    shadowed = inputViews;
    AndShadowLessCuts(shadowed, coarseVolume, MisalignedCTToRoom(plannedCTToRoom, settings.initialPose, isocenter),
      settings.boneShadowSearchMarginMM, cutPoints, settings.device);
  }
  const std::vector<RegistrationView>& startViews = result.boneOnly ? shadowed : inputViews;
  WorkingXRays working;
  if (settings.rankedXRays)
    working = RankedXRays(startViews, coarseVolume, plannedCTToRoom, isocenter, settings.initialPose, pyramid, settings.device, result);
  else
  {
    working.ranked = startViews;
    for (const RegistrationView& item : startViews)
      working.openFieldBright.push_back(item.xray);
    working.noiseScaled = working.openFieldBright;
  }
  const std::vector<RegistrationView>& views = working.ranked;
  const std::vector<RegistrationView> coarseViews = AtCoarseSize(views, pyramid);
  StereoSimilarity coarse(coarseVolume, plannedCTToRoom, isocenter, coarseViews, settings.bins, { settings.equalizedLevels, 0.0 });
  coarse.SetDevice(settings.device);
  coarse.SetCostSink(&cost);
  // A bone's start is already near (a given pose, the previous frame's, or the global search's,
  // refined on both views at once): the 2D/2D steps, each view alone in a field of other bones,
  // turned the third metacarpal 25 degrees away from a good start.
  if (result.boneOnly)
  {
    result.prealignment.pose = settings.initialPose;
    result.prealignment.objective = coarse.Evaluate(settings.initialPose);
  }
  else
    result.prealignment = PreAlign(coarse, settings.initialPose, isocenter);
  result.drrCount += coarse.RenderedDRRs();
  result.prealignSeconds = Since(start);
  result.prealignCPUSeconds = CPUSince(cpuStart);
  result.prealignCost = cost;

  // 2. Entropy masks AND ROIs AND the CT's coverage at the pre-alignment.
  start = Clock::now();
  cpuStart = std::clock();
  const CTCoverage coverage(volume, settings.coverageMarginMM);
  if (settings.coverageMask)
  {
    std::vector<std::vector<uint16_t>> asTheyCame;
    for (const RegistrationView& item : AtCoarseSize(inputViews, pyramid))
      asTheyCame.push_back(item.xray);
    result.endFaces = MeasureEndFaces(coarse, asTheyCame, result.prealignment.pose, coverage,
      MisalignedCTToRoom(plannedCTToRoom, result.prealignment.pose, isocenter), settings.coverageMinExcess);
  }
  ValidityMasks masks = BuildValidityMasks(
    views, working.noiseScaled, settings, coverage, MisalignedCTToRoom(plannedCTToRoom, result.prealignment.pose, isocenter), result);
  std::vector<RegistrationView>& masked = masks.masked;
  result.maskSeconds = Since(start);
  result.maskCPUSeconds = CPUSince(cpuStart);

  // 3. 6-DOF alignment with masked DRRs: the coarse search (half resolution), then each end it
  // leaves refined at full resolution.
  start = Clock::now();
  StageStart stageStart{ cost }; // set by BeginStage
  std::vector<Pose> searchEnds;
  {
    const std::vector<RegistrationView> coarseSearch = AtCoarseSize(masked, pyramid);
    StereoSimilarity searchSimilarity(coarseVolume, plannedCTToRoom, isocenter, coarseSearch, settings.bins,
      { settings.equalizedLevels, 0.0, correlationMM });
    searchSimilarity.SetDevice(settings.device);
    result.searchRenderStride = settings.searchRenderStride > 0
      ? RenderStride{ settings.searchRenderStride, settings.searchRenderStride }
      : RenderStrideFor(coarseVolume, coarseSearch, plannedCTToRoom, isocenter);
    searchSimilarity.SetRenderStride(result.searchRenderStride);
    searchSimilarity.SetCostSink(&cost);
    std::unique_ptr<StereoSimilarity> quarter;
    if (pyramid && settings.quarterSizeTravel && coarseSearch[0].view.Columns() >= 256 && coarseSearch[0].view.Rows() >= 192)
    {
      quarter = std::make_unique<StereoSimilarity>(coarseVolume, plannedCTToRoom, isocenter, AtCoarseSize(coarseSearch, true),
        settings.bins, SimilarityLevels{ settings.equalizedLevels, 0.0, correlationMM });
      quarter->SetDevice(settings.device);
      quarter->SetCostSink(&cost);
    }
    searchEnds =
      SearchFromTwoStarts(searchSimilarity, quarter.get(), result.prealignment.pose, settings, pyramid, result, progress, stageStart);
    result.drrCount += searchSimilarity.RenderedDRRs() + (quarter ? quarter->RenderedDRRs() : 0);
  }
  // A stall on the half-size images' flatter valley floor comes back at full resolution or shows
  // its lower objective: only ends that stay apart there and are equally good within
  // ambiguousObjectiveRatio mean the images do not fix the pose.
  // The pre-alignment leaves the angles the views see least a few degrees off (pitch of 3.6
  // degrees moves a pelvis CT's end faces 3.5 mm at 56 mm from the isocentre): the coverage is
  // taken again where the coarse search ended, before the refinement that it would otherwise bias.
  if (settings.coverageMask)
  {
    const Eigen::Isometry3d searchedCTToRoom = MisalignedCTToRoom(plannedCTToRoom, searchEnds.front(), isocenter);
    for (size_t v = 0; v < masked.size(); ++v)
    {
      masked[v].mask = masks.content[v];
      AndCoverage(masked[v], coverage, searchedCTToRoom, result.endFaces[v].facesToLeaveOut);
      if (std::count(masked[v].mask.begin(), masked[v].mask.end(), 1) == 0)
        throw InputError("view " + masked[v].view.name, "the CT covers none of the valid pixels: nothing left to register");
    }
  }
  if (result.boneOnly)
    AndShadowLessCuts(masked, volume, MisalignedCTToRoom(plannedCTToRoom, searchEnds.front(), isocenter),
      settings.boneShadowFineMarginMM, cutPoints, settings.device);
  StereoSimilarity fine(volume, plannedCTToRoom, isocenter, masked, settings.bins,
    { settings.equalizedLevels, settings.fineHighPassMM, correlationMM });
  fine.SetDevice(settings.device);
  result.fineRenderStride = settings.fineRenderStride > 0 ? RenderStride{ settings.fineRenderStride, settings.fineRenderStride }
                                                          : RenderStrideFor(volume, masked, plannedCTToRoom, isocenter);
  fine.SetRenderStride(result.fineRenderStride);
  fine.SetCostSink(&cost);
  const PoseOptimizerSettings fineSettings = RefinementSettings(settings);
  std::vector<PoseOptimizerResult> refined;
  for (size_t e = 0; e < searchEnds.size(); ++e)
  {
    const char* name = e == 0 ? "fine" : "fine from the second search's end";
    BeginStage(result, name, stageStart);
    progress.Begin(name, e == 0 ? 0.7 : 0.85, e == 0 ? 0.85 : 0.95);
    const auto objective = [&](const Pose& p)
    {
      const double value = Traced(result, fine.Evaluate(p));
      progress.Evaluated(value);
      return value;
    };
    refined.push_back(MaximizePose(objective, searchEnds[e], fineSettings));
    result.evaluations += refined.back().evaluations;
  }
  EndStage(result, stageStart);
  GateEvidence evidence;
  if (refined.size() == 2)
  {
    RecordDisagreement(result, refined[0], refined[1]);
    const double worse = std::min(refined[0].value, refined[1].value), better = std::max(refined[0].value, refined[1].value);
    const bool apart = !(TranslationApart(refined[0].pose, refined[1].pose) <= settings.maxSearchDisagreementMM &&
      RotationApart(refined[0].pose, refined[1].pose) <= settings.maxRefinedApartDegrees);
    evidence.ambiguous = apart && worse >= settings.ambiguousObjectiveRatio * better;
    if (refined[1].value > refined[0].value)
      std::swap(refined[0], refined[1]);
  }
  PoseOptimizerResult& fineResult = refined.front();
  // The refinement's objective, each evaluation counted: for the polish and the landscape.
  const auto countedObjective = [&](const Pose& p)
  {
    const double value = Traced(result, fine.Evaluate(p));
    ++result.evaluations;
    progress.Evaluated(value);
    return value;
  };
  if (!result.boneOnly && settings.vertexPolishRounds > 0)
  {
    BeginStage(result, "vertex polish", stageStart);
    // The refinement's small simplex stops on the first bump of a noisy objective near where it
    // started; the parabolas span the landscape's 3 mm and 2 degrees and read the peak's shape.
    for (int round = 0; round < settings.vertexPolishRounds; ++round)
    {
      fineResult.pose = MoveToParabolaVertex(
        countedObjective, fineResult.pose, fineResult.value, settings.landscapeNearMM, settings.landscapeNearDegrees);
      fineResult.value = countedObjective(fineResult.pose);
    }
    EndStage(result, stageStart);
  }
  if (result.boneOnly)
  {
    // Four refinements from 2 mm and 2 degrees around the result, each axis's sign changing from
    // start to start (rotations about the bone's centre): they must all come back.
    BeginStage(result, "restarts", stageStart);
    evidence.restartsApartMM = evidence.restartsApartDegrees = 0.0;
    const auto objective = [&](const Pose& p) { return Traced(result, fine.Evaluate(p)); };
    // Steps of the restarts' own size: the refinement's quarter-millimetre steps polish, they
    // do not travel 2 mm, and a stall would count as a disagreement of the images.
    PoseOptimizerSettings restartSettings = fineSettings;
    restartSettings.initialStepMM = 1.0;
    restartSettings.initialStepDegrees = 1.0;
    restartSettings.maxRestarts = 1;
    // A restart still travelling after 150 evaluations is in a flat valley: it ends where it is,
    // and that disagreement is the answer (four unbounded ones took 10 s on the metacarpal).
    restartSettings.maxEvaluations = std::min(restartSettings.maxEvaluations, 150);
    for (int k = 0; k < 4; ++k)
    {
      std::array<double, 6> p = fineResult.pose.Parameters();
      for (int a = 0; a < 6; ++a)
        p[a] += ((k < 2 ? k : a + k) % 2 == 0 ? 2.0 : -2.0);
      const PoseOptimizerResult again = MaximizePose(objective, Pose::FromParameters(p.data()), restartSettings);
      result.evaluations += again.evaluations;
      evidence.restartsApartMM = std::max(evidence.restartsApartMM, TranslationApart(again.pose, fineResult.pose));
      evidence.restartsApartDegrees = std::max(evidence.restartsApartDegrees, RotationApart(again.pose, fineResult.pose));
    }
    result.restartsApartMM = evidence.restartsApartMM;
    result.restartsApartDegrees = evidence.restartsApartDegrees;
  }
  BeginStage(result, "landscape", stageStart);
  progress.Begin("landscape", 0.9, 0.95);
  {
    // The ROI and the CT's coverage, without the entropy mask: pixels the optimiser never saw,
    // but none that no pose of this CT can explain.
    const Eigen::Isometry3d resultCTToRoom = MisalignedCTToRoom(plannedCTToRoom, fineResult.pose, isocenter);
    std::vector<RegistrationView> wholeViews;
    for (size_t v = 0; v < views.size(); ++v)
    {
      RegistrationView item = views[v];
      if (item.mask.empty())
        item.mask.assign(item.xray.size(), 1);
      if (settings.coverageMask && !result.endFaces.empty())
        AndCoverage(item, coverage, resultCTToRoom, result.endFaces[v].facesToLeaveOut);
      wholeViews.push_back(item);
    }
    // Where no ray meets the CT there is only what it does not hold: open field shaded by the
    // heel effect and scatter, a couch. Beyond the outline's margin that is no evidence about
    // the pose, and it flattened the peak of a rounded head along roll (Algorithms.md).
    if (result.boneOnly)
      AndShadowLessCuts(wholeViews, volume, resultCTToRoom, settings.boneShadowFineMarginMM, cutPoints, settings.device);
    else
      AndShadow(wholeViews, volume, resultCTToRoom, settings.heldOutShadowMarginMM, settings.device);
    StereoSimilarity heldOut(coarseVolume, plannedCTToRoom, isocenter, AtCoarseSize(wholeViews, pyramid), settings.bins,
      { settings.equalizedLevels, settings.heldOutHighPassMM, correlationMM });
    heldOut.SetDevice(settings.device);
    heldOut.SetCostSink(&cost);
    MeasureLandscape(countedObjective, heldOut, fineResult.pose,
      fineResult.value, settings, result);
    // Equalised levels on both sides: the DRR's transmission at 12 bits is quantised where a
    // thick body lets little through, and its steps would be edges.
    for (size_t v = 0; v < wholeViews.size(); ++v)
      wholeViews[v].xray = unsmoothedViews[v].xray;
    StereoSimilarity atFullSize(volume, plannedCTToRoom, isocenter, wholeViews, settings.bins, { true, 0.0 });
    atFullSize.SetDevice(settings.device);
    atFullSize.SetCostSink(&cost);
    MeasureEdges(atFullSize, fineResult.pose, isocenter, result);
    result.drrCount += atFullSize.RenderedDRRs();
  }
  EndStage(result, stageStart);
  result.objective = fine.Evaluate(fineResult.pose);
  result.drrCount += fine.RenderedDRRs();
  result.converged = fineResult.converged;
  result.misalignment = aboutIsocenter(fineResult.pose);
  result.correction = result.misalignment.Inverse();
  result.mutualInformation = fine.LastMutualInformation();
  result.fineSeconds = Since(start);

  // 4. Quality gate, on what each view says at the result.
  progress.Begin("quality gate", 0.95, 1.0);
  const Clock::time_point gateStart = Clock::now();
  const std::clock_t gateCPUStart = std::clock();
  evidence.misalignment = fineResult.pose; // the gate's motion limits: about the same centre as the start
  evidence.start = settings.initialPose;
  evidence.converged = fineResult.converged;
  evidence.stopReason = fineResult.stopReason;
  evidence.searchApartMM = result.searchDisagreementMM;
  evidence.searchApartDegrees = result.searchDisagreementDegrees;
  evidence.uncertainty = result.uncertainty;
  evidence.peakMargin = result.peakMargin;
  // Each view's checks read only its own images: one thread each.
  std::vector<ViewEvidence> measured(masked.size());
  vtkSMPTools::For(size_t{ 0 }, masked.size(), size_t{ 1 },
    [&](size_t first, size_t last)
    {
      JointHistogram histogram(settings.bins);
      for (size_t v = first; v < last; ++v)
        measured[v] = MeasureView(fine, v, working.openFieldBright[v], isocenter, settings, histogram);
    });
  for (size_t v = 0; v < masked.size(); ++v)
  {
    result.drrs.push_back(fine.LastDRR(v));
    result.masks.push_back(masked[v].mask);
    const ViewEvidence& view = measured[v];
    result.explained.push_back(view.explained);
    result.uncovered.push_back(view.uncovered);
    result.viewResidualMM.push_back(view.residualMM);
    result.halvesApartMM.push_back(view.halvesApartMM);
    evidence.views.push_back(view);
  }
  result.failures = CheckQuality(evidence, settings);
  result.prealignment.pose = aboutIsocenter(result.prealignment.pose);
  result.ok = result.failures.empty();
  result.gateSeconds = Since(gateStart);
  result.gateCPUSeconds = CPUSince(gateCPUStart);
  progress.Done();
  return result;
}

} // namespace xp
