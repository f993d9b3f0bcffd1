#include "xpStereoRegistration.h"

#include "xpCTCoverage.h"
#include "xpError.h"
#include "xpPoseOptimizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
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

/** Starts a stage of the 6-DOF search; the previous one, if any, ends here. */
void BeginStage(StereoRegistrationResult& result, const char* name, Clock::time_point& stageStart)
{
  const Clock::time_point now = Clock::now();
  if (!result.stages.empty())
    result.stages.back().seconds = std::chrono::duration<double>(now - stageStart).count();
  stageStart = now;
  result.stages.push_back({ name, static_cast<int>(result.objectiveTrace.size()) });
}

double Traced(StereoRegistrationResult& result, double objective)
{
  result.objectiveTrace.push_back(objective);
  return objective;
}

std::string Format(const char* format, double a, double b = 0.0, double c = 0.0)
{
  char text[200];
  std::snprintf(text, sizeof(text), format, a, b, c);
  return text;
}

double TranslationApart(const Pose& a, const Pose& b)
{
  return (a.translation - b.translation).cwiseAbs().maxCoeff();
}

double RotationApart(const Pose& a, const Pose& b)
{
  return std::max({ std::abs(a.pitch - b.pitch), std::abs(a.roll - b.roll), std::abs(a.yaw - b.yaw) });
}

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

