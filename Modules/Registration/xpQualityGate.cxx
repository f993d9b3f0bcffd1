#include "xpQualityGate.h"

#include "xpError.h"
#include "xpStereoRegistration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

std::string Format(const char* format, double a, double b = 0.0, double c = 0.0)
{
  char text[240];
  std::snprintf(text, sizeof(text), format, a, b, c);
  return text;
}

} // namespace

const char* GateCodeName(GateCode code)
{
  switch (code)
  {
    case GateCode::InvalidInput:
      return "invalid_input";
    case GateCode::NotConverged:
      return "not_converged";
    case GateCode::TranslationTooLarge:
      return "translation_too_large";
    case GateCode::RotationTooLarge:
      return "rotation_too_large";
    case GateCode::AmbiguousPose:
      return "ambiguous_pose";
    case GateCode::TooFewPixels:
      return "too_few_pixels";
    case GateCode::LowExplained:
      return "low_explained";
    case GateCode::UncoveredAnatomy:
      return "uncovered_anatomy";
    case GateCode::ViewDisagrees:
      return "view_disagrees";
    case GateCode::NotDistinct:
      return "not_distinct";
    case GateCode::Uncertain:
      return "uncertain";
    case GateCode::HalvesDisagree:
      return "halves_disagree";
    case GateCode::RestartsDisagree:
      return "restarts_disagree";
  }
  return "unknown";
}

std::vector<std::string> GateMessages(const std::vector<GateFailure>& failures)
{
  std::vector<std::string> messages;
  for (const GateFailure& failure : failures)
    messages.push_back(failure.message);
  return messages;
}

void ValidateGateLimits(const StereoRegistrationSettings& settings)
{
  for (const auto& [limit, name] : { std::make_pair(settings.maxTranslation, "maxTranslation"),
         std::make_pair(settings.maxRotation, "maxRotation"), std::make_pair(settings.maxViewResidual, "maxViewResidual"),
         std::make_pair(settings.maxViewResidualDegrees, "maxViewResidualDegrees"),
         std::make_pair(settings.maxUncovered, "maxUncovered"), std::make_pair(settings.maxUncertaintyMM, "maxUncertaintyMM"),
         std::make_pair(settings.maxUncertaintyDegrees, "maxUncertaintyDegrees"),
         std::make_pair(settings.maxHalvesApartMM, "maxHalvesApartMM"),
         std::make_pair(settings.maxHalvesApartClearPeakMM, "maxHalvesApartClearPeakMM"),
         std::make_pair(settings.halvesSearchStepMM, "halvesSearchStepMM"),
         std::make_pair(settings.maxRestartsApartMM, "maxRestartsApartMM"),
         std::make_pair(settings.maxRestartsApartDegrees, "maxRestartsApartDegrees"),
         std::make_pair(settings.maxSearchDisagreementDegrees, "maxSearchDisagreementDegrees"),
         std::make_pair(settings.maxRefinedApartDegrees, "maxRefinedApartDegrees"),
         std::make_pair(settings.landscapeNearMM, "landscapeNearMM"), std::make_pair(settings.landscapeNearDegrees, "landscapeNearDegrees"),
         std::make_pair(settings.landscapeCheckMM, "landscapeCheckMM"), std::make_pair(settings.landscapeCheckDegrees, "landscapeCheckDegrees") })
  {
    if (!(limit > 0.0 && std::isfinite(limit)))
    {
      throw InputError(std::string("registration settings: ") + name, "must be finite and positive");
    }
  }
  // 0 mm runs one search; a NaN would call any two ends one optimum.
  if (!(settings.maxSearchDisagreementMM >= 0.0 && std::isfinite(settings.maxSearchDisagreementMM)))
    throw InputError("registration settings: maxSearchDisagreementMM", "must be finite and not negative");
  // Not a gate limit, but a NaN here would keep every end face without a word.
  if (!(settings.coverageMinExcess >= 0.0 && settings.coverageMinExcess <= 1.0))
  {
    throw InputError("registration settings: coverageMinExcess", "must be between 0 and 1");
  }
  if (!(settings.boneCorrelationHighPassMM >= 0.0 && std::isfinite(settings.boneCorrelationHighPassMM)))
  {
    throw InputError("registration settings: boneCorrelationHighPassMM", "must be finite and not negative");
  }
  // The held-out check's pixels and scale: a NaN or negative value would dilate by nothing
  // (or everything) and keep the open field the check is meant to leave out.
  for (const auto& [value, name] : { std::make_pair(settings.heldOutShadowMarginMM, "heldOutShadowMarginMM"),
         std::make_pair(settings.heldOutHighPassMM, "heldOutHighPassMM") })
    if (!(value >= 0.0 && value <= 500.0))
      throw InputError(std::string("registration settings: ") + name, "must be between 0 and 500 mm");
  if (!(settings.minValidPixelsPerCell >= 0.0 && settings.minValidPixelsPerCell <= 1000.0))
  {
    throw InputError("registration settings: minValidPixelsPerCell", "must be between 0 and 1000");
  }
  for (const auto& [value, name] : { std::make_pair(settings.minPeakMargin, "minPeakMargin"),
         std::make_pair(settings.boneMinPeakMargin, "boneMinPeakMargin"), std::make_pair(settings.clearPeakMargin, "clearPeakMargin") })
    if (!(value >= -1.0 && value <= 1.0))
      throw InputError(std::string("registration settings: ") + name, "must be between -1 and 1");
  if (!(settings.minValidFraction >= 0.0 && settings.minValidFraction <= 1.0))
  {
    throw InputError("registration settings: minValidFraction", "must be between 0 and 1");
  }
  if (!(settings.minExplained >= 0.0 && settings.minExplained <= 1.0))
  {
    throw InputError("registration settings: minExplained", "must be between 0 and 1");
  }
}

