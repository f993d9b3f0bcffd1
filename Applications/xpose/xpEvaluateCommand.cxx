#include "xpCommands.h"
#include "xpRegistrationSources.h"

#include "xpAccuracyEvaluation.h"
#include "xpError.h"
#include "xpEvaluation.h"
#include "xpEvaluationFolder.h"
#include "xpEvaluationScenario.h"
#include "xpStereoGeometry.h"
#include "xpTargetError.h"
#include "xpVolumeIO.h"

#include <vtkImageData.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

/** The same file named from another folder, or with ./ and ../, must resume the same run. */
std::string CanonicalPath(const std::string& path)
{
  std::error_code error;
  const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, error);
  return error ? path : canonical.string();
}

std::string Joined(const std::vector<std::string>& items)
{
  std::string text;
  for (const std::string& item : items)
    text += (text.empty() ? "" : ",") + item;
  return text;
}

/** The settings that make trials comparable (evaluation.json); a resumed run must have the same. */
std::string SettingsText(const EvaluateOptions& o, const std::string& size, const std::string& model)
{
  std::ostringstream text;
  text.precision(10);
  text << "{\n  \"ct\": \"" << CanonicalPath(o.ct) << "\",\n  \"series\": \"" << o.series << "\",\n  \"geometry\": \""
       << CanonicalPath(o.geometry)
       << "\",\n  \"scenario\": \"" << o.scenario << "\",\n  \"size\": \"" << size << "\",\n  \"seed\": " << o.seed
       << ",\n  \"min_start_translation_mm\": " << o.minTranslation << ",\n  \"max_start_translation_mm\": " << o.maxTranslation
       << ",\n  \"max_start_rotation_deg\": " << o.maxRotation << ",\n  \"noise\": " << o.noise
       << ",\n  \"xray_ct\": \"" << (o.xrayCT.empty() ? "" : CanonicalPath(o.xrayCT)) << "\",\n  \"xray_stretch\": \""
       << o.xrayStretch << "\""
       << ",\n  \"registration_off\": \"" << Joined(o.registrationOff) << "\""
       << ",\n  \"optimizer\": \"" << o.optimizer << "\""
       << ",\n  \"xray_smoothing\": " << o.settings.xraySmoothingPerVoxel
       << ",\n  \"xray_noise_levels\": " << o.settings.xrayNoiseLevels
       << ",\n  \"fine_render_stride\": " << o.settings.fineRenderStride
       << ",\n  \"fine_plane_step\": " << o.settings.finePlaneStep
       << ",\n  \"search_render_stride\": " << o.settings.searchRenderStride
       << ",\n  \"quarter_size_travel\": " << (o.settings.quarterSizeTravel ? "true" : "false")
       << ",\n  \"schedule\": \"" << ScheduleChoiceName(o.settings.schedule) << "\""
       << ",\n  \"second_search_joins\": " << (o.settings.secondSearchJoins ? "true" : "false")
       << ",\n  \"held_out_turns\": " << (o.settings.heldOutTurns ? "true" : "false")
       << ",\n  \"vertex_polish_rounds\": " << o.settings.vertexPolishRounds
       << ",\n  \"half_size_refinement\": " << (o.settings.halfSizeRefinement ? "true" : "false")
       << ",\n  \"linearized_refinement\": " << (o.settings.linearizedRefinement ? "true" : "false")
       << ",\n  \"high_pass_after_travel\": " << (o.settings.highPassAfterTravel ? "true" : "false")
       << ",\n  \"high_pass_mm\": " << o.settings.fineHighPassMM << ",\n  \"coverage_margin_mm\": " << o.settings.coverageMarginMM
       << ",\n  \"coverage_min_excess\": " << o.settings.coverageMinExcess
       << ",\n  \"bins\": " << o.settings.bins << ",\n  \"max_evaluations\": " << o.settings.maxEvaluations
       << ",\n  \"gate\": {\"min_explained\": " << o.settings.minExplained << ", \"max_view_residual_mm\": "
       << o.settings.maxViewResidual << ", \"max_uncovered\": " << o.settings.maxUncovered << ", \"max_search_apart_mm\": "
       << o.settings.maxSearchDisagreementMM << ", \"max_search_apart_deg\": " << o.settings.maxSearchDisagreementDegrees
       << ", \"max_refined_apart_deg\": " << o.settings.maxRefinedApartDegrees << ", \"min_peak_margin\": " << o.settings.minPeakMargin
       << ", \"max_halves_apart_mm\": " << o.settings.maxHalvesApartMM << ", \"max_halves_apart_clear_peak_mm\": "
       << o.settings.maxHalvesApartClearPeakMM << ", \"clear_peak_margin\": " << o.settings.clearPeakMargin << "}"
       << ",\n  \"table\": \"" << (o.settings.chooseTable ? "chosen by the X-rays" : o.removeTable ? "removed" : "kept") << "\""
       << ",\n  \"x_rays\": " << model
       << ",\n  \"success_mtre_mm\": " << o.successMTRE << ",\n  \"target_region\": \"CT voxels above " << TargetHU
       << " HU within " << TargetRadiusMM << " mm of the isocentre\"\n}\n";
  return text.str();
}

