#include "xpSessionOptions.h"

#include "xpError.h"
#include "xpStereoRegistration.h"

#include <cstdio>

namespace xp
{

void CheckLimit(double value, double low, double high, const std::string& option)
{
  if (!(value >= low && value <= high))
  {
    char range[96];
    std::snprintf(range, sizeof(range), "must be a number from %g to %g, got %g", low, high, value);
    throw InputError(option, range);
  }
}

void SetOptimizers(const std::string& text, StereoRegistrationSettings& settings, const std::string& option)
{
  const size_t slash = text.find('/');
  settings.optimizer = ParsePoseOptimizerMethod(text.substr(0, slash), option);
  settings.refinementOptimizer = ParsePoseOptimizerMethod(slash == std::string::npos ? text : text.substr(slash + 1), option);
}

std::string DefaultOptimizers()
{
  const StereoRegistrationSettings settings;
  const std::string search = PoseOptimizerMethodName(settings.optimizer);
  const std::string refinement = PoseOptimizerMethodName(settings.refinementOptimizer);
  return search == refinement ? search : search + "/" + refinement;
}

void CheckRegistrationSettings(const StereoRegistrationSettings& settings)
{
  CheckLimit(settings.bins, 8, 256, "--bins");
  CheckLimit(settings.maxEvaluations, 10, 100000, "--max-evaluations");
  CheckLimit(settings.fineHighPassMM, 0.0, 500.0, "--high-pass-mm");
  CheckLimit(settings.xraySmoothingPerVoxel, 0.0, 10.0, "--xray-smoothing");
  CheckLimit(settings.xrayNoiseLevels, 0.0, 4096.0, "--xray-noise-levels");
  CheckLimit(settings.fineRenderStride, 0, 8, "--fine-render-stride");
  CheckLimit(settings.finePlaneStep, 0, 4, "--fine-plane-step");
  CheckLimit(settings.searchRenderStride, 0, 8, "--search-render-stride");
  CheckLimit(settings.coverageMarginMM, 0.0, 100.0, "--coverage-margin-mm");
  CheckLimit(settings.coverageMinExcess, 0.0, 1.0, "--coverage-min-excess");
  CheckLimit(settings.maxTranslation, 0.1, 500.0, "--max-translation");
  CheckLimit(settings.maxRotation, 0.1, 180.0, "--max-rotation");
  CheckLimit(settings.minExplained, 0.0, 1.0, "--min-explained");
  CheckLimit(settings.maxViewResidual, 0.01, 100.0, "--max-view-residual");
  CheckLimit(settings.maxUncovered, 0.001, 1.0, "--max-uncovered");
  CheckLimit(settings.maxSearchDisagreementMM, 0.0, 100.0, "--max-search-apart-mm");
  CheckLimit(settings.maxSearchDisagreementDegrees, 0.001, 45.0, "--max-search-apart-deg");
  CheckLimit(settings.maxRefinedApartDegrees, 0.001, 45.0, "--max-refined-apart-deg");
  CheckLimit(settings.maxHalvesApartMM, 0.01, 100.0, "--max-halves-apart-mm");
  CheckLimit(settings.maxHalvesApartClearPeakMM, 0.01, 100.0, "--max-halves-apart-clear-peak-mm");
  CheckLimit(settings.minPeakMargin, -1.0, 1.0, "--min-peak-margin");
  CheckLimit(settings.clearPeakMargin, -1.0, 1.0, "--clear-peak-margin");
}

} // namespace xp