std::vector<GateFailure> CheckQuality(const GateEvidence& evidence, const StereoRegistrationSettings& settings)
{
  std::vector<GateFailure> failures;
  if (!evidence.converged)
    failures.push_back({ GateCode::NotConverged, -1, "the optimiser did not converge (" + evidence.stopReason + ")" });
  // Limits on the whole motion from the start: the translation's length and the rotation's angle
  // about its own axis, as the table would move. Every comparison is written so that a NaN fails it.
  // From an initial pose: how far the point it put at the isocentre (the volume's centre, by
  // default) moved, and the angle of the relative rotation.
  const bool fromZero = evidence.start.Parameters() == Pose{}.Parameters();
  Pose m = evidence.misalignment;
  if (!fromZero)
  {
    m = Pose::FromTransform(Eigen::Isometry3d(m.Rotation() * evidence.start.Rotation().transpose()), Eigen::Vector3d::Zero());
    m.translation = evidence.misalignment.translation - evidence.start.translation;
  }
  const std::string what = fromZero ? "the correction's" : "the change from the initial pose:";
  if (!(m.translation.norm() <= settings.maxTranslation))
    failures.push_back({ GateCode::TranslationTooLarge, -1,
      what + Format(" translation (%.1f mm) exceeds %.1f mm", m.translation.norm(), settings.maxTranslation) });
  if (!(m.RotationAngle() <= settings.maxRotation))
    failures.push_back({ GateCode::RotationTooLarge, -1,
      what + Format(" rotation (%.1f degrees) exceeds %.1f degrees", m.RotationAngle(), settings.maxRotation) });
  if (evidence.ambiguous)
    failures.push_back({ GateCode::AmbiguousPose, -1,
      Format("two searches, from the pre-alignment and 1.5 mm / 1.5 degrees beside it, ended %.2f mm and %.2f degrees "
             "apart at full resolution: the images do not fix the pose",
        evidence.searchApartMM, evidence.searchApartDegrees) });
  // Each start around the result must come back to it: a pose that its own neighbourhood's
  // searches leave is one stall among many, however well its gate measures read.
  if (evidence.restartsApartMM >= 0.0 && !(evidence.restartsApartMM <= settings.maxRestartsApartMM &&
                                              evidence.restartsApartDegrees <= settings.maxRestartsApartDegrees))
    failures.push_back({ GateCode::RestartsDisagree, -1,
      Format("refinements restarted 2 mm and 2 degrees around the result ended up to %.2f mm and %.2f degrees from it",
        evidence.restartsApartMM, evidence.restartsApartDegrees) +
        Format(" (> %.2f mm or %.2f degrees): the images do not fix the pose", settings.maxRestartsApartMM,
          settings.maxRestartsApartDegrees) });
  // A similarity the optimiser never saw must peak at the result too: another patient's X-rays
  // and anatomy no pose fits give a result that only the optimised, masked objective favours.
  if (!(evidence.peakMargin >= settings.minPeakMargin))
    failures.push_back({ GateCode::NotDistinct, -1,
      Format("on a similarity the optimiser did not use (the pixels its masks left out as well) the result leads the "
             "poses %.1f mm away", settings.landscapeCheckMM) +
        (settings.heldOutJudgesTurns ? Format(" and %.1f degrees turned", settings.landscapeCheckDegrees) : std::string()) +
        Format(" by %.1f %% (< %.1f %%): the images do not single out this pose", 100.0 * evidence.peakMargin,
          100.0 * settings.minPeakMargin) });
  // Where the held-out peak is clear, the halves may end farther apart: noise scatters them, and
  // another anatomy would have cost the peak its lead too (StereoRegistrationSettings).
  const bool clearPeak = evidence.peakMargin >= settings.clearPeakMargin;
  const double halvesLimit =
    clearPeak ? std::max(settings.maxHalvesApartMM, settings.maxHalvesApartClearPeakMM) : settings.maxHalvesApartMM;
  static const char* axes[6] = { "tx", "ty", "tz", "pitch", "roll", "yaw" };
  for (int a = 0; a < 6; ++a)
  {
    const double limit = a < 3 ? settings.maxUncertaintyMM : settings.maxUncertaintyDegrees;
    if (evidence.uncertainty[a] <= limit)
      continue;
    const std::string unit = a < 3 ? " mm" : " degrees";
    failures.push_back({ GateCode::Uncertain, -1,
      std::isfinite(evidence.uncertainty[a])
        ? std::string("along ") + axes[a] + Format(" the result is uncertain by %.2f", evidence.uncertainty[a]) + unit +
            Format(" (> %.2f", limit) + unit + "): the similarity is too flat there to fix the pose"
        : std::string("along ") + axes[a] + " the result is no maximum of the similarity: a pose beside it fits better" });
  }
  for (size_t v = 0; v < evidence.views.size(); ++v)
  {
    const ViewEvidence& view = evidence.views[v];
    const int index = static_cast<int>(v);
    // MI from a joint histogram with fewer samples than cells measures its own sparseness: a few
    // hundred pixels make any pose look good (a CT covering a sliver of the X-ray's anatomy).
    const double cells = static_cast<double>(settings.bins) * settings.bins;
    if (!(view.validPixels >= settings.minValidPixelsPerCell * cells))
      failures.push_back({ GateCode::TooFewPixels, index,
        "view " + view.name +
          Format(": %.0f valid pixels, fewer than the %.0f that MI over %.0f histogram cells needs: the CT, the ROI "
                 "and the masks together leave too little of the X-ray to register",
            static_cast<double>(view.validPixels), settings.minValidPixelsPerCell * cells, cells) });
    // A mask that keeps a few percent of the view keeps edges and halos alone: on processed pelvis
    // X-rays 1-2 % of the view was left and results slid along the slice axis (Algorithms.md).
    if (view.pixels > 0 && !(view.validPixels >= settings.minValidFraction * view.pixels))
      failures.push_back({ GateCode::TooFewPixels, index,
        "view " + view.name +
          Format(": %.1f %% of the view is valid, less than %.1f %%: the masks leave too little of the X-ray to register",
            100.0 * view.validPixels / view.pixels, 100.0 * settings.minValidFraction) });
    if (!(view.explained >= settings.minExplained))
      failures.push_back({ GateCode::LowExplained, index,
        "view " + view.name +
          Format(": the final DRR explains %.3f of the X-ray's information (< %.3f)", view.explained, settings.minExplained) });
    // A CT shorter than the X-ray's field can slide to match the wrong level (a vertebra off)
    // and still explain enough of what it covers: the anatomy it leaves unexplained shows it.
    if (!(view.uncovered <= settings.maxUncovered))
      failures.push_back({ GateCode::UncoveredAnatomy, index,
        "view " + view.name +
          Format(": %.0f %% of the valid pixels show anatomy where the CT has none at the result (> %.0f %%): the CT does "
                 "not cover what the X-ray shows; a ROI around the anatomy the CT covers can exclude the rest",
            100.0 * view.uncovered, 100.0 * settings.maxUncovered) });
    if (!(view.halvesApartMM <= halvesLimit))
      failures.push_back({ GateCode::HalvesDisagree, index,
        "view " + view.name +
          Format(": its two halves, registered each on its own and both at once, end %.2f mm apart (> %.2f mm", view.halvesApartMM,
            halvesLimit) +
          (clearPeak ? Format(", with the held-out peak leading by %.1f %%", 100.0 * evidence.peakMargin) : std::string()) +
          "): the anatomy does not fit one rigid pose (another patient, or a changed one)" });
    if (!(view.residualMM <= settings.maxViewResidual && std::abs(view.residualDegrees) <= settings.maxViewResidualDegrees))
      failures.push_back({ GateCode::ViewDisagrees, index,
        "view " + view.name +
          Format(" disagrees with the 3D result: residual %.2f mm, %.2f degrees in 2D", view.residualMM, view.residualDegrees) });
  }
  return failures;
}

} // namespace xp
