#include "xpAccuracyEvaluation.h"

#include "xpRegistrationSession.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpImageRows.h"

#include <vtkImageData.h>

#include <algorithm>
#include <chrono>
#include <filesystem>

namespace xp
{

namespace
{

/** The X-rays of a trial as 16-bit PNGs (values as made), and the geometry at their size, to look
 *  at or to register again with `xpose register --geometry xrays/geometry.json`. */
void WriteTrialXRays(const std::vector<RegistrationView>& views, int trial, const std::filesystem::path& directory,
  const Eigen::Vector3d& isocenter)
{
  std::filesystem::create_directories(directory);
  StereoGeometry geometry;
  geometry.name = "evaluation X-rays";
  geometry.isocenter = isocenter;
  for (const RegistrationView& item : views)
    geometry.views.push_back(item.view);
  WriteStereoGeometry(geometry, (directory / "geometry.json").string());
  for (const RegistrationView& item : views)
    WritePNG(ImageFromRowsTopFirst(item.xray, item.view.Columns(), item.view.Rows()),
      (directory / ("trial_" + std::to_string(trial) + "_" + item.view.name + ".png")).string());
}

/** TrialRecord's evaluations by what they served, as the trace's stages record it. */
void CountStageEvaluations(const StereoRegistrationResult& result, TrialRecord& r)
{
  for (const RegistrationStage& traced : result.stages)
  {
    int& count = traced.secondEnd                    ? r.secondEndEvaluations
      : traced.kind == StageKind::Search            ? r.searchEvaluations
      : traced.kind == StageKind::Refinement        ? r.refinementEvaluations
      : traced.kind == StageKind::Polish || traced.kind == StageKind::Restarts ? r.polishEvaluations
                                                    : r.gateEvaluations;
    count += traced.evaluations;
  }
}

} // namespace

TrialRecord MakeTrialRecord(int trial, const std::string& approach, const std::string& scenario, const Pose& truth,
  const StereoRegistrationResult& result, const std::vector<Eigen::Vector3d>& targets,
  const Eigen::Vector3d& roomIsocenter, double successMTRE, double seconds)
{
  TrialRecord r;
  r.trial = trial;
  r.approach = approach;
  r.scenario = scenario;
  r.initial = truth.Parameters();
  r.initialTranslation = truth.translation.norm();
  r.initialMTRE = MeanTRE(targets, truth, Pose{}, roomIsocenter);
  r.status = result.ok ? "ok" : "failed";
  const std::array<double, 6> estimated = result.misalignment.Parameters();
  for (int a = 0; a < 6; ++a)
    r.error[a] = estimated[a] - r.initial[a];
  r.mtre = MeanTRE(targets, result.misalignment, truth, roomIsocenter);
  r.success = result.ok && r.mtre < successMTRE;
  r.prealignSeconds = result.prealignSeconds;
  r.maskSeconds = result.maskSeconds;
  r.fineSeconds = result.fineSeconds;
  r.totalSeconds = seconds;
  r.drrCount = result.drrCount;
  r.evaluations = result.evaluations;
  CountStageEvaluations(result, r);
  if (!result.explained.empty())
  {
    r.explained = *std::min_element(result.explained.begin(), result.explained.end());
    r.residualMM = *std::max_element(result.viewResidualMM.begin(), result.viewResidualMM.end());
    r.uncovered = *std::max_element(result.uncovered.begin(), result.uncovered.end());
    r.halvesApartMM = *std::max_element(result.halvesApartMM.begin(), result.halvesApartMM.end());
  }
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
  r.peakMargin = result.peakMargin;
  r.peakLeads = result.peakLeads;
  r.edgeMM = result.edgeDistanceMM;
  r.edgeMovedMM = result.edgeDistanceShiftedMM;
  r.xrayRankNoise = result.xrayRankNoise;
  if (result.table)
    r.table = result.table->keptTable ? "ct" : "body_only";
  r.uncertaintyMM = std::max({ result.uncertainty[0], result.uncertainty[1], result.uncertainty[2] });
  r.uncertaintyDegrees = std::max({ result.uncertainty[3], result.uncertainty[4], result.uncertainty[5] });
  for (const std::string& reason : result.Reasons())
    r.reasons += (r.reasons.empty() ? "" : "; ") + reason;
  return r;
}

AccuracyEvaluation::AccuracyEvaluation(const EvaluationScenario& scenario, vtkImageData* ct, const PatientSetup& patient,
  const StereoGeometry& geometry, const AccuracyEvaluationSettings& settings, vtkImageData* xrayCT)
  : Scenario(scenario.Name())
  , Settings(settings)
  , RoomIsocenter(patient.roomIsocenter)
  , XRays(scenario, xrayCT ? xrayCT : ct, patient, geometry.views, settings.shrinkFactor)
{
  const Eigen::Vector3d isoInCT = patient.IsocenterInCT(ImageCenter(ct));
  this->Targets = TargetPoints(ct, isoInCT, patient.PlannedCTToRoom(ImageCenter(ct)));
  // The X-rays reach the session at the registration size.
  StereoGeometry registrationGeometry = geometry;
  for (XRayView& panel : registrationGeometry.views)
    panel = panel.Resampled(panel.Columns() / settings.shrinkFactor, panel.Rows() / settings.shrinkFactor);
  // The isocentre stays where the whole CT puts it: a cut CT's centre is elsewhere.
  this->Session = std::make_unique<RegistrationSession>(scenario.RegistrationCT(ct),
    PatientSetup{ patient.position, isoInCT, patient.roomIsocenter }, registrationGeometry);
}

AccuracyEvaluation::~AccuracyEvaluation() = default;

void AccuracyEvaluation::Run(
  int trials, const std::vector<std::string>& approaches, EvaluationFolder& folder, const Progress& progress)
{
  int registered = 0, remaining = 0;
  for (int trial = 1; trial <= trials; ++trial)
    for (const std::string& approach : approaches)
      remaining += !folder.Done(trial, approach);
  std::mt19937 random;
  for (int trial = 1; trial <= trials; ++trial)
  {
    const Pose truth = DrawMisalignment(this->Settings.seed, trial, this->Settings.range, random);
    std::vector<RegistrationView> views; // simulated once, for the first approach not yet done
    for (const std::string& approach : approaches)
    {
      if (folder.Done(trial, approach))
        continue;
      if (views.empty())
      {
        views = this->XRays.Simulate(truth, random);
        if (this->Settings.writeXRays)
          WriteTrialXRays(views, trial, std::filesystem::path(folder.CSVPath()).parent_path() / "xrays", this->RoomIsocenter);
      }
      const TrialRecord record = this->Register(trial, approach, truth, views);
      folder.Append(record);
      ++registered;
      if (progress)
        progress(record, registered, remaining);
    }
  }
}

const StereoRegistrationResult& AccuracyEvaluation::LastResult() const
{
  return this->Session->Result();
}

TrialRecord AccuracyEvaluation::Register(
  int trial, const std::string& approach, const Pose& truth, const std::vector<RegistrationView>& views)
{
  StereoRegistrationSettings settings = this->Settings.registration;
  settings.entropyMask = approach == "B";
  const auto start = std::chrono::steady_clock::now();
  std::vector<vtkSmartPointer<vtkImageData>> xrays;
  for (const RegistrationView& item : views)
    xrays.push_back(ImageFromRowsTopFirst(item.xray, item.view.Columns(), item.view.Rows()));
  this->Session->SetXRays(xrays);
  this->Session->Run(settings);
  const StereoRegistrationResult& result = this->Session->Result();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return MakeTrialRecord(trial, approach, this->Scenario, truth, result, this->Targets, this->RoomIsocenter,
    this->Settings.successMTRE, seconds);
}

} // namespace xp