/** Leaves out of `item.mask` the pixels whose rays cross the body beyond the CT's end slices. */
void AndCoverage(RegistrationView& item, const CTCoverage& coverage, const Eigen::Isometry3d& ctToRoom)
{
  const std::vector<uint8_t> covered = coverage.Mask(ctToRoom, item.view);
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

StereoRegistrationResult RegisterStereo(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& isocenter, const std::vector<RegistrationView>& views, const StereoRegistrationSettings& settings)
{
  if (views.size() < 2)
  {
    throw InputError("registration", "a stereo registration needs at least two views");
  }
  // A NaN or negative limit would switch the gate off without a word.
  for (const auto& [limit, name] : { std::make_pair(settings.maxTranslation, "maxTranslation"),
         std::make_pair(settings.maxRotation, "maxRotation"), std::make_pair(settings.maxViewResidual, "maxViewResidual"),
         std::make_pair(settings.maxUncovered, "maxUncovered") })
  {
    if (!(limit > 0.0 && std::isfinite(limit)))
    {
      throw InputError(std::string("registration settings: ") + name, "must be finite and positive");
    }
  }
  if (!(settings.minExplained >= 0.0 && settings.minExplained <= 1.0))
  {
    throw InputError("registration settings: minExplained", "must be between 0 and 1");
  }
  StereoRegistrationResult result;
  const bool pyramid = settings.pyramid && views[0].view.Columns() >= 256 && views[0].view.Rows() >= 192;

  // 1. Pre-alignment (5+1 DOF) with the user ROIs only. Half-size images are rendered from a
  // half-resolution CT where its voxels stay fine enough: their pixels are twice as wide, and a
  // ray takes half the samples.
  Clock::time_point start = Clock::now();
  const bool halveCT = pyramid && 2.0 * volume.MaximumSpacing() <= settings.maxHalvedVoxelMM;
  const AttenuationVolume halfVolume = halveCT ? volume.Halved() : AttenuationVolume();
  const AttenuationVolume& coarseVolume = halveCT ? halfVolume : volume;
  std::vector<RegistrationView> coarseViews;
  for (const RegistrationView& item : views)
    coarseViews.push_back(pyramid ? Half(item) : item);
  StereoSimilarity coarse(coarseVolume, plannedCTToRoom, isocenter, coarseViews, settings.bins, { settings.equalizedLevels, 0.0 });
  result.prealignment = PreAlign(coarse, Pose{}, isocenter);
  result.drrCount += coarse.RenderedDRRs();
  result.prealignSeconds = Since(start);

  // 2. Entropy masks AND ROIs AND the CT's coverage, transferred into the DRR planes.
  start = Clock::now();
  std::vector<RegistrationView> masked = views;
  std::vector<std::vector<uint8_t>> contentMasks; // entropy AND ROI, before the coverage
  const CTCoverage coverage(volume, settings.coverageMarginMM);
  const Eigen::Isometry3d prealignedCTToRoom = MisalignedCTToRoom(plannedCTToRoom, result.prealignment.pose, isocenter);
  for (size_t v = 0; v < views.size(); ++v)
  {
    const RegistrationView& item = views[v];
    const uint8_t* roi = item.mask.empty() ? nullptr : item.mask.data();
    std::vector<uint8_t> mask;
    if (settings.entropyMask)
    {
      EntropyMaskResult entropy = ComputeEntropyMask(item.xray.data(), item.view.Columns(), item.view.Rows(), roi);
      mask = std::move(entropy.mask);
      result.entropyMaps.push_back(std::move(entropy.entropy));
    }
    else
    {
      mask = roi ? item.mask : std::vector<uint8_t>(item.xray.size(), 1);
    }
    masked[v].mask = TransferMask(mask, item.view, item.view);
    contentMasks.push_back(masked[v].mask);
    if (settings.coverageMask)
      AndCoverage(masked[v], coverage, prealignedCTToRoom);
    const long long valid = std::count(masked[v].mask.begin(), masked[v].mask.end(), 1);
    if (valid == 0)
    {
      throw InputError("view " + item.view.name, "the validity mask is empty: nothing left to register");
    }
    result.validFraction.push_back(static_cast<double>(valid) / masked[v].mask.size());
  }
  result.maskSeconds = Since(start);

  // 3. 6-DOF fine alignment with masked DRRs, half resolution first. The coarse search runs twice,
  // the second time from the pre-alignment moved along the roll/lateral valley (roll turns about
  // the axis perpendicular to both central rays, which two views see least): a landscape with two
  // optima there cannot give a trustworthy result. Two independent starts, not the first end
  // moved: a search from the first end can stall on the valley's flat floor short of it.
  start = Clock::now();
  PoseOptimizerSettings fineSettings;
  fineSettings.maxEvaluations = settings.maxEvaluations;
  // No restart here: the coarse search's restarts already escaped the valley's stalls, and on 14
  // pelvis trials a restart of the refinement cost a third of the time and changed the median
  // mTRE by 0.006 mm.
  fineSettings.maxRestarts = 0;
  fineSettings.initialStepMM = 0.25;
  fineSettings.initialStepDegrees = 0.15;
  // 0.05 mm and 0.03 degrees: ten times finer than the accuracy asked of the result.
  fineSettings.toleranceMM = 0.05;
  fineSettings.toleranceDegrees = 0.03;
  std::vector<Pose> searchEnds; // better first
  Clock::time_point stageStart; // set by BeginStage
  {
    std::vector<RegistrationView> coarseSearch;
    for (const RegistrationView& item : masked)
      coarseSearch.push_back(pyramid ? Half(item) : item);
    StereoSimilarity searchSimilarity(
      coarseVolume, plannedCTToRoom, isocenter, coarseSearch, settings.bins, { settings.equalizedLevels, 0.0 });
    PoseOptimizerSettings searchSettings = fineSettings;
    searchSettings.initialStepMM = 2.0;
    searchSettings.initialStepDegrees = 1.0;
    searchSettings.toleranceMM = 0.1;
    searchSettings.toleranceDegrees = 0.05;
    searchSettings.maxRestarts = 3; // stalls happen in the long coarse travel; restarts are cheap here
    const auto objective = [&](const Pose& p) { return Traced(result, searchSimilarity.Evaluate(p)); };
    BeginStage(result, pyramid ? "coarse search (half resolution)" : "coarse search", stageStart);
    PoseOptimizerResult first = MaximizePose(objective, result.prealignment.pose, searchSettings);
    result.evaluations += first.evaluations;
    searchEnds.push_back(first.pose);
    if (settings.maxSearchDisagreementMM > 0.0)
    {
      Pose moved = result.prealignment.pose;
      moved.roll += 1.5;
      moved.translation[0] += 1.5;
      BeginStage(result, "second coarse search", stageStart);
      // Once the second search stands where the first ended, about as high, it has found the
      // same optimum: the rest of its travel would only polish it.
      PoseOptimizerSettings secondSettings = searchSettings;
      secondSettings.stopWhen = [&](const Pose& pose, double value)
      { return Agree(pose, first.pose, settings) && value >= settings.sameOptimumObjectiveRatio * first.value; };
      PoseOptimizerResult second = MaximizePose(objective, moved, secondSettings);
      result.evaluations += second.evaluations;
      if (second.value > first.value)
        std::swap(first, second);
      searchEnds = { first.pose };
      // Ends far apart matter only when both are about as good; a clearly worse end is a local
      // optimum that the better search left behind. Comparable ends far apart are refined both.
      if (!Agree(first.pose, second.pose, settings) &&
        second.value >= settings.refineBothObjectiveRatio * first.value)
        searchEnds.push_back(second.pose);
      RecordDisagreement(result, first, second);
    }
    result.drrCount += searchSimilarity.RenderedDRRs();
  }
  // Each remaining end is refined at full resolution, where a stall on the half-size images'
  // flatter valley floor comes back or shows its lower objective: only ends that stay apart
  // there and are equally good within ambiguousObjectiveRatio mean the images do not fix the pose.
  // The pre-alignment leaves the angles the views see least a few degrees off (pitch of 3.6
  // degrees moves a pelvis CT's end faces 3.5 mm at 56 mm from the isocentre): the coverage is
  // taken again where the coarse search ended, before the refinement that it would otherwise bias.
  if (settings.coverageMask)
  {
    const Eigen::Isometry3d searchedCTToRoom = MisalignedCTToRoom(plannedCTToRoom, searchEnds.front(), isocenter);
    for (size_t v = 0; v < masked.size(); ++v)
    {
      masked[v].mask = contentMasks[v];
      AndCoverage(masked[v], coverage, searchedCTToRoom);
      if (std::count(masked[v].mask.begin(), masked[v].mask.end(), 1) == 0)
        throw InputError("view " + masked[v].view.name, "the CT covers none of the valid pixels: nothing left to register");
    }
  }
  StereoSimilarity fine(
    volume, plannedCTToRoom, isocenter, masked, settings.bins, { settings.equalizedLevels, settings.fineHighPassMM });
  std::vector<PoseOptimizerResult> refined;
  for (size_t e = 0; e < searchEnds.size(); ++e)
  {
    BeginStage(result, e == 0 ? "fine" : "fine from the second search's end", stageStart);
    refined.push_back(MaximizePose([&](const Pose& p) { return Traced(result, fine.Evaluate(p)); }, searchEnds[e], fineSettings));
    result.evaluations += refined.back().evaluations;
  }
  result.stages.back().seconds = Since(stageStart);
  if (refined.size() == 2)
  {
    RecordDisagreement(result, refined[0], refined[1]);
    const double worse = std::min(refined[0].value, refined[1].value), better = std::max(refined[0].value, refined[1].value);
    if (!Agree(refined[0].pose, refined[1].pose, settings) && worse >= settings.ambiguousObjectiveRatio * better)
    {
      result.reasons.push_back(Format("two searches, from the pre-alignment and 1.5 mm / 1.5 degrees beside it, ended "
                                      "%.2f mm and %.2f degrees apart at full resolution: the images do not fix the pose",
        result.searchDisagreementMM, result.searchDisagreementDegrees));
    }
    if (refined[1].value > refined[0].value)
      std::swap(refined[0], refined[1]);
  }
  const PoseOptimizerResult& fineResult = refined.front();
  result.objective = fine.Evaluate(fineResult.pose);
  result.drrCount += fine.RenderedDRRs();
  result.converged = fineResult.converged;
  result.misalignment = fineResult.pose;
  result.correction = fineResult.pose.Inverse();
  result.mutualInformation = fine.LastMutualInformation();
  result.fineSeconds = Since(start);

  // 4. Quality gate.
  if (!fineResult.converged)
    result.reasons.push_back("the optimiser did not converge (" + fineResult.stopReason + ")");
  // Limits on the whole motion: the translation's length and the rotation's angle about its
  // own axis, as the table would move; written so that a NaN fails them.
  const Pose& m = result.misalignment;
  if (!(m.translation.norm() <= settings.maxTranslation))
    result.reasons.push_back(Format("the correction's translation (%.1f mm) exceeds %.1f mm", m.translation.norm(),
      settings.maxTranslation));
  if (!(m.RotationAngle() <= settings.maxRotation))
    result.reasons.push_back(Format("the correction's rotation (%.1f degrees) exceeds %.1f degrees", m.RotationAngle(),
      settings.maxRotation));
  JointHistogram histogram(settings.bins);
  for (size_t v = 0; v < masked.size(); ++v)
  {
    const RegistrationView& item = masked[v];
    result.drrs.push_back(fine.LastDRR(v));
    result.masks.push_back(item.mask);
    // How much of the X-ray's information the final DRR explains, over the valid pixels.
    histogram.Compute(fine.XRayLevels(v).data(), fine.LastDRRLevels(v).data(), static_cast<long long>(item.xray.size()),
      item.mask.data(), item.mask.data());
    const double explained = histogram.FixedEntropy() > 0 ? histogram.MutualInformation() / histogram.FixedEntropy() : 0.0;
    result.explained.push_back(explained);
    if (!(explained >= settings.minExplained))
      result.reasons.push_back("view " + item.view.name +
        Format(": the final DRR explains %.3f of the X-ray's information (< %.3f)", explained, settings.minExplained));
    // A CT shorter than the X-ray's field can slide to match the wrong level (a vertebra off)
    // and still explain enough of what it covers: the anatomy it leaves unexplained shows it.
    const double uncovered = UncoveredFraction(item.xray, fine.LastDRR(v), item.mask);
    result.uncovered.push_back(uncovered);
    if (!(uncovered <= settings.maxUncovered))
      result.reasons.push_back("view " + item.view.name +
        Format(": %.0f %% of the valid pixels show anatomy where the CT has none at the result (> %.0f %%): the CT does "
               "not cover what the X-ray shows; a ROI around the anatomy the CT covers can exclude the rest",
          100.0 * uncovered, 100.0 * settings.maxUncovered));
    // A view whose own 2D registration still wants to move disagrees with the 3D result. Its
    // first steps are half the residual allowed: steps of the pre-alignment's size miss the
    // narrow optimum of high-passed levels and the search shrinks back onto its start.
    const double mmPerPixel =
      item.view.pixelSpacing[0] * (item.view.source - isocenter).norm() / item.view.SourceToPanelDistance();
    const Motion2D residual = Register2D(fine.XRayLevels(v), fine.LastDRRLevels(v), item.view.Columns(), item.view.Rows(),
      item.view.Project(isocenter), item.mask.data(), settings.bins, 0.5 * settings.maxViewResidual / mmPerPixel);
    const double shiftMM = residual.shift.norm() * mmPerPixel;
    result.viewResidualMM.push_back(shiftMM);
    if (!(shiftMM <= settings.maxViewResidual && std::abs(residual.rotation) <= 1.0))
      result.reasons.push_back("view " + item.view.name +
        Format(" disagrees with the 3D result: residual %.2f mm, %.2f degrees in 2D", shiftMM, residual.rotation));
  }
  result.ok = result.reasons.empty();
  return result;
}

} // namespace xp
