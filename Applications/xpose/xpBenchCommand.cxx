#include "xpCommands.h"
#include "xpRegistrationWriters.h"

#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpPose.h"
#include "xpRayCaster.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>
#include <vector>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

struct Scene
{
  AttenuationVolume volume;
  Eigen::Isometry3d ctToRoom;
  std::vector<XRayView> views;
};

/** Median seconds to render every view once (all views together), over `repetitions` runs (and
 *  one before them, uncounted, on the GPU: its volume and pixel lists go there once, as in a
 *  registration). The traced pixels are listed before the clock starts, as a registration does. */
double TimeViews(const Scene& scene, int columns, int rows, const std::vector<std::vector<uint8_t>>* masks,
  const RayCastSettings& settings, int repetitions, long long& rays)
{
  std::vector<double> times;
  std::vector<float> buffer(static_cast<size_t>(columns) * rows);
  std::vector<XRayView> views;
  std::vector<TracedPixels> traced;
  for (size_t v = 0; v < scene.views.size(); ++v)
  {
    views.push_back(scene.views[v].Resampled(columns, rows));
    traced.emplace_back(columns, rows, masks ? (*masks)[v].data() : nullptr);
  }
  const int warmUp = settings.device == ComputeDevice::CUDA ? 1 : 0;
  for (int r = 0; r < repetitions + warmUp; ++r)
  {
    rays = 0;
    const Clock::time_point start = Clock::now();
    for (size_t v = 0; v < views.size(); ++v)
      rays += RenderLineIntegrals(scene.volume, scene.ctToRoom, views[v].source, DetectorGrid::TopRowFirst(views[v]), traced[v],
        buffer.data(), settings);
    if (r >= warmUp)
      times.push_back(std::chrono::duration<double>(Clock::now() - start).count());
  }
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  return times[times.size() / 2];
}

RayCastSettings Settings(RayCastMethod method, ComputeDevice device = ComputeDevice::CPU)
{
  RayCastSettings settings;
  settings.method = method;
  settings.device = device;
  return settings;
}

/** Tiles of 16x16 pixels kept with probability `fraction` (a fixed hash): a mask with the
 *  blocky, spatially coherent shape of an entropy mask. Returns the exact valid fraction. */
double TileMask(int columns, int rows, double fraction, int seed, std::vector<uint8_t>& mask)
{
  mask.assign(static_cast<size_t>(columns) * rows, 0);
  long long valid = 0;
  for (int r = 0; r < rows; ++r)
  {
    for (int c = 0; c < columns; ++c)
    {
      unsigned h = static_cast<unsigned>((c / 16) * 73856093u ^ (r / 16) * 19349663u ^ seed * 83492791u);
      h ^= h >> 13;
      h *= 0x5bd1e995u;
      h ^= h >> 15;
      const bool keep = (h % 10000u) < fraction * 10000.0;
      mask[static_cast<size_t>(r) * columns + c] = keep;
      valid += keep;
    }
  }
  return static_cast<double>(valid) / mask.size();
}

} // namespace

std::string BenchMachineDescription()
{
  std::string model = "an unnamed CPU";
  std::ifstream cpuinfo("/proc/cpuinfo");
  for (std::string line; std::getline(cpuinfo, line);)
    if (line.rfind("model name", 0) == 0 && line.find(':') != std::string::npos)
    {
      model = line.substr(line.find(':') + 1);
      model.erase(0, model.find_first_not_of(" \t"));
      break;
    }
  return model + ", " + std::to_string(std::max(1u, std::thread::hardware_concurrency())) + " hardware threads, ray caster " +
    RayCasterPathDescription();
}

