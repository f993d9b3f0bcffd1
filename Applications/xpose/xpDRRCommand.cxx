#include "xpCommands.h"
#include "xpVolumeIO.h"
#include "xpRegistrationWriters.h"

#include "xpError.h"
#include "xpImageIO.h"
#include "xpImageGeometry.h"
#include "xpImageRows.h"
#include "xpPose.h"
#include "xpRTImageGeometry.h"
#include "xpSpatialRegistration.h"

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <optional>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

namespace
{

/** exp(-integral) as float, 0 where not traced, on the filter's grid. */
vtkSmartPointer<vtkImageData> Transmission(vtkImageData* lineIntegral, vtkImageData* valid)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->CopyStructure(lineIntegral);
  image->AllocateScalars(VTK_FLOAT, 1);
  const float* in = static_cast<const float*>(lineIntegral->GetScalarPointer());
  const uint8_t* ok = static_cast<const uint8_t*>(valid->GetScalarPointer());
  float* out = static_cast<float*>(image->GetScalarPointer());
  for (vtkIdType i = 0; i < image->GetNumberOfPoints(); ++i)
  {
    out[i] = ok[i] ? std::exp(-in[i]) : 0.0f;
  }
  return image;
}

/**
 * 8-bit view of a DRR for people: the line integral (log of the transmission, as a radiograph is
 * displayed) windowed to the 0.5 and 99.5 percentiles of the valid pixels; bone dark.
 */
vtkSmartPointer<vtkImageData> DisplayImage(vtkImageData* lineIntegral, vtkImageData* valid)
{
  const auto* in = static_cast<const float*>(lineIntegral->GetScalarPointer());
  const auto* ok = static_cast<const uint8_t*>(valid->GetScalarPointer());
  const vtkIdType n = lineIntegral->GetNumberOfPoints();
  std::vector<float> values;
  for (vtkIdType i = 0; i < n; ++i)
  {
    if (ok[i])
      values.push_back(in[i]);
  }
  float low = 0.0f, high = 1.0f;
  if (!values.empty())
  {
    const auto lowAt = values.begin() + values.size() / 200, highAt = values.end() - 1 - values.size() / 200;
    std::nth_element(values.begin(), lowAt, values.end());
    low = *lowAt;
    std::nth_element(lowAt, highAt, values.end());
    high = std::max(*highAt, low + 1e-6f);
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->CopyStructure(lineIntegral);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* out = static_cast<uint8_t*>(image->GetScalarPointer());
  for (vtkIdType i = 0; i < n; ++i)
  {
    const double level = std::clamp((high - in[i]) / (high - low), 0.0f, 1.0f);
    out[i] = ok[i] ? static_cast<uint8_t>(std::lround(255.0 * level)) : 0;
  }
  return image;
}

/** Runs independent jobs on all cores; the first exception (in job order) is rethrown here. */
void RunInParallel(const std::vector<std::function<void()>>& jobs)
{
  std::vector<std::exception_ptr> failures(jobs.size());
  vtkSMPTools::For(0, static_cast<vtkIdType>(jobs.size()), 1,
    [&](vtkIdType begin, vtkIdType end)
    {
      for (vtkIdType j = begin; j < end; ++j)
      {
        try
        {
          jobs[j]();
        }
        catch (...)
        {
          failures[j] = std::current_exception();
        }
      }
    });
  for (const std::exception_ptr& failure : failures)
  {
    if (failure)
      std::rethrow_exception(failure);
  }
}

/** mask_NAME.png of every view from `directory` (none when empty), at the rendered size. */
std::vector<vtkSmartPointer<vtkImageData>> ReadViewMasks(
  const std::string& directory, const StereoGeometry& geometry, const std::pair<int, int>& size)
{
  std::vector<vtkSmartPointer<vtkImageData>> masks;
  for (const XRayView& view : geometry.views)
  {
    if (directory.empty())
    {
      masks.emplace_back();
      continue;
    }
    const XRayView out = size.first > 0 ? view.Resampled(size.first, size.second) : view;
    const std::string path = directory + "/mask_" + view.name + ".png";
    struct stat status;
    if (stat(path.c_str(), &status) != 0)
    {
      throw InputError(path, "no mask for imager " + view.name + " (expected mask_NAME.png in --mask-dir)");
    }
    masks.push_back(ReadMaskPNG(path, out.Columns(), out.Rows()));
  }
  return masks;
}

/**
 * Renders the views one after the other (each on all cores); their files are then encoded and
 * written in parallel, as PNG compression runs on one core. The write jobs only read images
 * made here: VTK objects are created and released on this thread alone.
 */
void RenderAndWriteViews(vtkXPDRRFilter* drr, const StereoGeometry& geometry,
  const std::vector<vtkSmartPointer<vtkImageData>>& masks, StagedOutputDirectory& output,
  const std::function<void()>& afterEachView)
{
  std::vector<vtkSmartPointer<vtkImageData>> images;
  std::vector<std::function<void()>> writes;
  for (size_t v = 0; v < geometry.views.size(); ++v)
  {
    const XRayView& view = geometry.views[v];
    drr->SetView(view);
    drr->SetInputData(1, masks[v]);
    drr->Update();
    if (drr->GetOutput(0)->GetNumberOfPoints() == 0)
    {
      throw Error("view " + view.name, "DRR rendering failed");
    }
    const XRayView rendered = drr->GetOutputView();
    auto drr12Bit = vtkSmartPointer<vtkImageData>::New();
    drr12Bit->DeepCopy(drr->GetOutput(0)); // the next view's Update reuses the filter's outputs
    images.push_back(drr12Bit);
    images.push_back(DisplayImage(drr->GetOutput(1), drr->GetOutput(2)));
    images.push_back(Transmission(drr->GetOutput(1), drr->GetOutput(2)));
    vtkImageData* made[3] = { images[images.size() - 3], images[images.size() - 2], images.back() };
    // The staged paths are taken here: StagedOutputDirectory records each, and is not thread-safe.
    const std::string stem = "drr_" + view.name;
    writes.emplace_back([path = output.Path(stem + ".png"), image = made[0]] { WritePNG(image, path); });
    writes.emplace_back([path = output.Path(stem + "_display.png"), image = made[1]] { WritePNG(image, path); });
    writes.emplace_back([path = output.Path(stem + ".mha"), rendered, image = made[2]]
      { WriteDetectorMetaImage(image, rendered, path); });
    afterEachView();
    const double seconds = drr->GetLastRenderSeconds();
    if (v == 0)
    {
      std::printf("attenuation volume prepared in %.3f s\n", drr->GetLastPreparationSeconds());
    }
    std::printf("view %s: %dx%d, %lld rays in %.3f s (%.2f M rays/s)\n", view.name.c_str(), rendered.Columns(),
      rendered.Rows(), drr->GetNumberOfTracedRays(), seconds, drr->GetNumberOfTracedRays() / seconds / 1e6);
  }
  RunInParallel(writes);
}

} // namespace

