// xpose-gpu-check: the GPU ray caster and metric checked against the CPU's and timed, without VTK
// (README.md beside this file). Exit 0 when every check holds, 1 when one fails, 2 on bad input;
// without a usable GPU the CPU half runs and the GPU checks are reported as not run.
#include "xpAttenuationVolume.h"
#include "xpCudaRayCaster.h"
#include "xpError.h"
#include "xpImageLevels.h"
#include "xpJosephRay.h"
#include "xpMutualInformation.h"
#include "xpRayCaster.h"
#include "xpXRayView.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace
{

using Clock = std::chrono::steady_clock;
constexpr double Pi = 3.14159265358979323846;

int failures = 0;

void Verdict(bool ok, const std::string& what)
{
  std::printf("%s %s\n", ok ? "PASS" : "FAIL", what.c_str());
  failures += ok ? 0 : 1;
}

double Median(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

/** A CT: HU voxels (x fastest) and voxel index -> CT mm. */
struct CT
{
  std::string name;
  Eigen::Vector3i dims;
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  std::vector<int16_t> hu;

  Eigen::Vector3d Center() const { return this->indexToCT * (0.5 * (this->dims.cast<double>() - Eigen::Vector3d::Ones())); }
};

/** An analytic phantom: a water body with a soft-tissue insert, a dense ring and two bones, on a
 *  grid of 0.9 x 0.9 x 1.5 mm turned 10 degrees about z, so that every axis and the direction
 *  matrix count. Each voxel is the formula at its centre. */
CT AnalyticCT()
{
  CT ct;
  ct.name = "analytic phantom";
  ct.dims = Eigen::Vector3i(240, 200, 150);
  const Eigen::Vector3d spacing(0.9, 0.9, 1.5);
  ct.indexToCT = Eigen::Translation3d(-100.0, -90.0, -110.0) * Eigen::AngleAxisd(10.0 * Pi / 180.0, Eigen::Vector3d::UnitZ()) *
    Eigen::Scaling(spacing);
  ct.hu.resize(static_cast<size_t>(ct.dims.prod()));
  const Eigen::Vector3d c = ct.Center();
  for (int k = 0; k < ct.dims[2]; ++k)
    for (int j = 0; j < ct.dims[1]; ++j)
      for (int i = 0; i < ct.dims[0]; ++i)
      {
        const Eigen::Vector3d p = ct.indexToCT * Eigen::Vector3d(i, j, k) - c;
        double hu = -1000.0;
        const double body = std::pow(p.x() / 95.0, 2) + std::pow(p.y() / 75.0, 2);
        if (body < 1.0 && std::abs(p.z()) < 100.0)
        {
          hu = 20.0 + 30.0 * std::sin(p.x() / 9.0) * std::cos(p.z() / 13.0);
          if (std::pow((p.x() - 30.0) / 25.0, 2) + std::pow(p.y() / 20.0, 2) + std::pow(p.z() / 40.0, 2) < 1.0)
            hu = 60.0;
          const double ring = std::hypot(p.x() + 35.0, p.y() - 10.0);
          if (ring > 14.0 && ring < 20.0)
            hu = 1200.0; // a cortical shell
          else if (ring <= 14.0)
            hu = 250.0; // its marrow
          if (std::pow((p.x() - 45.0) / 12.0, 2) + std::pow((p.y() + 30.0) / 10.0, 2) + std::pow(p.z() / 70.0, 2) < 1.0)
            hu = 900.0;
        }
        ct.hu[(static_cast<size_t>(k) * ct.dims[1] + j) * ct.dims[0] + i] = static_cast<int16_t>(std::lround(hu));
      }
  return ct;
}

/** A MetaImage as export-ct.py writes it: a .mhd header (DimSize, ElementSpacing, Offset,
 *  TransformMatrix listing the direction's columns, ElementType MET_SHORT, little-endian) and its
 *  raw voxels beside it. */
CT ReadCT(const std::string& path)
{
  std::ifstream header(path);
  if (!header)
    throw xp::InputError(path, "cannot be opened");
  CT ct;
  ct.name = path;
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones(), offset = Eigen::Vector3d::Zero();
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  std::string line, dataFile, type;
  ct.dims.setZero();
  while (std::getline(header, line))
  {
    const size_t equals = line.find('=');
    if (equals == std::string::npos)
      continue;
    std::string key = line.substr(0, equals);
    key.erase(key.find_last_not_of(' ') + 1);
    std::istringstream value(line.substr(equals + 1));
    if (key == "DimSize")
      value >> ct.dims[0] >> ct.dims[1] >> ct.dims[2];
    else if (key == "ElementSpacing")
      value >> spacing[0] >> spacing[1] >> spacing[2];
    else if (key == "Offset")
      value >> offset[0] >> offset[1] >> offset[2];
    else if (key == "TransformMatrix")
      for (int k = 0; k < 9; ++k)
        value >> direction(k % 3, k / 3);
    else if (key == "ElementType")
      value >> type;
    else if (key == "BinaryDataByteOrderMSB" || key == "ElementByteOrderMSB")
    {
      std::string msb;
      value >> msb;
      if (msb == "True")
        throw xp::InputError(path, "field " + key + ": only little-endian voxels are read");
    }
    else if (key == "ElementDataFile")
      value >> dataFile;
  }
  if (ct.dims.minCoeff() < 1)
    throw xp::InputError(path, "field DimSize: three positive counts expected");
  if (!spacing.allFinite() || spacing.minCoeff() <= 0.0)
    throw xp::InputError(path, "field ElementSpacing: three finite positive spacings expected");
  if (!offset.allFinite())
    throw xp::InputError(path, "field Offset: three finite numbers expected");
  if (!direction.allFinite() || std::abs(std::abs(direction.determinant()) - 1.0) > 1e-3)
    throw xp::InputError(path, "field TransformMatrix: a rotation (or reflection) expected");
  if (type != "MET_SHORT")
    throw xp::InputError(path, "field ElementType: only MET_SHORT is read, not '" + type + "'");
  if (dataFile.empty() || dataFile == "LOCAL")
    throw xp::InputError(path, "field ElementDataFile: a raw file beside the header is read");
  ct.indexToCT = Eigen::Translation3d(offset) * Eigen::Affine3d(direction) * Eigen::Scaling(spacing);
  const size_t slash = path.find_last_of('/');
  const std::string raw = (slash == std::string::npos ? std::string() : path.substr(0, slash + 1)) + dataFile;
  std::ifstream in(raw, std::ios::binary);
  if (!in)
    throw xp::InputError(raw, "cannot be opened");
  ct.hu.resize(static_cast<size_t>(ct.dims.cast<double>().prod()));
  in.read(reinterpret_cast<char*>(ct.hu.data()), static_cast<std::streamsize>(ct.hu.size() * sizeof(int16_t)));
  if (in.gcount() != static_cast<std::streamsize>(ct.hu.size() * sizeof(int16_t)))
    throw xp::InputError(raw, "ends before DimSize's voxels");
  return ct;
}

/** Two imagers 90 degrees apart about the room's vertical axis, each 45 degrees off the lateral
 *  axis, source 1000 mm and panel 500 mm from the isocentre: the reference stereo geometry's
 *  layout (Data/geometry/stereo-oblique-90.json), at `columns` x `rows` over a 410 x 307 mm panel. */
std::vector<xp::XRayView> StereoViews(int columns, int rows)
{
  std::vector<xp::XRayView> views;
  for (double degrees : { -45.0, 45.0 })
  {
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(degrees * Pi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    xp::XRayView view;
    view.name = degrees < 0 ? "A" : "B";
    view.source = turn * Eigen::Vector3d(0.0, -1000.0, 0.0);
    view.detectorCenter = turn * Eigen::Vector3d(0.0, 500.0, 0.0);
    view.rowDirection = turn * Eigen::Vector3d::UnitX();
    view.columnDirection = -Eigen::Vector3d::UnitZ();
    view.size = Eigen::Vector2i(columns, rows);
    view.pixelSpacing = Eigen::Vector2d(410.0 / columns, 307.5 / rows);
    views.push_back(view);
  }
  return views;
}

/** CT mm -> Room mm: the CT's centre on the isocentre, misaligned by a small turn and shift. */
Eigen::Isometry3d Placement(const CT& ct, int pose)
{
  const double t = 0.7 * pose;
  return Eigen::Translation3d(2.0 * std::sin(t), -1.5 * std::cos(t), 3.0 * std::sin(2.0 * t)) *
    Eigen::AngleAxisd(0.03 * std::cos(t), Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.02 * std::sin(t), Eigen::Vector3d::UnitY()) *
    Eigen::AngleAxisd(0.05 * std::sin(1.3 * t), Eigen::Vector3d::UnitZ()) * Eigen::Translation3d(-ct.Center());
}

/** Line integrals of `view` into `out` (its size; untraced pixels left as they are). */
void Render(const xp::AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const xp::XRayView& view,
  const xp::TracedPixels& pixels, const xp::RayCastSettings& settings, std::vector<float>& out)
{
  out.resize(static_cast<size_t>(view.Columns()) * view.Rows());
  xp::RenderLineIntegrals(volume, ctToRoom, view.source, xp::DetectorGrid::TopRowFirst(view), pixels, out.data(), settings);
}

xp::RayCastSettings OnCPU(bool vectorized = true)
{
  xp::RayCastSettings settings;
  settings.vectorized = vectorized;
  return settings;
}

xp::RayCastSettings OnGPU(bool textureFilter = false)
{
  xp::RayCastSettings settings;
  settings.device = xp::ComputeDevice::CUDA;
  settings.textureFilter = textureFilter;
  return settings;
}

std::vector<float> RenderCPU(const xp::AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const xp::XRayView& view,
  const xp::TracedPixels& pixels, bool vectorized = true)
{
  std::vector<float> out(static_cast<size_t>(view.Columns()) * view.Rows(), 0.0f);
  Render(volume, ctToRoom, view, pixels, OnCPU(vectorized), out);
  return out;
}

std::vector<float> RenderGPU(const xp::AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const xp::XRayView& view,
  const xp::TracedPixels& pixels, bool textureFilter)
{
  std::vector<float> out(static_cast<size_t>(view.Columns()) * view.Rows(), 0.0f);
  Render(volume, ctToRoom, view, pixels, OnGPU(textureFilter), out);
  return out;
}

/** Per-pixel relative differences of `test` from `reference` where the ray crosses the CT (the
 *  reference above 1 % of its largest value: grazing rays of a few voxels compare absolutely). */
struct Agreement
{
  double maxRelative = 0.0, medianRelative = 0.0, maxAbsoluteElsewhere = 0.0;
  long long compared = 0;
};

Agreement Compare(const std::vector<float>& reference, const std::vector<float>& test)
{
  Agreement a;
  const float largest = *std::max_element(reference.begin(), reference.end());
  std::vector<double> relative;
  for (size_t i = 0; i < reference.size(); ++i)
  {
    const double difference = std::abs(double(test[i]) - reference[i]);
    if (reference[i] > 0.01f * largest)
    {
      relative.push_back(difference / reference[i]);
      a.maxRelative = std::max(a.maxRelative, relative.back());
    }
    else
      a.maxAbsoluteElsewhere = std::max(a.maxAbsoluteElsewhere, difference);
  }
  a.medianRelative = Median(relative);
  a.compared = static_cast<long long>(relative.size());
  return a;
}

/** xpJosephRay.h on the CPU, one ray at a time: the GPU's arithmetic, checked here without one. */
std::vector<float> RenderJosephOnCPU(const xp::AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const xp::XRayView& view)
{
  const xp::DetectorGrid grid = xp::DetectorGrid::TopRowFirst(view);
  const xp::joseph::Job job = xp::JosephJob(volume, ctToRoom, view.source, grid);
  const Eigen::Vector3i dims = volume.PaddedDimensions();
  const xp::joseph::Grid jgrid{ { dims[0], dims[1], dims[2] }, volume.Quantum() };
  const uint16_t* voxels = volume.Voxels();
  const long nx = dims[0], nxy = nx * dims[1];
  const auto voxel = [&](int x, int y, int z) { return static_cast<float>(voxels[x + y * nx + z * nxy]); };
  std::vector<float> out(static_cast<size_t>(grid.columns) * grid.rows);
  for (int p = 0; p < grid.columns * grid.rows; ++p)
    out[p] = xp::joseph::LineIntegral(job, jgrid, p, voxel);
  return out;
}

/** Ranks of a line-integral image as the registration's levels (LevelTable) over `mask`. */
struct RankedDRR
{
  xp::LevelTable table;
  std::vector<uint16_t> levels;
};

double CPUMutualInformation(const xp::LevelTable& table, const std::vector<float>& integrals, const std::vector<uint16_t>& xrayLevels,
  const std::vector<uint8_t>& mask, int bins)
{
  std::vector<uint16_t> levels(integrals.size(), 0);
  for (size_t i = 0; i < integrals.size(); ++i)
    levels[i] = mask[i] ? table(integrals[i]) : 0;
  xp::JointHistogram histogram(bins);
  histogram.Compute(xrayLevels.data(), levels.data(), static_cast<long long>(levels.size()), mask.data(), mask.data());
  return histogram.MutualInformation();
}

/** The check of one CT: line integrals on both devices, MI on both, and the times. */
void CheckCT(const CT& ct, int columns, int rows, int repetitions, bool gpu)
{
  std::printf("\n== %s: %d x %d x %d voxels\n", ct.name.c_str(), ct.dims[0], ct.dims[1], ct.dims[2]);
  const Clock::time_point built = Clock::now();
  const xp::AttenuationVolume volume(ct.hu.data(), ct.dims, ct.indexToCT, xp::WaterAttenuationPerMM);
  std::printf("attenuation volume %.2f s, padded %d x %d x %d\n", std::chrono::duration<double>(Clock::now() - built).count(),
    volume.PaddedDimensions()[0], volume.PaddedDimensions()[1], volume.PaddedDimensions()[2]);
  const std::vector<xp::XRayView> views = StereoViews(columns, rows);
  const xp::TracedPixels all(columns, rows, nullptr);
  const int poses = 3;

  // 1. The GPU's per-ray arithmetic (xpJosephRay.h) against the CPU ray caster, on this CPU.
  {
    Agreement worst;
    for (int pose = 0; pose < poses; ++pose)
      for (const xp::XRayView& view : views)
      {
        const Eigen::Isometry3d placed = Placement(ct, pose);
        const Agreement a = Compare(RenderCPU(volume, placed, view, all, false), RenderJosephOnCPU(volume, placed, view));
        worst.maxRelative = std::max(worst.maxRelative, a.maxRelative);
        worst.medianRelative = std::max(worst.medianRelative, a.medianRelative);
        worst.maxAbsoluteElsewhere = std::max(worst.maxAbsoluteElsewhere, a.maxAbsoluteElsewhere);
      }
    char text[256];
    std::snprintf(text, sizeof text,
      "%s: xpJosephRay.h on the CPU against the CPU ray caster (one ray at a time): max %.2e, median %.2e relative; "
      "elsewhere %.2e absolute", ct.name.c_str(), worst.maxRelative, worst.medianRelative, worst.maxAbsoluteElsewhere);
    Verdict(worst.maxRelative <= 1e-4 && worst.maxAbsoluteElsewhere <= 1e-4, text); // float sums in another order
  }
  if (!gpu)
    return;

  // 2. GPU line integrals against the CPU's (the AVX2 path the registration uses).
  for (bool texture : { false, true })
  {
    Agreement worst;
    for (int pose = 0; pose < poses; ++pose)
      for (const xp::XRayView& view : views)
      {
        const Eigen::Isometry3d placed = Placement(ct, pose);
        const Agreement a = Compare(RenderCPU(volume, placed, view, all), RenderGPU(volume, placed, view, all, texture));
        worst.maxRelative = std::max(worst.maxRelative, a.maxRelative);
        worst.medianRelative = std::max(worst.medianRelative, a.medianRelative);
        worst.maxAbsoluteElsewhere = std::max(worst.maxAbsoluteElsewhere, a.maxAbsoluteElsewhere);
        worst.compared += a.compared;
      }
    char text[300];
    std::snprintf(text, sizeof text,
      "%s: GPU (%s) against CPU line integrals, %d poses x 2 views, %lld rays through the CT: max %.4f %%, median "
      "%.5f %% relative (limits 0.5 %%, 0.05 %%); elsewhere %.2e absolute",
      ct.name.c_str(), texture ? "texture filter" : "float interpolation", poses, worst.compared, 100.0 * worst.maxRelative,
      100.0 * worst.medianRelative, worst.maxAbsoluteElsewhere);
    if (texture)
      std::printf("info %s\n", text); // the texture filter is measured, not the product's default
    else
      Verdict(worst.maxRelative <= 0.005 && worst.medianRelative <= 0.0005, text);
  }

  // 3. MI on the GPU against the CPU's: the X-ray is the DRR at pose 0 (12-bit, ranked), the
  //    mask half the panel in 32 x 32 blocks, the DRR's levels fixed at pose 1 (the first pose
  //    a registration evaluates), MI over 32 bins at poses 1..4.
  const int bins = 32;
  xp::cuda::GPUContext context;
  std::vector<int> metricViews;
  std::vector<std::vector<uint8_t>> masks;
  std::vector<xp::LevelTable> tables;
  std::vector<std::vector<uint16_t>> xrayLevels;
  std::vector<xp::TracedPixels> traced;
  const Eigen::Vector3i dims = volume.PaddedDimensions();
  const int volumeHandle = context.AddVolume(volume.Voxels(), xp::joseph::Grid{ { dims[0], dims[1], dims[2] }, volume.Quantum() });
  for (size_t v = 0; v < views.size(); ++v)
  {
    std::vector<uint8_t> mask(static_cast<size_t>(columns) * rows);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < columns; ++c)
        mask[static_cast<size_t>(r) * columns + c] = ((c / 32 + r / 32 + static_cast<int>(v)) % 2) == 0;
    const std::vector<float> truth = RenderCPU(volume, Placement(ct, 0), views[v], all);
    std::vector<uint16_t> xray(truth.size());
    xp::LineIntegralsTo12Bit(truth.data(), nullptr, static_cast<long long>(truth.size()), xray.data());
    xrayLevels.push_back(xp::EqualizedLevels(xray, mask));
    xp::LevelTable table;
    const std::vector<float> first = RenderCPU(volume, Placement(ct, 1), views[v], all);
    table.Build(first.data(), mask.data(), static_cast<long long>(first.size()));
    traced.emplace_back(columns, rows, mask.data());
    const std::vector<int>& order = traced.back().Order();
    std::vector<uint8_t> xrayBins(order.size());
    for (size_t n = 0; n < order.size(); ++n)
      xrayBins[n] = static_cast<uint8_t>(xrayLevels.back()[order[n]] * bins / xp::RankLevels);
    std::vector<uint8_t> cellBins(table.Levels().size());
    for (size_t c = 0; c < cellBins.size(); ++c)
      cellBins[c] = static_cast<uint8_t>(table.Levels()[c] * bins / xp::RankLevels);
    const int pixels = context.AddPixels(order.data(), static_cast<int>(order.size()));
    metricViews.push_back(context.AddMetricView(pixels, xrayBins.data(), bins, table.Low(), table.ToCell(), cellBins));
    masks.push_back(mask);
    tables.push_back(table);
  }
  const auto jobOf = [&](const Eigen::Isometry3d& ctToRoom, const xp::XRayView& view)
  { return xp::JosephJob(volume, ctToRoom, view.source, xp::DetectorGrid::TopRowFirst(view)); };
  double worstMI = 0.0;
  for (int pose = 1; pose <= 4; ++pose)
  {
    const Eigen::Isometry3d placed = Placement(ct, pose);
    xp::joseph::Job jobs[2] = { jobOf(placed, views[0]), jobOf(placed, views[1]) };
    double gpuMI[2];
    context.MutualInformation(volumeHandle, jobs, metricViews.data(), 2, gpuMI);
    for (int v = 0; v < 2; ++v)
    {
      const double cpuMI = CPUMutualInformation(tables[v], RenderCPU(volume, placed, views[v], traced[v]), xrayLevels[v], masks[v], bins);
      worstMI = std::max(worstMI, std::abs(gpuMI[v] - cpuMI) / std::max(cpuMI, 1e-9));
      std::printf("  pose %d view %s: MI cpu %.6f gpu %.6f nats\n", pose, views[v].name.c_str(), cpuMI, gpuMI[v]);
    }
  }
  {
    char text[200];
    std::snprintf(text, sizeof text, "%s: MI on the GPU against the CPU's, 4 poses x 2 views: largest difference %.3f %% (limit 0.5 %%)",
      ct.name.c_str(), 100.0 * worstMI);
    Verdict(worstMI <= 0.005, text);
  }

  // 4. Times: a stereo evaluation (both views' masked DRRs and their MI) on the GPU, one pose a
  //    launch and 16 poses a launch, against the same on this machine's CPU (all cores).
  const long long valid = static_cast<long long>(traced[0].Order().size() + traced[1].Order().size());
  std::vector<double> single, batched, cpu;
  std::vector<xp::joseph::Job> batch;
  std::vector<int> batchViews;
  for (int p = 0; p < 16; ++p)
    for (int v = 0; v < 2; ++v)
    {
      batch.push_back(jobOf(Placement(ct, p), views[v]));
      batchViews.push_back(metricViews[v]);
    }
  std::vector<double> batchMI(batch.size());
  for (int r = 0; r < repetitions + 3; ++r)
  {
    const Eigen::Isometry3d placed = Placement(ct, r % 7);
    xp::joseph::Job jobs[2] = { jobOf(placed, views[0]), jobOf(placed, views[1]) };
    double mi[2];
    Clock::time_point start = Clock::now();
    context.MutualInformation(volumeHandle, jobs, metricViews.data(), 2, mi);
    const double one = std::chrono::duration<double>(Clock::now() - start).count();
    start = Clock::now();
    context.MutualInformation(volumeHandle, batch.data(), batchViews.data(), static_cast<int>(batch.size()), batchMI.data());
    const double sixteen = std::chrono::duration<double>(Clock::now() - start).count() / 16.0;
    if (r >= 3) // the first launches load the kernels
    {
      single.push_back(one);
      batched.push_back(sixteen);
    }
  }
  for (int r = 0; r < std::max(3, repetitions / 20); ++r)
  {
    const Eigen::Isometry3d placed = Placement(ct, r % 7);
    const Clock::time_point start = Clock::now();
    for (int v = 0; v < 2; ++v)
      CPUMutualInformation(tables[v], RenderCPU(volume, placed, views[v], traced[v]), xrayLevels[v], masks[v], bins);
    cpu.push_back(std::chrono::duration<double>(Clock::now() - start).count());
  }
  const double gpuOne = Median(single), gpuBatch = Median(batched), cpuOne = Median(cpu);
  std::printf("stereo evaluation at %dx%d, %lld masked rays (%.0f %% of the pixels), MI over %d bins:\n"
              "  GPU, one pose a launch: %.3f ms (median of %zu), %.0f M rays/s\n"
              "  GPU, 16 poses a launch: %.3f ms a pose, %.0f M rays/s\n"
              "  CPU, %u hardware threads: %.2f ms (median of %zu); GPU %.0fx (one pose), %.0fx (16 poses)\n",
    columns, rows, valid, 100.0 * valid / (2.0 * columns * rows), bins, 1e3 * gpuOne, single.size(), valid / gpuOne / 1e6,
    1e3 * gpuBatch, valid / gpuBatch / 1e6, std::thread::hardware_concurrency(), 1e3 * cpuOne, cpu.size(), cpuOne / gpuOne,
    cpuOne / gpuBatch);
  char text[160];
  std::snprintf(text, sizeof text, "%s: a stereo evaluation at %dx%d on the GPU takes %.3f ms (limit 1 ms)", ct.name.c_str(),
    columns, rows, 1e3 * gpuOne);
  Verdict(gpuOne <= 1e-3, text);

  // 5. Whole panels, every ray, one view at a time through RenderLineIntegrals (as xpose drr),
  //    into buffers kept between runs.
  for (int size : { 512, 1024 })
  {
    const std::vector<xp::XRayView> panel = StereoViews(size, size * 3 / 4);
    const xp::TracedPixels every(size, size * 3 / 4, nullptr);
    std::vector<double> g, c;
    std::vector<float> out;
    for (int r = 0; r < 6; ++r)
    {
      Clock::time_point start = Clock::now();
      for (const xp::XRayView& view : panel)
        Render(volume, Placement(ct, 0), view, every, OnGPU(), out);
      if (r > 0)
        g.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      if (r < 3)
      {
        start = Clock::now();
        for (const xp::XRayView& view : panel)
          Render(volume, Placement(ct, 0), view, every, OnCPU(), out);
        c.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      }
    }
    const double rays = 2.0 * size * (size * 3 / 4);
    std::printf("two %dx%d DRRs, every ray, RenderLineIntegrals (host buffers): GPU %.2f ms (%.0f M rays/s), CPU %.2f ms "
                "(%.0f M rays/s), %.1fx\n", size, size * 3 / 4, 1e3 * Median(g), rays / Median(g) / 1e6, 1e3 * Median(c),
      rays / Median(c) / 1e6, Median(c) / Median(g));
  }
}

int Run(int argc, char** argv)
{
  std::vector<std::string> cts;
  int columns = 512, rows = 384, repetitions = 200;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    const auto next = [&]() -> std::string
    {
      if (i + 1 >= argc)
        throw xp::InputError(arg, "needs a value");
      return argv[++i];
    };
    if (arg == "--ct")
      cts.push_back(next());
    else if (arg == "--size")
    {
      const std::string size = next();
      if (std::sscanf(size.c_str(), "%dx%d", &columns, &rows) != 2 || columns < 16 || rows < 16)
        throw xp::InputError("--size", "'" + size + "' is not COLSxROWS (each at least 16)");
    }
    else if (arg == "--repetitions")
    {
      repetitions = std::stoi(next());
      if (repetitions < 1)
        throw xp::InputError("--repetitions", "must be at least 1");
    }
    else
      throw xp::InputError(arg, "unknown option (--ct FILE.mhd, --size COLSxROWS, --repetitions N)");
  }
  std::string reason;
  const bool gpu = xp::cuda::Available(&reason);
  if (gpu)
    std::printf("GPU: %s\n", xp::cuda::GPUContext().DeviceName().c_str());
  else
    std::printf("GPU: none (%s): the GPU checks are not run\n", reason.c_str());
  std::vector<CT> read; // every CT read and checked before any work
  for (const std::string& path : cts)
    read.push_back(ReadCT(path));
  CheckCT(AnalyticCT(), columns, rows, repetitions, gpu);
  for (const CT& ct : read)
    CheckCT(ct, columns, rows, repetitions, gpu);
  std::printf("\n%d check(s) failed%s\n", failures, gpu ? "" : "; GPU checks not run");
  return failures == 0 ? 0 : 1;
}

} // namespace

int main(int argc, char** argv)
{
  try
  {
    return Run(argc, argv);
  }
  catch (const xp::InputError& error)
  {
    std::fprintf(stderr, "xpose-gpu-check: error: %s\n", error.what());
    return 2;
  }
  catch (const std::exception& error)
  {
    std::fprintf(stderr, "xpose-gpu-check: error: %s\n", error.what());
    return 1;
  }
}
