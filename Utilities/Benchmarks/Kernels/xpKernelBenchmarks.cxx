/**
 * What a registration's kernels cost per call (Google Benchmark): the 2D warp of a view's pixels
 * at each width, the joint histogram with its mutual information, a full-size DRR's high-pass,
 * one view's measure and one whole 2D registration, on images the size of a registration's
 * half-size views (256 x 192) and full-size views (512 x 384); and the body's segmentation, the
 * attenuation volume and its halving of a CT of a pelvis CT's size (512 x 512 x 140). The images
 * are smooth shapes with a little noise, as DRRs and X-rays are: their neighbouring pixels share
 * histogram bins, which is what the histogram's speed depends on.
 *
 *   build/bin/xpKernelBenchmarks [--benchmark_filter=REGEX] [--benchmark_repetitions=N]
 */
#include "xpAttenuationVolume.h"
#include "xpBodyMask.h"
#include "xpImageLevels.h"
#include "xpMutualInformation.h"
#include "xpPreAlignment.h"
#include "xpViewMetrics.h"

#include <benchmark/benchmark.h>

#include <algorithm>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace
{

/** A 12-bit image of columns x rows: two overlapping blobs on a slope, and noise of sd `noise`. */
std::vector<uint16_t> Shapes(int columns, int rows, double shiftColumns, double noise, unsigned seed)
{
  std::mt19937 random(seed);
  std::normal_distribution<double> grain(0.0, noise);
  std::vector<uint16_t> image(static_cast<size_t>(columns) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const double x = (c - shiftColumns) / columns, y = static_cast<double>(r) / rows;
      const double blob = std::exp(-40.0 * ((x - 0.4) * (x - 0.4) + (y - 0.5) * (y - 0.5))) +
        0.6 * std::exp(-90.0 * ((x - 0.65) * (x - 0.65) + (y - 0.35) * (y - 0.35)));
      const double value = 600.0 + 1500.0 * x + 1800.0 * blob + grain(random);
      image[static_cast<size_t>(r) * columns + c] = static_cast<uint16_t>(std::clamp(value, 0.0, 4095.0));
    }
  return image;
}

/** Every pixel of a columns x rows panel whose column and row are inside the central 80 %. */
std::vector<xp::PixelIndex> CentralPixels(int columns, int rows)
{
  std::vector<xp::PixelIndex> pixels;
  for (int r = rows / 10; r < rows - rows / 10; ++r)
    for (int c = columns / 10; c < columns - columns / 10; ++c)
      pixels.push_back({ c, r });
  return pixels;
}

void Warp(benchmark::State& state)
{
  const int columns = static_cast<int>(state.range(0)), rows = columns * 3 / 4;
  const xp::WarpLanes lanes = static_cast<xp::WarpLanes>(state.range(1));
  if (!xp::WarpLanesAvailable(lanes))
  {
    state.SkipWithError("this CPU has not the lanes asked for");
    return;
  }
  const std::vector<uint16_t> moving = Shapes(columns, rows, 0.0, 20.0, 1);
  const std::vector<xp::PixelIndex> pixels = CentralPixels(columns, rows);
  xp::Motion2D motion;
  motion.center = { columns / 2.0, rows / 2.0 };
  motion.shift = { 1.3, -0.7 };
  motion.rotation = 1.5;
  std::vector<uint16_t> out;
  std::vector<uint8_t> valid;
  for (auto _ : state)
  {
    xp::WarpPixels(moving, columns, rows, motion, pixels, out, valid, lanes);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long long>(pixels.size()));
}
BENCHMARK(Warp)
  ->ArgNames({ "columns", "lanes" })
  ->ArgsProduct({ { 256, 512 }, { 1, 4, 8 } })
  ->Unit(benchmark::kMicrosecond);

void HistogramMI(benchmark::State& state)
{
  const int columns = static_cast<int>(state.range(0)), rows = columns * 3 / 4, bins = static_cast<int>(state.range(1));
  const std::vector<uint16_t> fixed = Shapes(columns, rows, 0.0, 20.0, 1), moving = Shapes(columns, rows, 3.0, 20.0, 2);
  std::vector<uint8_t> mask(fixed.size());
  for (size_t i = 0; i < mask.size(); ++i)
    mask[i] = (i / 16) % 2 == 0; // half the pixels, in runs
  xp::JointHistogram histogram(bins);
  for (auto _ : state)
  {
    histogram.Compute(fixed.data(), moving.data(), static_cast<long long>(fixed.size()), mask.data(), mask.data());
    benchmark::DoNotOptimize(histogram.MutualInformation());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<long long>(fixed.size()));
}
BENCHMARK(HistogramMI)->ArgNames({ "columns", "bins" })->ArgsProduct({ { 256, 512 }, { 32, 64 } })->Unit(benchmark::kMicrosecond);

/** The refinement's high-pass of a full-size DRR: its low-pass (5 mm on a 0.39 mm pixel, 13 pixels'
 *  sd) over the valid half of the pixels, subtracted. */
void HighPass(benchmark::State& state)
{
  const int columns = 512, rows = 384;
  const std::vector<uint16_t> image = Shapes(columns, rows, 0.0, 20.0, 1);
  std::vector<uint8_t> mask(image.size());
  for (size_t i = 0; i < mask.size(); ++i)
    mask[i] = (i / 16) % 2 == 0;
  const xp::MaskedLowPass lowPass(mask.data(), columns, rows, 13.0);
  std::vector<float> values(image.size());
  for (auto _ : state)
  {
    std::copy(image.begin(), image.end(), values.begin());
    lowPass.Subtract(values.data());
    benchmark::DoNotOptimize(values.data());
  }
}
BENCHMARK(HighPass)->Unit(benchmark::kMicrosecond);

/** One view's measure in the refinement: a full-size DRR's line integrals ranked, high-passed
 *  (13 pixels' sd), ranked again, and their MI with the X-ray's levels over 32 bins, on the valid
 *  half of the pixels (in runs of 16, as an entropy mask's blocks leave them). */
void ViewMI(benchmark::State& state)
{
  const int columns = 512, rows = 384;
  const std::vector<uint16_t> xray = Shapes(columns, rows, 0.0, 20.0, 1), drr = Shapes(columns, rows, 2.0, 5.0, 2);
  std::vector<uint8_t> mask(xray.size());
  for (size_t i = 0; i < mask.size(); ++i)
    mask[i] = (i / 16) % 2 == 0;
  std::vector<float> integrals(drr.begin(), drr.end());
  for (float& value : integrals)
    value = 4.0f - value / 1000.0f;
  xp::MutualInformationMetric metric(mask.data(), columns, rows, xray, 32, true, 13.0);
  for (auto _ : state)
    benchmark::DoNotOptimize(metric.Measure(integrals));
}
BENCHMARK(ViewMI)->Unit(benchmark::kMicrosecond);

void Register2D(benchmark::State& state)
{
  const int columns = 256, rows = 192;
  const std::vector<uint16_t> fixed = Shapes(columns, rows, 0.0, 20.0, 1), moving = Shapes(columns, rows, 4.0, 20.0, 2);
  for (auto _ : state)
    benchmark::DoNotOptimize(xp::Register2D(fixed, moving, columns, rows, { columns / 2.0, rows / 2.0 }).shift);
}
BENCHMARK(Register2D)->Unit(benchmark::kMillisecond);

/** A 16-bit CT of columns x rows x slices: an elliptic body of soft tissue with a bone inside, on a
 *  table slab below it, in air. */
std::vector<int16_t> BodyOnATable(int columns, int rows, int slices)
{
  std::vector<int16_t> hu(static_cast<size_t>(columns) * rows * slices, -1000);
  for (int k = 0; k < slices; ++k)
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < columns; ++i)
      {
        const double x = (i - 0.5 * columns) / (0.4 * columns), y = (j - 0.45 * rows) / (0.3 * rows);
        int16_t& v = hu[(static_cast<size_t>(k) * rows + j) * columns + i];
        if (x * x + y * y < 1.0)
          v = x * x + y * y < 0.05 ? 700 : 40;
        else if (j > 0.8 * rows && j < 0.83 * rows)
          v = -300; // the table's top
      }
  return hu;
}

