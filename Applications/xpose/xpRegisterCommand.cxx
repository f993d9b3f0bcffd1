#include "xpCommands.h"
#include "xpDRRSetup.h"

#include "xpAttenuationVolume.h"
#include "xpEntropyMask.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpPoseOptimizer.h"
#include "xpPreAlignment.h"
#include "xpStereoSimilarity.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>

#include <chrono>
#include <cmath>
#include <cstdio>
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

/** Rows of a VTK image (bottom-up) as a top-row-first vector. */
template <typename T>
std::vector<T> TopRowFirst(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  const T* in = static_cast<const T*>(image->GetScalarPointer());
  std::vector<T> out(static_cast<size_t>(dims[0]) * dims[1]);
  for (int row = 0; row < dims[1]; ++row)
    std::copy(in + static_cast<size_t>(dims[1] - 1 - row) * dims[0], in + static_cast<size_t>(dims[1] - row) * dims[0],
      out.begin() + static_cast<size_t>(row) * dims[0]);
  return out;
}

/** Box-averages a columns x rows image by an integer factor (the registration resolution). */
template <typename T>
std::vector<T> Shrink(const std::vector<T>& in, int columns, int factor, bool anyValid = false)
{
  const int rows = static_cast<int>(in.size() / columns), outColumns = columns / factor, outRows = rows / factor;
  std::vector<T> out(static_cast<size_t>(outColumns) * outRows);
  for (int r = 0; r < outRows; ++r)
    for (int c = 0; c < outColumns; ++c)
    {
      double sum = 0.0;
      bool all = true;
      for (int y = 0; y < factor; ++y)
        for (int x = 0; x < factor; ++x)
        {
          const T v = in[static_cast<size_t>(r * factor + y) * columns + c * factor + x];
          sum += v;
          all = all && v;
        }
      out[static_cast<size_t>(r) * outColumns + c] =
        anyValid ? static_cast<T>(all ? 1 : 0) : static_cast<T>(std::lround(sum / (factor * factor)));
    }
  return out;
}

/** A top-row-first 2D image as VTK image data (bottom-up) for the PNG writer. */
template <typename T>
vtkSmartPointer<vtkImageData> ToVTK(const std::vector<T>& image, int columns, int rows, int type)
{
  auto out = vtkSmartPointer<vtkImageData>::New();
  out->SetDimensions(columns, rows, 1);
  out->AllocateScalars(type, 1);
  T* p = static_cast<T*>(out->GetScalarPointer());
  for (int row = 0; row < rows; ++row)
    std::copy(image.begin() + static_cast<size_t>(row) * columns, image.begin() + static_cast<size_t>(row + 1) * columns,
      p + static_cast<size_t>(rows - 1 - row) * columns);
  return out;
}

std::string JsonString(const std::string& text)
{
  std::string out = "\"";
  for (char c : text)
    out += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  return out + "\"";
}

} // namespace