int RunDRR(const DRROptions& options)
{
  UseThreads(options.threads);
  // The GPU casts trilinear rays with one sample per voxel plane; Siddon and a fixed step run on the CPU.
  const bool onePerPlane = options.method != "siddon" && options.stepSize <= 0.0;
  ComputeDevice device = ComputeDevice::CPU;
  if (onePerPlane)
    device = UseDevice(options.device);
  else if (options.device == "cuda")
    throw InputError("--device", "the GPU casts trilinear rays with one sample per voxel plane: use it without --method "
                                 "siddon and --step, or with --device cpu or auto");
  else if (options.device == "auto")
    std::printf("device: --method siddon and --step cast on the CPU\n");
  else
    UseDevice(options.device); // cpu, or a word it refuses
  const Pose pose = Pose::Parse(options.pose, "--pose");
  std::pair<int, int> size{ 0, 0 };
  if (!options.size.empty())
  {
    size = ParseSize(options.size, "--size");
  }
  const std::optional<Eigen::Vector3d> isocenterInCT = ParsePointIfGiven(options.isocenterInCT, "--iso-ct");
  std::optional<Eigen::Vector3d> voxelSize;
  if (!options.voxelSize.empty())
  {
    const std::array<double, 3> given = ParseVoxelSize(options.voxelSize, "--voxel-size");
    voxelSize = Eigen::Vector3d(given[0], given[1], given[2]);
  }
  const auto readStart = std::chrono::steady_clock::now();
  DRRSetup setup = MakeDRRSetup(options.ct, options.series, voxelSize, options.geometry, isocenterInCT, options.muWater,
    options.method, options.stepSize);
  const double readSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - readStart).count();
  vtkXPDRRFilter* drr = setup.filter;
  drr->SetMisalignment(pose);
  drr->SetOutputSize(size.first, size.second);
  drr->SetDevice(device == ComputeDevice::CUDA ? 1 : 0);

  // Masks and the DICOM output's CT are checked before anything is rendered or written.
  const std::vector<vtkSmartPointer<vtkImageData>> masks = ReadViewMasks(options.maskDirectory, setup.geometry, size);
  std::optional<CTSeriesInfo> dicomCT;
  if (!options.dicomOutputDirectory.empty())
  {
    StagedOutputDirectory::CheckWritable(options.dicomOutputDirectory);
    dicomCT = DICOMSeriesForOutput(options.ct, options.series, "--dicom-out");
    CheckRTImageViews(setup.geometry, "--dicom-out");
  }
  int dims[3];
  setup.ct.image->GetDimensions(dims);
  std::printf("CT %s: %d x %d x %d voxels, patient position %s; read in %.2f s\n", options.ct.c_str(), dims[0], dims[1],
    dims[2], setup.ct.patientPosition.c_str(), readSeconds);
  std::printf("misalignment: %s\n", pose.ToString().c_str());
  StagedOutputDirectory output(options.outputDirectory);
  std::vector<RTImageDRR> rtImages;
  RenderAndWriteViews(drr, setup.geometry, masks, output, [&] {
    if (dicomCT) // a copy of each DRR only when it is written as DICOM
      rtImages.push_back(RTImageOfLastDRR(setup, "DRR by xpose, patient misalignment " + pose.ToString()));
  });
  if (dicomCT)
  {
    StagedOutputDirectory dicomOutput(options.dicomOutputDirectory);
    const std::string series = NewDICOMUID();
    for (size_t v = 0; v < rtImages.size(); ++v)
      WriteRTImageDRR(*dicomCT, rtImages[v], series, static_cast<int>(v) + 1, dicomOutput.Path("drr_" + rtImages[v].view.name + ".dcm"));
    dicomOutput.Commit();
    std::printf("wrote the DRRs as RT Images (drr_NAME.dcm) to %s\n", options.dicomOutputDirectory.c_str());
  }
  output.Commit();
  std::printf("wrote drr_NAME.png (16-bit, 0..4095), drr_NAME_display.png (8-bit, log-windowed for viewing) and drr_NAME.mha "
              "(float transmission) to %s\n",
    options.outputDirectory.c_str());
  return ExitOk;
}

} // namespace xp
