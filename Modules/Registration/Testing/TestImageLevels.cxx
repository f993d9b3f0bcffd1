// The X-ray's 3x3 median: outliers go, edges stay where they are; its smoothing to the CT's
// resolution; the masked high-pass.
#include "xpImageLevels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace
{

/** LevelTable's levels as first written: the sample sorted, each cell's middle looked up in it. */
std::vector<uint16_t> SortedLevels(const std::vector<float>& values, const std::vector<uint8_t>& mask)
{
  std::vector<float> sorted;
  for (size_t i = 0; i < values.size(); ++i)
    if (mask.empty() || mask[i])
      sorted.push_back(values[i]);
  std::sort(sorted.begin(), sorted.end());
  const double low = sorted.empty() ? 0.0 : sorted.front(), high = sorted.empty() ? 1.0 : sorted.back();
  const double margin = std::max(0.2 * (high - low), 1e-6);
  const double lowValue = low - margin, cellsPerValue = xp::RankLevels / (high - low + 2.0 * margin);
  std::vector<uint16_t> table(xp::RankLevels);
  for (int c = 0; c < xp::RankLevels; ++c)
  {
    const float middle = static_cast<float>(lowValue + (c + 0.5) / cellsPerValue);
    const size_t below = std::lower_bound(sorted.begin(), sorted.end(), middle) - sorted.begin();
    table[c] = static_cast<uint16_t>(sorted.empty() ? 0 : (xp::RankLevels - 1) * static_cast<double>(below) / sorted.size());
  }
  return table;
}

// The level table counts each value into its cell instead of sorting: the same levels, bit for bit,
// as the sort's on wide and narrow ranges, ties, values on the cells' middles, masks, a constant
// image and an empty sample.
TEST(LevelTable, CountsEachValueIntoItsCellAsTheSortedSampleDoes)
{
  std::mt19937 random(3);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  std::uniform_int_distribution<int> coin(0, 3);
  for (int trial = 0; trial < 6; ++trial)
  {
    const size_t n = 20000;
    std::vector<float> values(n);
    std::vector<uint8_t> mask;
    for (float& v : values)
      v = trial == 0 ? 7.5f                                     // constant
        : trial == 1 ? static_cast<float>(coin(random)) * 0.25f // few distinct values
        : trial == 2 ? 1e-4f * normal(random)                   // a narrow range
        : trial == 3 ? 300.0f + 80.0f * normal(random)          // line integrals' size
        : std::exp(2.0f * normal(random));                      // heavy tail
    if (trial >= 4)
    {
      mask.resize(n);
      for (uint8_t& m : mask)
        m = trial == 5 ? 0 : coin(random) != 0; // trial 5: nothing kept
    }
    if (trial == 3) // values exactly on middles of cells inside the range (which they leave as it is)
    {
      xp::LevelTable first;
      first.Build(values.data(), nullptr, static_cast<long long>(n));
      for (int c = 700; c < 3400; c += 97)
        values[static_cast<size_t>(c)] = static_cast<float>(first.Low() + (c + 0.5) / first.ToCell());
    }
    xp::LevelTable table;
    table.Build(values.data(), mask.empty() ? nullptr : mask.data(), static_cast<long long>(n));
    EXPECT_TRUE(table.Levels() == SortedLevels(values, mask)) << "trial " << trial;
  }
}

TEST(Median3x3, RemovesAnIsolatedOutlierAndKeepsAStepEdgeInPlace)
{
  const int columns = 8, rows = 6;
  // Left half 100, right half 900 (the edge between columns 3 and 4), one hot pixel in each half
  // and one dead pixel at a corner.
  std::vector<uint16_t> image(columns * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      image[r * columns + c] = c < 4 ? 100 : 900;
  image[2 * columns + 1] = 4095;
  image[3 * columns + 6] = 4095;
  image[0] = 0;
  const std::vector<uint16_t> median = xp::Median3x3(image, columns, rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      EXPECT_EQ(median[r * columns + c], c < 4 ? 100 : 900) << "row " << r << ", column " << c;
}

TEST(Median3x3, KeepsAnOrderedRampAndReplicatesTheBorder)
{
  // A ramp along the columns is its own median, border pixels included (edges replicated: the
  // window at column 0 holds columns 0, 0 and 1, whose median is column 0's value).
  const int columns = 5, rows = 4;
  std::vector<uint16_t> image(columns * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      image[r * columns + c] = static_cast<uint16_t>(10 * c + 3);
  const std::vector<uint16_t> median = xp::Median3x3(image, columns, rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      EXPECT_EQ(median[r * columns + c], image[r * columns + c]) << "row " << r << ", column " << c;
}

TEST(GaussianSmoothed, SpreadsAnImpulseByItsSigmaAndKeepsItsSum)
{
  // One bright pixel in the middle of a dark field: the smoothed image holds the same sum (at
  // the scale asked for), centred on the pixel, with a spread of sigma along rows and columns.
  const int columns = 41, rows = 31;
  const double sigma = 1.5;
  std::vector<uint16_t> image(columns * rows, 0);
  image[15 * columns + 20] = 4000;
  const int scale = 16;
  const std::vector<uint16_t> smoothed = xp::GaussianSmoothed(image, columns, rows, sigma, scale);
  double sum = 0.0, meanColumn = 0.0, meanRow = 0.0, varianceColumn = 0.0, varianceRow = 0.0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const double value = smoothed[r * columns + c];
      sum += value;
      meanColumn += value * c;
      meanRow += value * r;
      varianceColumn += value * (c - 20) * (c - 20);
      varianceRow += value * (r - 15) * (r - 15);
    }
  EXPECT_NEAR(sum, 4000.0 * scale, 4000.0 * scale * 0.002);
  EXPECT_NEAR(meanColumn / sum, 20.0, 1e-3);
  EXPECT_NEAR(meanRow / sum, 15.0, 1e-3);
  EXPECT_NEAR(std::sqrt(varianceColumn / sum), sigma, 0.05);
  EXPECT_NEAR(std::sqrt(varianceRow / sum), sigma, 0.05);
  EXPECT_EQ(smoothed[15 * columns + 20], *std::max_element(smoothed.begin(), smoothed.end()));
}

TEST(GaussianSmoothed, KeepsAConstantAtTheBorderAndFillsTheLevelsOfAStep)
{
  // A constant image stays constant up to its border (edges replicated, no darkening there).
  // An 8-bit step from 10 to 11 smoothed at scale 256 passes through the levels between them,
  // in order: what the scale is for.
  const int columns = 12, rows = 5;
  std::vector<uint16_t> flat(columns * rows, 200);
  for (uint16_t value : xp::GaussianSmoothed(flat, columns, rows, 2.0, 4))
    EXPECT_EQ(value, 800);
  std::vector<uint16_t> step(columns * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      step[r * columns + c] = c < 6 ? 10 : 11;
  const std::vector<uint16_t> smoothed = xp::GaussianSmoothed(step, columns, rows, 1.0, 256);
  EXPECT_EQ(smoothed[2 * columns + 0], 10 * 256);
  EXPECT_EQ(smoothed[2 * columns + columns - 1], 11 * 256);
  for (int c = 1; c < columns; ++c)
    EXPECT_GE(smoothed[2 * columns + c], smoothed[2 * columns + c - 1]) << "column " << c;
  EXPECT_GT(smoothed[2 * columns + 5], 10 * 256 + 32);
  EXPECT_LT(smoothed[2 * columns + 6], 11 * 256 - 32);
}

TEST(GaussianSmoothed, AnSDWiderThanTheImageAveragesItWhole)
{
  // Taps beyond the image would all read its edge: the kernel stops at the image's size, and a
  // very wide sd leaves about the image's mean everywhere (a tiny image, not a hang or a crash).
  const int columns = 4, rows = 3;
  std::vector<uint16_t> image(columns * rows, 100);
  image[0] = 1300;
  const std::vector<uint16_t> smoothed = xp::GaussianSmoothed(image, columns, rows, 1e6, 1);
  for (uint16_t value : smoothed)
  {
    EXPECT_GT(value, 100);
    EXPECT_LT(value, 1300);
  }
}

} // namespace

// The high-pass removes what is wider than its sd and keeps what is narrower, over the mask's
// pixels only: a ramp across the valid half vanishes, a one-pixel spike stays, and the masked
// half is left as it was. A MaskedLowPass used again gives SubtractLowPass's result exactly.
TEST(MaskedLowPass, RemovesARampKeepsASpikeAndEqualsSubtractLowPassOnReuse)
{
  const int columns = 96, rows = 64;
  std::vector<uint8_t> mask(static_cast<size_t>(columns) * rows, 0);
  std::vector<float> ramp(mask.size()), spiky(mask.size());
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const size_t i = static_cast<size_t>(r) * columns + c;
      mask[i] = c < columns / 2;
      ramp[i] = 100.0f + 2.0f * c + 0.5f * r;
      spiky[i] = 50.0f;
    }
  spiky[static_cast<size_t>(32) * columns + 20] = 150.0f;
  const double sigma = 8.0;
  const xp::MaskedLowPass lowPass(mask.data(), columns, rows, sigma);
  std::vector<float> once = ramp, reused = ramp;
  xp::SubtractLowPass(once.data(), mask.data(), columns, rows, sigma);
  lowPass.Subtract(spiky.data()); // another image first: nothing of it may stay in the object
  lowPass.Subtract(reused.data());
  EXPECT_EQ(once, reused);
  // Inside the valid half, away from its edges, a linear ramp has nothing a low-pass removes.
  EXPECT_NEAR(reused[static_cast<size_t>(32) * columns + 24], 0.0f, 0.05f);
  EXPECT_FLOAT_EQ(reused[static_cast<size_t>(10) * columns + 70], ramp[static_cast<size_t>(10) * columns + 70]);
  EXPECT_GT(spiky[static_cast<size_t>(32) * columns + 20], 95.0f);
  EXPECT_NEAR(spiky[static_cast<size_t>(10) * columns + 10], 0.0f, 1.0f);
}

namespace
{

/** A columns x rows ramp along the rows, `perColumn` grey values a column from 1000, with white
 *  noise of sd `noise` (seeded). */
std::vector<uint16_t> NoisyRamp(int columns, int rows, double perColumn, double noise, unsigned seed)
{
  std::mt19937 random(seed);
  std::normal_distribution<double> gaussian(0.0, noise);
  std::vector<uint16_t> image(static_cast<size_t>(columns) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      image[static_cast<size_t>(r) * columns + c] =
        static_cast<uint16_t>(std::clamp(std::lround(1000.0 + perColumn * c + gaussian(random)), 0L, 65535L));
  return image;
}

} // namespace

// The noise of an image's ranks is measured against its own contrast: white noise of sd 20 on a
// ramp 10 grey values a column wide (2 550 over 256 columns) is 20 / 2 550 of the ranks' 4 096
// levels; the same noise on half the contrast twice that; a monotone remapping (a log, as a
// workstation writes) changes nothing; a clean ramp reads next to none, and the mask decides
// which pixels count. A scale or sign slip in the estimator (the four neighbours' sqrt(1.25), the
// median's 0.6745) moves the first figure by 12 % or more.
TEST(RankNoiseLevels, MeasuresTheNoiseAgainstTheImagesOwnContrast)
{
  const int columns = 256, rows = 128;
  const std::vector<uint8_t> all;
  const double noisy = xp::RankNoiseLevels(NoisyRamp(columns, rows, 10.0, 20.0, 3), columns, rows, all);
  EXPECT_NEAR(noisy, 4095.0 * 20.0 / 2550.0, 0.08 * 4095.0 * 20.0 / 2550.0);
  const double halfContrast = xp::RankNoiseLevels(NoisyRamp(columns, rows, 5.0, 20.0, 3), columns, rows, all);
  EXPECT_GT(halfContrast / noisy, 1.7);
  EXPECT_LT(halfContrast / noisy, 2.1);

  std::vector<uint16_t> logged = NoisyRamp(columns, rows, 10.0, 20.0, 3);
  for (uint16_t& value : logged)
    value = static_cast<uint16_t>(std::lround(6000.0 * std::log(value)));
  EXPECT_NEAR(xp::RankNoiseLevels(logged, columns, rows, all), noisy, 0.03 * noisy);

  const std::vector<uint16_t> clean = NoisyRamp(columns, rows, 10.0, 0.0, 3);
  EXPECT_LT(xp::RankNoiseLevels(clean, columns, rows, all), 1.0);
  // The left half clean, the right half noisy: only the pixels the mask keeps count.
  std::vector<uint16_t> halves = clean;
  const std::vector<uint16_t> noise = NoisyRamp(columns, rows, 10.0, 20.0, 3);
  std::vector<uint8_t> left(halves.size(), 0), right(halves.size(), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const size_t i = static_cast<size_t>(r) * columns + c;
      (c < columns / 2 ? left : right)[i] = 1;
      if (c >= columns / 2)
        halves[i] = noise[i];
    }
  EXPECT_LT(xp::RankNoiseLevels(halves, columns, rows, left), 1.0);
  EXPECT_GT(xp::RankNoiseLevels(halves, columns, rows, right), 0.5 * noisy);
  EXPECT_EQ(xp::RankNoiseLevels(std::vector<uint16_t>(4, 7), 2, 2, all), 0.0); // no interior pixel
  // Sizes that do not match the panel are refused, not read past.
  EXPECT_THROW(xp::RankNoiseLevels(clean, columns, rows + 1, all), std::invalid_argument);
  EXPECT_THROW(xp::RankNoiseLevels(clean, columns, rows, std::vector<uint8_t>(10, 1)), std::invalid_argument);
}