void CheckTrialOptions(const EvaluateOptions& options)
{
  CheckLimit(options.noise, 0.0, 1000.0, "--noise");
  CheckLimit(options.successMTRE, 0.01, 100.0, "--success-mtre");
  CheckLimit(options.trials, 1, 100000, "--trials");
  if (!(options.minTranslation >= 0.0 && options.maxTranslation >= options.minTranslation && options.maxTranslation <= 200.0))
  {
    throw InputError("--max-start-translation", "must be at least --min-start-translation and at most 200 mm, both 0 or more");
  }
  if (!(options.maxRotation >= 0.0 && options.maxRotation <= 10.0))
  {
    throw InputError("--max-start-rotation", "must be between 0 and 10 degrees");
  }
  for (const std::string& approach : options.approaches)
  {
    if (approach != "A" && approach != "B")
      throw InputError("--approaches", "expected A (whole image) and/or B (entropy masks), got '" + approach + "'");
  }
}

/** The registration settings with the steps of --registration-off switched off. */
StereoRegistrationSettings RegistrationSettingsOf(const EvaluateOptions& options)
{
  CheckRegistrationSettings(options.settings);
  StereoRegistrationSettings settings = options.settings;
  SetOptimizers(options.optimizer, settings, "--optimizer");
  for (const std::string& step : options.registrationOff)
  {
    if (step == "levels")
      settings.equalizedLevels = false;
    else if (step == "high-pass")
      settings.fineHighPassMM = 0.0;
    else if (step == "coverage")
      settings.coverageMask = false;
    else if (step == "median")
      settings.medianFilter = false;
    else if (step == "smoothing")
      settings.xraySmoothingPerVoxel = 0.0;
    else if (step == "bone-cuts")
      settings.leaveOutBoneCuts = false;
    else
      throw InputError("--registration-off", "expected levels, high-pass, coverage, median, smoothing or bone-cuts, got '" + step + "'");
  }
  return settings;
}

/** One line per registration: where it started and ended, and the run's success so far. */
void PrintProgress(const TrialRecord& r, const EvaluationFolder& folder, int trials, int registered, int remaining,
  Clock::time_point start)
{
  int successes = 0, count = 0;
  for (const TrialRecord& other : folder.Records())
    if (other.approach == r.approach)
      ++count, successes += other.success;
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
  std::printf("trial %d of %d, %s: initial %.1f mm (mTRE %.1f), final mTRE %.3f mm, %s, %.1f s | success %s %d/%d | "
              "about %.0f min left\n",
    r.trial, trials, r.approach == "A" ? "A (whole image)" : "B (entropy masks)", r.initialTranslation, r.initialMTRE,
    r.mtre, r.success ? "success" : (r.status == "ok" ? "ok but off" : "failed"), r.totalSeconds, r.approach.c_str(),
    successes, count, elapsed / registered * (remaining - registered) / 60.0);
  std::fflush(stdout);
}

