#include "xpCommands.h"
#include "xpRegistrationInputs.h"

#include "xpBodyMask.h"

#include "vtkXPDRRFilter.h"

#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpDICOMXRay.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpImageGeometry.h"
#include "xpStereoRegistration.h"

#include <vtkImageData.h>
#include <vtkPointData.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::string JsonString(const std::string& text)
{
  std::string out = "\"";
  for (char c : text)
    out += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return out + "\"";
}

} // namespace

int RegistrationShrinkFactor(const std::vector<XRayView>& panels, const std::string& size)
{
  if (size.empty())
    return 1;
  const auto [columns, rows] = ParseSize(size, "--size");
  const int factor = panels[0].Columns() / columns;
  for (const XRayView& panel : panels)
  {
    if (factor < 1 || panel.Columns() != columns * factor || panel.Rows() != rows * factor)
    {
      throw InputError("--size", size + " must divide imager " + panel.name + "'s " + std::to_string(panel.Columns()) + "x" +
          std::to_string(panel.Rows()) + " pixels by a whole number");
    }
  }
  return factor;
}

RegistrationInputs LoadRegistrationInputs(const RegisterOptions& options)
{
  RegistrationInputs inputs;
  inputs.setup = MakeDRRSetup(options.ct, options.series, options.geometry, options.isocenterInCT, options.muWater,
    "trilinear", 0.0);
  if (options.removeTable)
  {
    // The CT's table is not the treatment couch: render from the body alone.
    inputs.setup.ct.image = BodyOnly(inputs.setup.ct.image, {}, &inputs.tableVoxelsRemoved);
    inputs.setup.filter->SetInputData(inputs.setup.ct.image);
  }
  const DRRSetup& setup = inputs.setup;
  ValidateStereoGeometry(setup.geometry, options.geometry);
  const std::vector<XRayView>& panels = setup.geometry.views;
  if (options.xrays.size() != panels.size())
  {
    throw InputError("--xray", "the geometry has " + std::to_string(panels.size()) + " imagers; give one X-ray each, in order (got " +
        std::to_string(options.xrays.size()) + ")");
  }
  if (!options.rois.empty() && options.rois.size() != panels.size())
  {
    throw InputError("--roi", "give one ROI per X-ray, in the same order");
  }
  const int factor = RegistrationShrinkFactor(panels, options.size);
  for (size_t v = 0; v < panels.size(); ++v)
  {
    vtkSmartPointer<vtkImageData> xray = ReadXRayImage(options.xrays[v]);
    int dims[3];
    xray->GetDimensions(dims);
    if (dims[0] != panels[v].Columns() || dims[1] != panels[v].Rows())
    {
      throw InputError(options.xrays[v], "is " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " pixels, imager " +
          panels[v].name + " of " + options.geometry + " has " + std::to_string(panels[v].Columns()) + "x" +
          std::to_string(panels[v].Rows()));
    }
    RegistrationView item;
    item.view = panels[v].Resampled(panels[v].Columns() / factor, panels[v].Rows() / factor);
    item.xray = factor > 1 ? ShrinkImage(RowsTopFirst<uint16_t>(xray), dims[0], factor) : RowsTopFirst<uint16_t>(xray);
    if (!options.rois.empty())
    {
      item.mask = RowsTopFirst<uint8_t>(ReadMaskPNG(options.rois[v], dims[0], dims[1]));
      item.mask = factor > 1 ? ShrinkMask(item.mask, dims[0], factor) : item.mask;
    }
    for (size_t earlier = 0; earlier < inputs.views.size(); ++earlier)
    {
      if (inputs.views[earlier].xray == item.xray)
      {
        throw InputError("--xray", options.xrays[v] + " (imager " + panels[v].name + ") holds the same image as " +
            options.xrays[earlier] + " (imager " + panels[earlier].name + "): each imager needs its own X-ray");
      }
    }
    inputs.views.push_back(std::move(item));
  }
  vtkImageData* ct = setup.ct.image;
  inputs.isoInCT = setup.patient.IsocenterInCT(ImageCenter(ct));
  inputs.planned = setup.patient.PlannedCTToRoom(ImageCenter(ct));
  return inputs;
}

void CheckRegisterOptions(const RegisterOptions& options)
{
  CheckLimit(options.bins, 8, 256, "--bins");
  CheckLimit(options.maxEvaluations, 10, 100000, "--max-evaluations");
  CheckLimit(options.maxTranslation, 0.1, 500.0, "--max-translation");
  CheckLimit(options.maxRotation, 0.1, 180.0, "--max-rotation");
}

