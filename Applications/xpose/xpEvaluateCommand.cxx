#include "xpCommands.h"
#include "xpRegistrationInputs.h"
#include "xpEvaluation.h"
#include "xpTargetError.h"
#include "xpModelXRaySimulator.h"
#include "xpXRayPhysics.h"

#include "xpAttenuationVolume.h"
#include "xpBodyMask.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpStereoGeometry.h"
#include "vtkXPStereoRegistrationFilter.h"
#include "xpImageRows.h"
#include "xpVolumeIO.h"
#include <vtkNew.h>

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

/** The slices of `ct` whose index lies in the central `fraction` of its length (same LPS placement). */
vtkSmartPointer<vtkImageData> CropSlices(vtkImageData* ct, double fraction)
{
  int dims[3];
  ct->GetDimensions(dims);
  const int keep = std::max(1, static_cast<int>(std::lround(dims[2] * fraction)));
  const int first = (dims[2] - keep) / 2;
  auto cropped = vtkSmartPointer<vtkImageData>::New();
  cropped->SetDimensions(dims[0], dims[1], keep);
  cropped->SetSpacing(ct->GetSpacing());
  cropped->SetDirectionMatrix(ct->GetDirectionMatrix());
  const Eigen::Vector3d origin = IndexToPhysical(ct) * Eigen::Vector3d(0, 0, first);
  cropped->SetOrigin(origin.data());
  cropped->AllocateScalars(ct->GetScalarType(), 1);
  const size_t slice = static_cast<size_t>(dims[0]) * dims[1] * ct->GetScalarSize();
  std::memcpy(cropped->GetScalarPointer(), static_cast<const char*>(ct->GetScalarPointer()) + slice * first, slice * keep);
  return cropped;
}

/** The settings that make trials comparable; a resumed run must have the same. */
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

std::string SettingsText(const EvaluateOptions& o, const std::string& size, const std::string& model)
{
  std::ostringstream text;
  text.precision(10);
  text << "{\n  \"ct\": \"" << CanonicalPath(o.ct) << "\",\n  \"series\": \"" << o.series << "\",\n  \"geometry\": \""
       << CanonicalPath(o.geometry)
       << "\",\n  \"scenario\": \"" << o.scenario << "\",\n  \"size\": \"" << size << "\",\n  \"seed\": " << o.seed
       << ",\n  \"min_translation_mm\": " << o.minTranslation << ",\n  \"max_translation_mm\": " << o.maxTranslation
       << ",\n  \"max_rotation_deg\": " << o.maxRotation << ",\n  \"noise\": " << o.noise
       << ",\n  \"registration_off\": \"" << Joined(o.registrationOff) << "\""
       << ",\n  \"high_pass_mm\": " << o.settings.fineHighPassMM << ",\n  \"coverage_margin_mm\": " << o.settings.coverageMarginMM
       << ",\n  \"coverage_min_excess\": " << o.settings.coverageMinExcess
       << ",\n  \"bins\": " << o.settings.bins << ",\n  \"max_evaluations\": " << o.settings.maxEvaluations
       << ",\n  \"gate\": {\"min_explained\": " << o.settings.minExplained << ", \"max_view_residual_mm\": "
       << o.settings.maxViewResidual << ", \"max_uncovered\": " << o.settings.maxUncovered << ", \"max_search_apart_mm\": "
       << o.settings.maxSearchDisagreementMM << ", \"max_search_apart_deg\": " << o.settings.maxSearchDisagreementDegrees << "}"
       << ",\n  \"remove_table\": " << (o.removeTable && o.scenario == "clinical" ? "true" : "false") << ",\n  \"x_rays\": " << model
       << ",\n  \"success_mtre_mm\": " << o.successMTRE << ",\n  \"target_region\": \"CT voxels above " << TargetHU
       << " HU within " << TargetRadiusMM << " mm of the isocentre\"\n}\n";
  return text.str();
}

void WriteWhole(const std::string& path, const std::string& text)
{
  const std::string partial = path + ".partial";
  std::ofstream out(partial);
  out << text;
  out.close();
  if (!out || std::rename(partial.c_str(), path.c_str()) != 0)
  {
    throw Error(path, "cannot write");
  }
}

std::string ReadWhole(const std::string& path)
{
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

} // namespace