void SegmentBody(benchmark::State& state)
{
  const Eigen::Vector3i dims(512, 512, 140);
  const std::vector<int16_t> hu = BodyOnATable(dims[0], dims[1], dims[2]);
  for (auto _ : state)
    benchmark::DoNotOptimize(xp::SegmentBody(hu.data(), dims).data());
  state.SetItemsProcessed(state.iterations() * static_cast<long long>(hu.size()));
}
BENCHMARK(SegmentBody)->Unit(benchmark::kMillisecond);

/** The attenuation volume of the CT above (16-bit mu, its y-fastest copy, the occupied blocks). */
void AttenuationVolume(benchmark::State& state)
{
  const Eigen::Vector3i dims(512, 512, 140);
  const std::vector<int16_t> hu = BodyOnATable(dims[0], dims[1], dims[2]);
  for (auto _ : state)
    benchmark::DoNotOptimize(xp::AttenuationVolume(hu.data(), dims, Eigen::Affine3d::Identity(), 0.02).VoxelCount());
  state.SetItemsProcessed(state.iterations() * static_cast<long long>(hu.size()));
}
BENCHMARK(AttenuationVolume)->Unit(benchmark::kMillisecond);

/** That volume halved along each axis (the pre-alignment's and the searches' CT). */
void HalvedVolume(benchmark::State& state)
{
  const Eigen::Vector3i dims(512, 512, 140);
  const std::vector<int16_t> hu = BodyOnATable(dims[0], dims[1], dims[2]);
  const xp::AttenuationVolume volume(hu.data(), dims, Eigen::Affine3d::Identity(), 0.02);
  for (auto _ : state)
    benchmark::DoNotOptimize(volume.Halved(Eigen::Vector3i(2, 2, 2)).VoxelCount());
}
BENCHMARK(HalvedVolume)->Unit(benchmark::kMillisecond);

} // namespace

BENCHMARK_MAIN();