int RunRegister(const RegisterOptions& options)
{
  const Clock::time_point start = Clock::now();
  UseThreads(options.threads);
  if (options.bins < 8 || options.bins > 256)
  {
    throw InputError("--bins", "must be between 8 and 256");
  }
  // --- read and check every input before any work ---
  DRRSetup setup = MakeDRRSetup(options.ct, options.series, options.geometry, options.isocenterInCT, options.muWater,
    "trilinear", 0.0);
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
  int factor = 1;
  if (!options.size.empty())
  {
    const auto [columns, rows] = ParseSize(options.size, "--size");
    factor = panels[0].Columns() / columns;
    for (const XRayView& panel : panels)
    {
      if (factor < 1 || panel.Columns() != columns * factor || panel.Rows() != rows * factor)
      {
        throw InputError("--size", options.size + " must divide imager " + panel.name + "'s " +
            std::to_string(panel.Columns()) + "x" + std::to_string(panel.Rows()) + " pixels by a whole number");
      }
    }
  }
  std::vector<RegistrationView> views;
  std::vector<std::vector<uint8_t>> rois;
  for (size_t v = 0; v < panels.size(); ++v)
  {
    vtkSmartPointer<vtkImageData> xray = ReadXRayPNG(options.xrays[v]);
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
    item.xray = Shrink(TopRowFirst<uint16_t>(xray), dims[0], factor);
    std::vector<uint8_t> roi;
    if (!options.rois.empty())
    {
      roi = Shrink(TopRowFirst<uint8_t>(ReadMaskPNG(options.rois[v], dims[0], dims[1])), dims[0], factor, true);
    }
    rois.push_back(roi);
    views.push_back(std::move(item));
  }
  const double readSeconds = Since(start);
  std::printf("read: CT %s, %zu X-rays, registering at %dx%d per view (%.2f s)\n", options.ct.c_str(), views.size(),
    views[0].view.Columns(), views[0].view.Rows(), readSeconds);

  // --- attenuation volume and planned set-up ---
  vtkImageData* ct = setup.ct.image;
  const std::unique_ptr<AttenuationVolume> attenuation = MakeAttenuationVolume(ct, options.muWater);
  const AttenuationVolume& volume = *attenuation;
  Eigen::Vector3d isoInCT;
  if (options.isocenterInCT.empty())
    ImageCenter(ct, isoInCT.data());
  else
    isoInCT = Eigen::Vector3d(setup.filter->GetIsocenterInCT());
  const Eigen::Vector3d& roomIso = setup.geometry.isocenter;
  const Eigen::Isometry3d planned =
    PlannedCTToRoom(ParsePatientPosition(setup.ct.patientPosition, options.ct), isoInCT, roomIso);

  // Coarse stages run at half resolution (a quarter of the rays) when the images allow it.
  const bool pyramid = views[0].view.Columns() >= 256 && views[0].view.Rows() >= 192;
  const auto halfOf = [&](const RegistrationView& item)
  {
    RegistrationView small;
    small.view = item.view.Resampled(item.view.Columns() / 2, item.view.Rows() / 2);
    small.xray = Shrink(item.xray, item.view.Columns(), 2);
    small.mask = item.mask.empty() ? item.mask : Shrink(item.mask, item.view.Columns(), 2, true);
    return small;
  };

  // --- pre-alignment (5+1 DOF), user ROIs only ---
  const Clock::time_point prealignStart = Clock::now();
  std::vector<RegistrationView> roiViews;
  for (size_t v = 0; v < views.size(); ++v)
  {
    RegistrationView item = views[v];
    item.mask = rois[v];
    roiViews.push_back(pyramid ? halfOf(item) : item);
  }
  StereoSimilarity coarse(volume, planned, roomIso, roiViews, options.bins);
  const PreAlignmentResult prealigned = PreAlign(coarse, Pose{}, roomIso);
  const double prealignSeconds = Since(prealignStart);
  std::printf("pre-alignment at %dx%d: %s, %d iterations, %lld DRRs (%.2f s)\n", roiViews[0].view.Columns(),
    roiViews[0].view.Rows(), prealigned.pose.ToString().c_str(), prealigned.iterations, prealigned.drrs, prealignSeconds);

  // --- masks: block entropy of each X-ray AND its ROI, transferred into the DRR plane ---
  const Clock::time_point maskStart = Clock::now();
  std::vector<EntropyMaskResult> entropy(views.size());
  for (size_t v = 0; v < views.size(); ++v)
  {
    const int columns = views[v].view.Columns(), rows = views[v].view.Rows();
    std::vector<uint8_t> mask;
    if (options.entropyMask)
    {
      entropy[v] = ComputeEntropyMask(views[v].xray.data(), columns, rows, rois[v].empty() ? nullptr : rois[v].data());
      mask = entropy[v].mask;
    }
    else
    {
      mask = rois[v].empty() ? std::vector<uint8_t>(views[v].xray.size(), 1) : rois[v];
    }
    views[v].mask = TransferMask(mask, views[v].view, views[v].view);
    if (std::count(views[v].mask.begin(), views[v].mask.end(), 1) == 0)
    {
      throw InputError(options.xrays[v], "the validity mask is empty: nothing left to register");
    }
  }
  const double maskSeconds = Since(maskStart);

  // --- 6-DOF fine alignment over both views with masked DRRs, coarse to fine ---
  const Clock::time_point fineStart = Clock::now();
  Pose startPose = prealigned.pose;
  int evaluations = 0;
  long long coarseDRRs = 0;
  if (pyramid)
  {
    // Half resolution first: a quarter of the rays per evaluation for most of the simplex's travel.
    std::vector<RegistrationView> half;
    for (const RegistrationView& item : views)
      half.push_back(halfOf(item));
    StereoSimilarity halfSimilarity(volume, planned, roomIso, half, options.bins);
    PoseOptimizerSettings halfSettings;
    halfSettings.initialStepMM = 1.0;
    halfSettings.initialStepDegrees = 0.5;
    halfSettings.toleranceMM = 0.1;
    halfSettings.toleranceDegrees = 0.05;
    halfSettings.maxEvaluations = options.maxEvaluations;
    const PoseOptimizerResult halfResult =
      MaximizePose([&](const Pose& p) { return halfSimilarity.Evaluate(p); }, startPose, halfSettings);
    startPose = halfResult.pose;
    evaluations += halfResult.evaluations;
    std::printf("fine 6-DOF at %dx%d: %s, %d evaluations (%.2f s)\n", half[0].view.Columns(), half[0].view.Rows(),
      halfResult.pose.ToString().c_str(), halfResult.evaluations, Since(fineStart));
    coarseDRRs = halfSimilarity.RenderedDRRs();
  }
  StereoSimilarity fine(volume, planned, roomIso, views, options.bins);
  PoseOptimizerSettings settings;
  settings.initialStepMM = coarseDRRs > 0 ? 0.25 : 1.0;
  settings.initialStepDegrees = coarseDRRs > 0 ? 0.15 : 0.5;
  settings.toleranceMM = 0.05;      // 0.05 mm and 0.03 degrees: ten times finer than the
  settings.toleranceDegrees = 0.03; // accuracy asked of the result, at a third of the evaluations
  settings.maxEvaluations = options.maxEvaluations;
  PoseOptimizerResult result = MaximizePose([&](const Pose& p) { return fine.Evaluate(p); }, startPose, settings);
  result.evaluations += evaluations;
  fine.Evaluate(result.pose);
  const double fineSeconds = Since(fineStart);
  std::printf("fine 6-DOF: %s, %d evaluations, %s (%.2f s)\n", result.pose.ToString().c_str(), result.evaluations,
    result.stopReason.c_str(), fineSeconds);

  // --- quality gate ---
  std::vector<std::string> reasons;
  if (!result.converged)
    reasons.push_back("the optimiser did not converge (" + result.stopReason + ")");
  const Pose correction = result.pose.Inverse();
  const double maxAngle = std::max({ std::abs(result.pose.pitch), std::abs(result.pose.roll), std::abs(result.pose.yaw) });
  char limit[160];
  if (result.pose.translation.cwiseAbs().maxCoeff() > options.maxTranslation)
  {
    std::snprintf(limit, sizeof(limit), "the correction exceeds %.1f mm", options.maxTranslation);
    reasons.push_back(limit);
  }
  if (maxAngle > options.maxRotation)
  {
    std::snprintf(limit, sizeof(limit), "the correction exceeds %.1f degrees", options.maxRotation);
    reasons.push_back(limit);
  }
  std::vector<double> agreement;
  for (size_t v = 0; v < views.size(); ++v)
  {
    // How much of the X-ray's information the final DRR explains: MI / H(X-ray), over valid pixels.
    JointHistogram h(options.bins);
    h.Compute(views[v].xray.data(), fine.LastDRR(v).data(), static_cast<long long>(views[v].xray.size()),
      views[v].mask.data(), views[v].mask.data());
    const double explained = h.FixedEntropy() > 0 ? h.MutualInformation() / h.FixedEntropy() : 0.0;
    agreement.push_back(explained);
    if (explained < options.minSimilarity)
    {
      char text[160];
      std::snprintf(text, sizeof(text), "view %s: the final DRR explains %.3f of the X-ray's information (< %.3f)",
        views[v].view.name.c_str(), explained, options.minSimilarity);
      reasons.push_back(text);
    }
    // A view whose own 2D registration still wants to move disagrees with the 3D result.
    const Motion2D residual = Register2D(views[v].xray, fine.LastDRR(v), views[v].view.Columns(), views[v].view.Rows(),
      views[v].view.Project(roomIso), views[v].mask.data(), options.bins);
    const double shiftMM = residual.shift.norm() * views[v].view.pixelSpacing[0] *
      (views[v].view.source - roomIso).norm() / views[v].view.SourceToPanelDistance();
    if (shiftMM > options.maxViewResidual || std::abs(residual.rotation) > 1.0)
    {
      char text[160];
      std::snprintf(text, sizeof(text), "view %s disagrees with the 3D result: residual %.2f mm, %.2f degrees in 2D",
        views[v].view.name.c_str(), shiftMM, residual.rotation);
      reasons.push_back(text);
    }
  }
  const bool ok = reasons.empty();
  const double totalSeconds = Since(start);

  // --- outputs ---
  StagedOutputDirectory output(options.outputDirectory);
  std::ostringstream json;
  json << "{\n  \"status\": \"" << (ok ? "ok" : "failed") << "\",\n  \"misalignment\": " << JsonPose(result.pose)
       << ",\n  \"correction\": " << JsonPose(correction)
       << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
       << ",\n  \"similarity\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << JsonString(views[v].view.name) << ": " << fine.LastMutualInformation()[v] << ", ";
  json << "\"objective\": " << result.value << "},\n  \"explained_information\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << (v ? ", " : "") << JsonString(views[v].view.name) << ": " << agreement[v];
  json << "},\n  \"mask_valid_fraction\": {";
  for (size_t v = 0; v < views.size(); ++v)
    json << (v ? ", " : "") << JsonString(views[v].view.name) << ": "
         << static_cast<double>(std::count(views[v].mask.begin(), views[v].mask.end(), 1)) / views[v].mask.size();
  json << "},\n  \"drr_count\": " << coarse.RenderedDRRs() + coarseDRRs + fine.RenderedDRRs() << ",\n  \"evaluations\": " << result.evaluations
       << ",\n  \"timing_s\": {\"read\": " << readSeconds << ", \"prealign\": " << prealignSeconds << ", \"mask\": " << maskSeconds
       << ", \"fine\": " << fineSeconds << ", \"total\": " << totalSeconds << "},\n  \"reasons\": [";
  for (size_t r = 0; r < reasons.size(); ++r)
    json << (r ? ", " : "") << JsonString(reasons[r]);
  json << "]\n}\n";
  std::ofstream(output.Path("result.json")) << json.str();
  for (size_t v = 0; v < views.size(); ++v)
  {
    const int columns = views[v].view.Columns(), rows = views[v].view.Rows();
    std::vector<uint8_t> mask255(views[v].mask.size());
    std::transform(views[v].mask.begin(), views[v].mask.end(), mask255.begin(), [](uint8_t m) { return m ? 255 : 0; });
    WritePNG(ToVTK(mask255, columns, rows, VTK_UNSIGNED_CHAR), output.Path("mask_" + views[v].view.name + ".png"));
    WritePNG(ToVTK(fine.LastDRR(v), columns, rows, VTK_UNSIGNED_SHORT), output.Path("drr_" + views[v].view.name + ".png"));
    if (options.entropyMask)
    {
      std::vector<uint8_t> map(entropy[v].entropy.size());
      std::transform(entropy[v].entropy.begin(), entropy[v].entropy.end(), map.begin(),
        [](float h) { return static_cast<uint8_t>(std::lround(255.0 * std::clamp(h, 0.0f, 1.0f))); });
      WritePNG(ToVTK(map, columns, rows, VTK_UNSIGNED_CHAR), output.Path("entropy_" + views[v].view.name + ".png"));
    }
  }
  output.Commit();

  std::printf("\n%s\nmisalignment: %s\ncorrection:   %s\n(IEC 61217 fixed, R = Rz(yaw) Ry(roll) Rx(pitch); apply the "
              "correction to the table only when status is ok)\nDRRs: %lld, evaluations: %d, total %.2f s; result.json in %s\n",
    ok ? "status: ok" : "status: FAILED", result.pose.ToString().c_str(), correction.ToString().c_str(),
    coarse.RenderedDRRs() + coarseDRRs + fine.RenderedDRRs(), result.evaluations, totalSeconds, options.outputDirectory.c_str());
  for (const std::string& reason : reasons)
    std::printf("  reason: %s\n", reason.c_str());
  return ok ? ExitOk : ExitRegistrationFailed;
}

} // namespace xp