int RunEvaluate(const EvaluateOptions& options)
{
  UseThreads(options.threads);
  const std::set<std::string> scenarios{ "clean", "noisy", "objects", "truncated", "clinical" };
  if (!scenarios.count(options.scenario))
  {
    throw InputError("--scenario", "expected clean, noisy, objects, truncated or clinical, got '" + options.scenario + "'");
  }
  const bool clinical = options.scenario == "clinical";
  if (!clinical && !options.without.empty())
  {
    throw InputError("--without", "switches off effects of the clinical scenario");
  }
  // The clinical scenario: the physics simulator with every effect on, and a planning CT shorter
  // than the CT the X-rays are made from, each of which --without can switch off.
  XRayPhysicsSettings physicsSettings = XRayPhysicsSettings::Clinical();
  bool truncation = clinical;
  for (const std::string& effect : options.without)
  {
    if (effect == "truncation")
      truncation = false;
    else
      SwitchOff(physicsSettings, effect, "--without");
  }
  if (options.trials < 1)
  {
    throw InputError("--trials", "must be 1 or more");
  }
  CheckLimit(options.noise, 0.0, 1000.0, "--noise");
  CheckLimit(options.successMTRE, 0.01, 100.0, "--success-mtre");
  CheckLimit(options.trials, 1, 100000, "--trials");
  if (!(options.minTranslation >= 0.0 && options.maxTranslation >= options.minTranslation && options.maxTranslation <= 200.0))
  {
    throw InputError("--max-translation", "must be at least --min-translation and at most 200 mm, both 0 or more");
  }
  if (!(options.maxRotation >= 0.0 && options.maxRotation <= 10.0))
  {
    throw InputError("--max-rotation", "must be between 0 and 10 degrees");
  }
  for (const std::string& approach : options.approaches)
  {
    if (approach != "A" && approach != "B")
      throw InputError("--approaches", "expected A (whole image) and/or B (entropy masks), got '" + approach + "'");
  }

  CheckRegistrationSettings(options.settings);
  StereoRegistrationSettings registrationSettings = options.settings;
  for (const std::string& step : options.registrationOff)
  {
    if (step == "levels")
      registrationSettings.equalizedLevels = false;
    else if (step == "high-pass")
      registrationSettings.fineHighPassMM = 0.0;
    else if (step == "coverage")
      registrationSettings.coverageMask = false;
    else
      throw InputError("--registration-off", "expected levels, high-pass or coverage, got '" + step + "'");
  }

  // --- inputs, read once for every trial ---
  const StereoGeometry geometry = ReadStereoGeometry(options.geometry);
  ValidateStereoGeometry(geometry, options.geometry);
  const CTVolume ct = ReadCTVolume(options.ct, options.series);
  const PatientSetup patient{ ParsePatientPosition(ct.patientPosition, options.ct), std::nullopt, geometry.isocenter };
  const Eigen::Vector3d isoInCT = patient.IsocenterInCT(ImageCenter(ct.image));
  const Eigen::Vector3d& roomIso = patient.roomIsocenter;
  const Eigen::Isometry3d planned = patient.PlannedCTToRoom(ImageCenter(ct.image));
  const int factor = RegistrationShrinkFactor(geometry.views, options.size);
  const std::string size = std::to_string(geometry.views[0].Columns() / factor) + "x" + std::to_string(geometry.views[0].Rows() / factor);

  XRaySimulation simulation;
  simulation.noise = options.scenario == "clean" ? 0.0 : options.noise;
  simulation.kvContrast = options.scenario != "clean";
  simulation.addObjects = options.scenario == "objects";
  std::unique_ptr<XRaySimulator> ownModel;
  std::unique_ptr<XRayPhysicsSimulator> physics;
  if (clinical)
    physics = std::make_unique<XRayPhysicsSimulator>(ct.image, planned, roomIso, physicsSettings);
  else
    ownModel = std::make_unique<XRaySimulator>(ct.image, patient, simulation);
  // Truncated: the X-rays see the whole patient, the registration a planning CT of half its
  // length; clinical: of 80 % of its length.
  vtkSmartPointer<vtkImageData> registrationCT = ct.image;
  if (options.scenario == "truncated")
    registrationCT = CropSlices(ct.image, 0.5);
  else if (truncation)
    registrationCT = CropSlices(ct.image, 0.8);
  // The simulated room has no CT table: in the clinical scenario the registration leaves it out
  // too, unless --keep-table. The DRR-model scenarios' X-rays show the table.
  if (clinical && options.removeTable)
    registrationCT = BodyOnly(registrationCT);
  // The registration filter keeps the CT's attenuation between trials; the X-rays reach it at the
  // registration size (the physics simulator renders each binned pixel's area).
  vtkNew<vtkXPStereoRegistrationFilter> registration;
  registration->SetCTData(registrationCT);
  StereoGeometry registrationGeometry = geometry;
  for (XRayView& panel : registrationGeometry.views)
    panel = panel.Resampled(panel.Columns() / factor, panel.Rows() / factor);
  registration->SetGeometry(registrationGeometry);
  // The isocentre stays where the whole CT puts it: the cut CT's centre is elsewhere.
  registration->SetPatientSetup({ patient.position, isoInCT, roomIso });
  const std::vector<Eigen::Vector3d> targets = TargetPoints(ct.image, isoInCT, planned);

  // --- the output folder: settings, then one CSV row per finished registration ---
  const std::string& directory = options.outputDirectory;
  if (mkdir(directory.c_str(), 0755) != 0 && errno != EEXIST)
  {
    throw InputError(directory, "cannot create the output folder");
  }
  const std::string settingsPath = directory + "/evaluation.json", csvPath = directory + "/trials.csv";
  std::string model = "\"the DRR model (xpModelXRaySimulator.h)\"";
  if (clinical)
  {
    std::string off;
    for (const std::string& effect : options.without)
      off += (off.empty() ? "\"" : ", \"") + effect + "\"";
    model = "{ \"simulator\": \"physics (xpXRayPhysics.h)\", \"planning_ct_cut_to\": " +
      std::string(truncation ? "0.8" : "1") + ", \"without\": [" + off + "], \"settings\": " + physicsSettings.Describe() + " }";
  }
  const std::string settings = SettingsText(options, size, model);
  std::vector<TrialRecord> records = ReadTrialCSV(csvPath);
  struct stat info;
  if (stat(settingsPath.c_str(), &info) == 0 && ReadWhole(settingsPath) != settings)
  {
    throw InputError(settingsPath, "was written with other settings (CT, geometry, scenario, size, seed or ranges); "
                                   "resume with the same options or use another --out-dir");
  }
  WriteWhole(settingsPath, settings);
  {
    // Rewrite the rows that were read whole: drops a row cut off by an interruption.
    std::string text = TrialCSVHeader() + "\n";
    for (const TrialRecord& r : records)
      text += TrialCSVRow(r) + "\n";
    WriteWhole(csvPath, text);
  }
  std::ofstream csv(csvPath, std::ios::app);
  std::set<std::pair<int, std::string>> done;
  for (const TrialRecord& r : records)
    done.insert({ r.trial, r.approach });
  std::printf("evaluate: %s, scenario %s, %d trials x %zu approaches at %s, %zu target points; %zu registrations "
              "already in %s\n",
    options.ct.c_str(), options.scenario.c_str(), options.trials, options.approaches.size(), size.c_str(),
    targets.size(), records.size(), csvPath.c_str());

  std::mt19937 random;
  const Clock::time_point start = Clock::now();
  int registered = 0, remaining = 0;
  for (int trial = 1; trial <= options.trials; ++trial)
    for (const std::string& approach : options.approaches)
      remaining += !done.count({ trial, approach });
  for (int trial = 1; trial <= options.trials; ++trial)
  {
    const Pose truth = DrawMisalignment(options.seed, trial, { options.minTranslation, options.maxTranslation, options.maxRotation }, random);
    const double initialMTRE = MeanTRE(targets, truth, Pose{}, roomIso);
    bool simulated = false;
    std::vector<RegistrationView> views;
    for (const std::string& approach : options.approaches)
    {
      if (done.count({ trial, approach }))
        continue;
      if (!simulated)
      {
        for (const XRayView& panel : geometry.views)
        {
          RegistrationView item;
          item.view = panel.Resampled(panel.Columns() / factor, panel.Rows() / factor);
          if (physics)
          {
            // Rendered at the registration size: its rays spread over each (binned) pixel's area.
            item.xray = physics->Simulate(item.view, truth, random);
          }
          else
          {
            const std::vector<uint16_t> xray = ownModel->Simulate(panel, truth, random);
            item.xray = factor > 1 ? ShrinkImage(xray, panel.Columns(), factor) : xray;
          }
          views.push_back(std::move(item));
        }
        simulated = true;
      }
      StereoRegistrationSettings settingsOfApproach = registrationSettings;
      settingsOfApproach.entropyMask = approach == "B";
      const Clock::time_point registrationStart = Clock::now();
      registration->RemoveAllXRaysAndROIs();
      for (const RegistrationView& item : views)
        registration->AddXRayData(ImageFromRowsTopFirst(item.xray, item.view.Columns(), item.view.Rows()));
      registration->SetSettings(settingsOfApproach);
      registration->Update();
      const StereoRegistrationResult& result = registration->GetResult();
      if (!result.failures.empty() && result.failures.front().code == GateCode::InvalidInput)
        throw InputError("registration", result.failures.front().message);

      TrialRecord r;
      r.trial = trial;
      r.approach = approach;
      r.scenario = options.scenario;
      r.initial = truth.Parameters();
      r.initialTranslation = truth.translation.norm();
      r.initialMTRE = initialMTRE;
      r.status = result.ok ? "ok" : "failed";
      const std::array<double, 6> estimated = result.misalignment.Parameters();
      for (int a = 0; a < 6; ++a)
        r.error[a] = estimated[a] - r.initial[a];
      r.mtre = MeanTRE(targets, result.misalignment, truth, roomIso);
      r.success = result.ok && r.mtre < options.successMTRE;
      r.prealignSeconds = result.prealignSeconds;
      r.maskSeconds = result.maskSeconds;
      r.fineSeconds = result.fineSeconds;
      r.totalSeconds = std::chrono::duration<double>(Clock::now() - registrationStart).count();
      r.drrCount = result.drrCount;
      r.evaluations = result.evaluations;
      r.explained = *std::min_element(result.explained.begin(), result.explained.end());
      r.residualMM = *std::max_element(result.viewResidualMM.begin(), result.viewResidualMM.end());
      r.uncovered = *std::max_element(result.uncovered.begin(), result.uncovered.end());
      r.searchApartMM = result.searchDisagreementMM;
      r.searchApartDegrees = result.searchDisagreementDegrees;
      r.validPixels = -1;
      for (const std::vector<uint8_t>& mask : result.masks)
      {
        const long long valid = std::count(mask.begin(), mask.end(), 1);
        r.validPixels = r.validPixels < 0 ? valid : std::min(r.validPixels, valid);
      }
      r.endFaceExcessMin = result.endFaces.empty() ? 0.0 : 1e9;
      r.endFaceExcessMax = result.endFaces.empty() ? 0.0 : -1e9;
      for (const EndFaceEvidence& faces : result.endFaces)
        for (int f = 0; f < 2; ++f)
        {
          r.endFaceExcessMin = std::min(r.endFaceExcessMin, faces.excess[f]);
          r.endFaceExcessMax = std::max(r.endFaceExcessMax, faces.excess[f]);
          r.endFacesLeftOut += (faces.facesToLeaveOut >> f) & 1;
        }
      for (const std::string& reason : result.Reasons())
        r.reasons += (r.reasons.empty() ? "" : "; ") + reason;
      csv << TrialCSVRow(r) << std::endl; // flushed: an interruption keeps every finished registration
      records.push_back(r);
      ++registered;

      int successes = 0, count = 0;
      for (const TrialRecord& other : records)
        if (other.approach == approach)
          ++count, successes += other.success;
      const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      std::printf("trial %d of %d, %s: initial %.1f mm (mTRE %.1f), final mTRE %.3f mm, %s, %.1f s | success %s %d/%d | "
                  "about %.0f min left\n",
        trial, options.trials, approach == "A" ? "A (whole image)" : "B (entropy masks)", r.initialTranslation,
        r.initialMTRE, r.mtre, r.success ? "success" : (result.ok ? "ok but off" : "failed"), r.totalSeconds,
        approach.c_str(), successes, count, elapsed / registered * (remaining - registered) / 60.0);
      std::fflush(stdout);
    }
  }
  if (!csv)
  {
    throw Error(csvPath, "cannot append a trial");
  }
  // The summary covers trials 1..N of this run; rows of a longer earlier run stay in trials.csv.
  records.erase(std::remove_if(records.begin(), records.end(), [&](const TrialRecord& r) { return r.trial > options.trials; }),
    records.end());
  WriteWhole(directory + "/summary.json", SummaryJSON(records, options.successMTRE));
  WriteEvaluationPlots(records, options.successMTRE, directory);
  std::printf("\n%s\nwrote trials.csv, summary.json and plots to %s\n", SummaryTable(records).c_str(), directory.c_str());
  return ExitOk;
}

} // namespace xp