int RunBenchDRR(const BenchOptions& options)
{
  if (options.repetitions < 1)
  {
    throw InputError("--repetitions", "must be at least 1");
  }
  const ComputeDevice device = UseDevice(options.device);
  DRRSetup setup = MakeDRRSetup(options.ct, options.series, std::nullopt, options.geometry, std::nullopt, WaterAttenuationPerMM, "trilinear", 0.0);
  vtkImageData* ct = setup.ct.image;
  int dims[3];
  ct->GetDimensions(dims);
  const Clock::time_point prepare = Clock::now();
  Scene scene{ std::move(*MakeAttenuationVolume(ct, WaterAttenuationPerMM)), Eigen::Isometry3d::Identity(), setup.geometry.views };
  const double prepareSeconds = std::chrono::duration<double>(Clock::now() - prepare).count();
  scene.ctToRoom = setup.patient.PlannedCTToRoom(ImageCenter(ct));

  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const Eigen::Vector3i stored = scene.volume.StoredDimensions();
  std::printf("xpose bench drr\nCT: %s, %d x %d x %d voxels; attenuation volume built in %.3f s, storing the %d x %d x %d "
              "voxels around the body, %.0f %% of its %d^3 blocks occupied\ngeometry: %s, %zu views; machine: %s; median of %d "
              "runs\n\n",
    options.ct.c_str(), dims[0], dims[1], dims[2], prepareSeconds, stored[0], stored[1], stored[2],
    100.0 * scene.volume.OccupiedFraction(), 1 << AttenuationVolume::BlockShift, options.geometry.c_str(), scene.views.size(),
    BenchMachineDescription().c_str(), options.repetitions);

  std::printf("Unmasked rendering, all views per run\n%-10s %-9s %-7s %10s %12s %14s %10s\n", "method", "size", "threads",
    "rays", "time (s)", "M rays/s", "speed-up");
  std::vector<int> threadCounts{ 1 };
  if (cores > 1)
    threadCounts.push_back(cores);
  for (const std::string& name : options.methods)
  {
    const RayCastMethod method = name == "siddon" ? RayCastMethod::Siddon : RayCastMethod::Trilinear;
    for (const std::string& text : options.sizes)
    {
      const auto [columns, rows] = ParseSize(text, "--sizes");
      double single = 0.0;
      for (int threads : threadCounts)
      {
        vtkSMPTools::Initialize(threads);
        long long rays = 0;
        const double seconds = TimeViews(scene, columns, rows, nullptr, Settings(method), options.repetitions, rays);
        if (threads == 1)
          single = seconds;
        std::printf("%-10s %-9s %-7d %10lld %12.4f %14.2f %9.2fx\n",
          name.c_str(), text.c_str(), threads, rays, seconds,
          rays / seconds / 1e6, single / seconds);
      }
    }
  }

  if (HasWideVectorRayCaster() && device == ComputeDevice::CPU)
  {
    // The same rays sixteen at a time (AVX-512), their voxels read by row loads or by gathers,
    // and eight at a time (AVX2); and the CPU's default with each packet's rays set up one at a
    // time instead of eight: taking turns in this run, the same integrals to the bit, in
    // different times. Masked too, as a registration renders.
    const VoxelReads reads = WideVoxelReadsOf(VoxelReads::Auto);
    std::printf("\nRays per packet (trilinear, the same integrals): 16 lanes with AVX-512, voxels read by row loads or "
                "by gathers, against 8 with AVX2; this CPU's default: %s, its rays set up 8 at a time (\"1 by 1\": the "
                "default set up one at a time)\n%-9s %-9s %-7s %12s %14s %12s %12s %12s %12s %12s\n",
      ToString(reads), "size", "valid (%)", "threads", "loads (s)", "gathers (s)", "8 lanes (s)", "1 by 1 (s)",
      "gathers/loads", "8 / loads", "default/1by1");
    RayCastSettings loads = Settings(RayCastMethod::Trilinear), gathers = loads, narrow = loads, oneByOne = loads;
    loads.voxelReads = VoxelReads::Loads;
    gathers.voxelReads = VoxelReads::Gathers;
    narrow.wideVectors = false;
    oneByOne.wideSetUp = false;
    const auto compare = [&](const std::string& size, int c, int r, const std::vector<std::vector<uint8_t>>* masks, double valid,
                           int threads)
    {
      vtkSMPTools::Initialize(threads);
      long long rays = 0;
      const double byLoads = TimeViews(scene, c, r, masks, loads, options.repetitions, rays);
      const double byGathers = TimeViews(scene, c, r, masks, gathers, options.repetitions, rays);
      const double eight = TimeViews(scene, c, r, masks, narrow, options.repetitions, rays);
      const double single = TimeViews(scene, c, r, masks, oneByOne, options.repetitions, rays);
      const double byDefault = reads == VoxelReads::Loads ? byLoads : byGathers;
      std::printf("%-9s %-9.1f %-7d %12.4f %14.4f %12.4f %12.4f %11.2fx %11.2fx %11.2fx\n", size.c_str(), 100.0 * valid,
        threads, byLoads, byGathers, eight, single, byGathers / byLoads, eight / byLoads, byDefault / single);
    };
    for (const std::string& text : options.sizes)
    {
      const auto [c, r] = ParseSize(text, "--sizes");
      for (int threads : threadCounts)
        compare(text, c, r, nullptr, 1.0, threads);
    }
    const auto [c, r] = ParseSize(options.maskSize, "--mask-size");
    for (double fraction : options.validFractions)
    {
      std::vector<std::vector<uint8_t>> masks(scene.views.size());
      double valid = 0.0;
      for (size_t v = 0; v < masks.size(); ++v)
        valid += TileMask(c, r, fraction, static_cast<int>(v) + 1, masks[v]) / masks.size();
      compare(options.maskSize, c, r, &masks, valid, cores);
    }
  }

  vtkSMPTools::Initialize(cores);
  const auto [columns, rows] = ParseSize(options.maskSize, "--mask-size");
  long long fullRays = 0;
  const double full = TimeViews(scene, columns, rows, nullptr, Settings(RayCastMethod::Trilinear), options.repetitions, fullRays);
  std::printf("\nMasked rendering (trilinear, %s, %d threads): time should track the valid fraction\n"
              "%-14s %12s %12s %14s %16s\n",
    options.maskSize.c_str(), cores, "valid (%)", "rays", "time (s)", "M rays/s", "time / unmasked");
  std::printf("%-14.1f %12lld %12.4f %14.2f %16.3f\n", 100.0, fullRays, full, fullRays / full / 1e6, 1.0);
  for (double fraction : options.validFractions)
  {
    std::vector<std::vector<uint8_t>> masks(scene.views.size());
    double valid = 0.0;
    for (size_t v = 0; v < masks.size(); ++v)
      valid += TileMask(columns, rows, fraction, static_cast<int>(v) + 1, masks[v]) / masks.size();
    long long rays = 0;
    const double seconds = TimeViews(scene, columns, rows, &masks, Settings(RayCastMethod::Trilinear), options.repetitions, rays);
    std::printf("%-14.1f %12lld %12.4f %14.2f %16.3f\n", 100.0 * valid, rays, seconds, rays / seconds / 1e6, seconds / full);
  }
  if (device == ComputeDevice::CUDA)
  {
    // The GPU beside the CPU's every core, each size timed on both in this run. Its time is
    // RenderLineIntegrals' whole call: the rays, and the line integrals' way back to the host.
    std::printf("\nOn the GPU, %s (trilinear, line integrals back in host memory), against the CPU's %d threads\n"
                "%-9s %-10s %10s %12s %14s %12s %10s\n",
      ComputeDeviceDescription(device).c_str(), cores, "size", "valid (%)", "rays", "time (s)", "M rays/s", "CPU (s)", "speed-up");
    const auto row = [&](const std::string& size, int c, int r, const std::vector<std::vector<uint8_t>>* masks, double valid)
    {
      long long rays = 0, cpuRays = 0;
      const double gpu = TimeViews(scene, c, r, masks, Settings(RayCastMethod::Trilinear, device), options.repetitions, rays);
      const double cpu = TimeViews(scene, c, r, masks, Settings(RayCastMethod::Trilinear), options.repetitions, cpuRays);
      std::printf("%-9s %-10.1f %10lld %12.5f %14.1f %12.4f %9.1fx\n", size.c_str(), 100.0 * valid, rays, gpu, rays / gpu / 1e6,
        cpu, cpu / gpu);
    };
    for (const std::string& text : options.sizes)
    {
      const auto [c, r] = ParseSize(text, "--sizes");
      row(text, c, r, nullptr, 1.0);
    }
    for (double fraction : options.validFractions)
    {
      std::vector<std::vector<uint8_t>> masks(scene.views.size());
      double valid = 0.0;
      for (size_t v = 0; v < masks.size(); ++v)
        valid += TileMask(columns, rows, fraction, static_cast<int>(v) + 1, masks[v]) / masks.size();
      row(options.maskSize, columns, rows, &masks, valid);
    }
  }
  return ExitOk;
}

} // namespace xp