/** What the X-rays show when it is not --ct: another CT (--xray-ct) or --ct stretched. */
vtkSmartPointer<vtkImageData> XRayCTOf(const EvaluateOptions& options, vtkImageData* ct)
{
  if (!options.xrayCT.empty() && !options.xrayStretch.empty())
    throw InputError("--xray-stretch", "stretches --ct; it cannot be given with --xray-ct");
  if (!options.xrayCT.empty())
    return ReadCTVolume(options.xrayCT).image;
  if (options.xrayStretch.empty())
    return nullptr;
  int axis = -1;
  double factor = 0.0;
  char tail = 0;
  if (std::sscanf(options.xrayStretch.c_str(), "%d,%lf%c", &axis, &factor, &tail) != 2 || !(factor >= 0.5 && factor <= 2.0))
    throw InputError("--xray-stretch", "expected AXIS,FACTOR with AXIS 0, 1 or 2 and FACTOR 0.5 to 2, got '" + options.xrayStretch + "'");
  return StretchedCT(ct, axis, factor);
}

} // namespace

int RunEvaluate(const EvaluateOptions& options)
{
  UseThreads(options.threads);
  std::optional<DetectorSettings> detector;
  if (!options.detector.empty())
    detector = DetectorSettings{ ParseDetectorFormat(options.detector, "--detector"), options.dose, options.electronicNoise };
  const EvaluationScenario scenario(options.scenario, options.without, options.noise, options.removeTable, detector);
  CheckTrialOptions(options);
  AccuracyEvaluationSettings settings;
  settings.registration = RegistrationSettingsOf(options);
  settings.registration.device = UseDevice(options.device);
  settings.seed = options.seed;
  settings.range = { options.minTranslation, options.maxTranslation, options.maxRotation };
  settings.successMTRE = options.successMTRE;
  settings.writeXRays = options.writeXRays;

  // Inputs, read once for every trial.
  const StereoGeometry geometry = ReadStereoGeometry(options.geometry);
  ValidateStereoGeometry(geometry, options.geometry);
  const CTVolume ct = ReadCTVolume(options.ct, options.series);
  const PatientSetup patient{ ParsePatientPosition(ct.patientPosition, options.ct), std::nullopt, geometry.isocenter };
  settings.shrinkFactor = RegistrationShrinkFactor(geometry.views, ParseSizeIfGiven(options.size, "--size"));
  const XRayView& first = geometry.views[0];
  const std::string size =
    std::to_string(first.Columns() / settings.shrinkFactor) + "x" + std::to_string(first.Rows() / settings.shrinkFactor);
  vtkSmartPointer<vtkImageData> xrayCT = XRayCTOf(options, ct.image);
  AccuracyEvaluation evaluation(scenario, ct.image, patient, geometry, settings, xrayCT);

  EvaluationFolder folder(options.outputDirectory, SettingsText(options, size, scenario.DescribeXRays()));
  std::printf("evaluate: %s, scenario %s, %d trials x %zu approaches at %s, %zu target points; %zu registrations "
              "already in %s\n",
    options.ct.c_str(), options.scenario.c_str(), options.trials, options.approaches.size(), size.c_str(),
    evaluation.TargetCount(), folder.Records().size(), folder.CSVPath().c_str());
  const Clock::time_point start = Clock::now();
  evaluation.Run(options.trials, options.approaches, folder, [&](const TrialRecord& record, int registered, int remaining)
    { PrintProgress(record, folder, options.trials, registered, remaining, start); });
  const std::vector<TrialRecord> records = folder.Finish(options.trials, options.successMTRE);
  std::printf("\n%s\nwrote trials.csv, summary.json and plots to %s\n", SummaryTable(records).c_str(),
    options.outputDirectory.c_str());
  return ExitOk;
}

} // namespace xp