int RunRegister(const RegisterOptions& options)
{
  const Clock::time_point start = Clock::now();
  UseThreads(options.threads);
  CheckRegisterOptions(options);
  // Output folders are checked before the work, not after it: a registration whose result
  // cannot be written must not run for seconds and then fail.
  StagedOutputDirectory::CheckWritable(options.outputDirectory);
  if (!options.reportDirectory.empty())
  {
    StagedOutputDirectory::CheckWritable(options.reportDirectory);
  }
  // --- read and check every input before any work ---
  const RegistrationInputs inputs = LoadRegistrationInputs(options);
  const DRRSetup& setup = inputs.setup;
  const std::vector<RegistrationView>& views = inputs.views;
  const double readSeconds = Since(start);
  std::printf("read: CT %s, %zu X-rays, registering at %dx%d per view (%.2f s)\n", options.ct.c_str(), views.size(),
    views[0].view.Columns(), views[0].view.Rows(), readSeconds);
  if (options.removeTable)
    std::printf("table: %lld voxels outside the body set to air\n", inputs.tableVoxelsRemoved);

  // --- the method (Modules/Registration) ---
  const std::unique_ptr<AttenuationVolume> volume = MakeAttenuationVolume(setup.ct.image, options.muWater);
  const Eigen::Vector3d& roomIso = setup.geometry.isocenter;
  StereoRegistrationSettings settings;
  settings.entropyMask = options.entropyMask;
  settings.bins = options.bins;
  settings.maxEvaluations = options.maxEvaluations;
  settings.maxTranslation = options.maxTranslation;
  settings.maxRotation = options.maxRotation;
  settings.minExplained = options.minExplained;
  settings.maxViewResidual = options.maxViewResidual;
  const StereoRegistrationResult result = RegisterStereo(*volume, inputs.planned, roomIso, views, settings);
  std::printf("pre-alignment: %s, %d iterations (%.2f s)\nmasks: valid fraction", result.prealignment.pose.ToString().c_str(),
    result.prealignment.iterations, result.prealignSeconds);
  for (size_t v = 0; v < views.size(); ++v)
    std::printf(" %s %.3f", views[v].view.name.c_str(), result.validFraction[v]);
  std::printf(" (%.2f s)\nfine 6-DOF: %s, %d evaluations (%.2f s)\n", result.maskSeconds, result.misalignment.ToString().c_str(),
    result.evaluations, result.fineSeconds);
  const bool ok = result.ok;
  const std::vector<std::string>& reasons = result.reasons;
  const Pose& correction = result.correction;
  const double totalSeconds = Since(start);

  // --- outputs ---
  StagedOutputDirectory output(options.outputDirectory);
  std::ostringstream json;
  json << "{\n  \"status\": \"" << (ok ? "ok" : "failed") << "\",\n  \"misalignment\": " << JsonPose(result.misalignment)
       << ",\n  \"correction\": " << JsonPose(correction)
       << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
       << ",\n  \"similarity\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << JsonString(views[v].view.name) << ": " << result.mutualInformation[v] << ", ";
  json << "\"objective\": " << result.objective << "},\n  \"explained_information\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << (v ? ", " : "") << JsonString(views[v].view.name) << ": " << result.explained[v];
  json << "},\n  \"uncovered_fraction\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << (v ? ", " : "") << JsonString(views[v].view.name) << ": " << result.uncovered[v];
  json << "},\n  \"mask_valid_fraction\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << (v ? ", " : "") << JsonString(views[v].view.name) << ": " << result.validFraction[v];
  json << "},\n  \"drr_count\": " << result.drrCount << ",\n  \"evaluations\": " << result.evaluations
       << ",\n  \"timing_s\": {\"read\": " << readSeconds << ", \"prealign\": " << result.prealignSeconds
       << ", \"mask\": " << result.maskSeconds << ", \"fine\": " << result.fineSeconds << ", \"total\": " << totalSeconds
       << "},\n  \"search_disagreement\": {\"mm\": " << result.searchDisagreementMM
       << ", \"degrees\": " << result.searchDisagreementDegrees << ", \"objective_ratio\": " << result.searchObjectiveRatio
       << "},\n  \"reasons\": [";
  for (size_t r = 0; r < reasons.size(); ++r)
    json << (r ? ", " : "") << JsonString(reasons[r]);
  // What `xpose report` needs to rebuild the pictures: the inputs (absolute paths) and the trace.
  const auto absolute = [](const std::string& path) { return JsonString(std::filesystem::absolute(path).lexically_normal().string()); };
  json << "],\n  \"inputs\": {\"ct\": " << absolute(options.ct) << ", \"series\": " << JsonString(options.series)
       << ", \"geometry\": " << absolute(options.geometry) << ", \"xrays\": [";
  for (size_t v = 0; v < options.xrays.size(); ++v)
    json << (v ? ", " : "") << absolute(options.xrays[v]);
  json << "], \"xray_md5\": [";
  for (size_t v = 0; v < options.xrays.size(); ++v)
    json << (v ? ", " : "") << JsonString(FileMD5(options.xrays[v]));
  json << "], \"rois\": [";
  for (size_t v = 0; v < options.rois.size(); ++v)
    json << (v ? ", " : "") << absolute(options.rois[v]);
  json << "], \"size\": " << JsonString(options.size) << ", \"iso_ct\": " << JsonString(options.isocenterInCT)
       << ", \"mu_water\": " << options.muWater << ", \"entropy_mask\": " << (options.entropyMask ? "true" : "false")
       << ", \"remove_table\": " << (options.removeTable ? "true" : "false")
       << "},\n  \"convergence\": {\"stages\": [";
  for (size_t n = 0; n < result.stages.size(); ++n)
    json << (n ? ", " : "") << "{\"name\": " << JsonString(result.stages[n].name)
         << ", \"first_evaluation\": " << result.stages[n].firstEvaluation << ", \"seconds\": " << result.stages[n].seconds
         << "}";
  json << "], \"objective\": [";
  for (size_t n = 0; n < result.objectiveTrace.size(); ++n)
    json << (n ? ", " : "") << result.objectiveTrace[n];
  json << "]}\n}\n";
  for (size_t v = 0; v < views.size(); ++v)
  {
    const int columns = views[v].view.Columns(), rows = views[v].view.Rows();
    std::vector<uint8_t> mask255(result.masks[v].size());
    std::transform(result.masks[v].begin(), result.masks[v].end(), mask255.begin(), [](uint8_t m) { return m ? 255 : 0; });
    WritePNG(ImageFromRowsTopFirst(mask255, columns, rows), output.Path("mask_" + views[v].view.name + ".png"));
    WritePNG(ImageFromRowsTopFirst(result.drrs[v], columns, rows), output.Path("drr_" + views[v].view.name + ".png"));
    if (!result.entropyMaps.empty())
    {
      std::vector<uint8_t> map(result.entropyMaps[v].size());
      std::transform(result.entropyMaps[v].begin(), result.entropyMaps[v].end(), map.begin(),
        [](float h) { return static_cast<uint8_t>(std::lround(255.0 * std::clamp(h, 0.0f, 1.0f))); });
      WritePNG(ImageFromRowsTopFirst(map, columns, rows), output.Path("entropy_" + views[v].view.name + ".png"));
    }
  }
  // The record last: a folder with a result.json holds that run's complete output.
  std::ofstream record(output.Path("result.json"));
  record << json.str();
  record.close();
  if (!record)
  {
    throw Error(options.outputDirectory + "/result.json", "cannot be written");
  }
  output.ReplaceEarlier({ "drr_*.png", "mask_*.png", "entropy_*.png" });
  output.Commit();

  std::printf("\n%s\nmisalignment: %s\ncorrection:   %s\n(IEC 61217 fixed, R = Rz(yaw) Ry(roll) Rx(pitch); apply the "
              "correction to the table only when status is ok)\nDRRs: %lld, evaluations: %d, total %.2f s; result.json in %s\n",
    ok ? "status: ok" : "status: FAILED", result.misalignment.ToString().c_str(), correction.ToString().c_str(),
    result.drrCount, result.evaluations, totalSeconds, options.outputDirectory.c_str());
  for (const std::string& reason : reasons)
    std::printf("  reason: %s\n", reason.c_str());
  if (!options.reportDirectory.empty())
  {
    ReportOptions report;
    report.result = options.outputDirectory + "/result.json";
    report.outputDirectory = options.reportDirectory;
    RunReport(report);
  }
  return ok ? ExitOk : ExitRegistrationFailed;
}

} // namespace xp
