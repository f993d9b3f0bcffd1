#include "vtkXPMutualInformationMetric.h"
#include "xpMutualInformation.h"

#include <cmath>
#include <gtest/gtest.h>
#include <random>
#include <vtkImageData.h>
#include <vtkNew.h>

namespace
{

/** A 12-bit image with structure: a smooth ramp plus blobs. */
std::vector<uint16_t> Structured(int n, unsigned seed)
{
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> noise(-40, 40);
  std::vector<uint16_t> image(static_cast<size_t>(n) * n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
    {
      const double v = 2000 + 1500 * std::sin(x * 0.05) * std::cos(y * 0.07) + ((x / 20 + y / 20) % 3) * 150;
      image[static_cast<size_t>(y) * n + x] = static_cast<uint16_t>(std::clamp<int>(int(v) + noise(random), 0, 4095));
    }
  return image;
}

} // namespace

TEST(MutualInformation, OfAnImageWithItselfIsItsEntropy)
{
  const std::vector<uint16_t> image = Structured(200, 1);
  xp::JointHistogram h(64);
  h.Compute(image.data(), image.data(), static_cast<long long>(image.size()));
  EXPECT_NEAR(h.MutualInformation(), h.FixedEntropy(), 1e-12);
  EXPECT_GT(h.FixedEntropy(), 2.0);
  EXPECT_NEAR(h.NormalizedMutualInformation(), 2.0, 1e-12);
  EXPECT_NEAR(xp::PearsonCorrelation(image.data(), image.data(), image.size()), 1.0, 1e-12);
}

TEST(MutualInformation, UnchangedByAMonotoneGreyRemap)
{
  // Values on bin centres of 32 bins; remap bin k to bin 31 - k (monotone decreasing) with a
  // non-linear spacing: MI is invariant, NCC is not.
  const int bins = 32, width = 4096 / bins;
  std::vector<uint16_t> a = Structured(150, 2), b(a.size());
  for (size_t i = 0; i < a.size(); ++i)
  {
    const int k = a[i] / width;
    a[i] = static_cast<uint16_t>(k * width + width / 2);
    const int remapped = (bins - 1) - (k * k) / (bins - 1); // monotone in k
    b[i] = static_cast<uint16_t>(remapped * width + width / 2);
  }
  xp::JointHistogram same(bins), remapped(bins);
  same.Compute(a.data(), a.data(), static_cast<long long>(a.size()));
  remapped.Compute(a.data(), b.data(), static_cast<long long>(a.size()));
  // k*k/(bins-1) merges some neighbouring bins, so MI can only drop by what the merge loses:
  // compare with the entropy of the remapped image instead.
  EXPECT_NEAR(remapped.MutualInformation(), remapped.MovingEntropy(), 1e-12);
  EXPECT_LE(remapped.MutualInformation(), same.MutualInformation() + 1e-12);
  // A strictly monotone, one-to-one remap keeps MI exactly.
  for (size_t i = 0; i < a.size(); ++i)
    b[i] = static_cast<uint16_t>(4095 - a[i]);
  remapped.Compute(a.data(), b.data(), static_cast<long long>(a.size()));
  EXPECT_NEAR(remapped.MutualInformation(), same.MutualInformation(), 1e-9);
}

TEST(MutualInformation, NearZeroForIndependentNoise)
{
  std::mt19937 random(3);
  std::uniform_int_distribution<int> grey(0, 4095);
  std::vector<uint16_t> a(500000), b(500000);
  for (size_t i = 0; i < a.size(); ++i)
  {
    a[i] = static_cast<uint16_t>(grey(random));
    b[i] = static_cast<uint16_t>(grey(random));
  }
  xp::JointHistogram h(32);
  h.Compute(a.data(), b.data(), static_cast<long long>(a.size()));
  // The estimator's bias is about (bins-1)^2 / (2N) = 0.001 nats.
  EXPECT_LT(h.MutualInformation(), 0.003);
  EXPECT_NEAR(xp::PearsonCorrelation(a.data(), b.data(), a.size()), 0.0, 0.01);
}

TEST(MutualInformation, MaskedPixelsHaveNoEffect)
{
  const std::vector<uint16_t> fixed = Structured(120, 4);
  std::vector<uint16_t> moving = Structured(120, 5);
  std::vector<uint8_t> fixedMask(fixed.size()), movingMask(fixed.size());
  std::vector<uint16_t> fixedKept, movingKept;
  for (size_t i = 0; i < fixed.size(); ++i)
  {
    fixedMask[i] = (i % 5) != 0;
    movingMask[i] = (i / 120) % 4 != 1;
    if (fixedMask[i] && movingMask[i])
    {
      fixedKept.push_back(fixed[i]);
      movingKept.push_back(moving[i]);
    }
  }
  xp::JointHistogram masked(48), kept(48);
  masked.Compute(fixed.data(), moving.data(), static_cast<long long>(fixed.size()), fixedMask.data(), movingMask.data());
  kept.Compute(fixedKept.data(), movingKept.data(), static_cast<long long>(fixedKept.size()));
  const double before = masked.MutualInformation();
  EXPECT_EQ(masked.Samples(), static_cast<long long>(fixedKept.size()));
  EXPECT_NEAR(before, kept.MutualInformation(), 1e-12);
  // Garbage under the masks changes nothing; zeros there are not counted either.
  for (size_t i = 0; i < fixed.size(); ++i)
    if (!movingMask[i])
      moving[i] = 0;
  masked.Compute(fixed.data(), moving.data(), static_cast<long long>(fixed.size()), fixedMask.data(), movingMask.data());
  EXPECT_NEAR(masked.MutualInformation(), before, 1e-12);
}

TEST(MutualInformation, ListedPixelsCountAsTheirMask)
{
  // The same counts and MI from a mask's pixels listed as from the mask, values above the top
  // included (they fall in the last bin either way); garbage at unlisted pixels changes nothing.
  std::vector<uint16_t> fixed = Structured(120, 4), moving = Structured(120, 5);
  fixed[7] = moving[9] = 65535;
  std::vector<uint8_t> mask(fixed.size());
  std::vector<int> listed;
  for (size_t i = 0; i < fixed.size(); ++i)
  {
    mask[i] = (i % 7) != 3 && (i / 120) % 5 != 2;
    if (mask[i])
      listed.push_back(static_cast<int>(i));
  }
  xp::JointHistogram byMask(32), byList(32);
  byMask.Compute(fixed.data(), moving.data(), static_cast<long long>(fixed.size()), mask.data(), mask.data());
  byList.Compute(fixed.data(), moving.data(), listed);
  EXPECT_EQ(byList.Counts(), byMask.Counts());
  EXPECT_EQ(byList.Samples(), byMask.Samples());
  EXPECT_EQ(byList.MutualInformation(), byMask.MutualInformation());
  for (size_t i = 0; i < fixed.size(); ++i)
    if (!mask[i])
      moving[i] = 4000;
  byList.Compute(fixed.data(), moving.data(), listed);
  EXPECT_EQ(byList.Counts(), byMask.Counts());
}

TEST(MutualInformation, EntropyOfLargeAndSmallCountsIsTheirSum)
{
  // Counts on both sides of the c ln c table's end (4096): one image of two values, split
  // 5000 : 3000, has the entropy of those proportions, to the last bits of a double.
  std::vector<uint16_t> image(8000, 100);
  std::fill(image.begin() + 5000, image.end(), 3000);
  xp::JointHistogram h(32);
  h.Compute(image.data(), image.data(), static_cast<long long>(image.size()));
  const double p = 5000.0 / 8000.0, q = 3000.0 / 8000.0;
  EXPECT_NEAR(h.FixedEntropy(), -(p * std::log(p) + q * std::log(q)), 1e-12);
  EXPECT_NEAR(h.JointEntropy(), h.FixedEntropy(), 1e-12);
}

TEST(vtkXPMutualInformationMetric, MatchesTheKernelAndChecksSizes)
{
  const std::vector<uint16_t> a = Structured(64, 6), b = Structured(64, 7);
  vtkNew<vtkImageData> fixed, moving, wrong;
  for (auto [image, data] : { std::pair<vtkImageData*, const std::vector<uint16_t>*>{ fixed, &a }, { moving, &b } })
  {
    image->SetDimensions(64, 64, 1);
    image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    std::copy(data->begin(), data->end(), static_cast<uint16_t*>(image->GetScalarPointer()));
  }
  vtkNew<vtkXPMutualInformationMetric> metric;
  metric->SetInputData(0, fixed);
  metric->SetInputData(1, moving);
  metric->SetNumberOfBins(32);
  metric->Update();
  xp::JointHistogram h(32);
  h.Compute(a.data(), b.data(), 64 * 64);
  EXPECT_NEAR(metric->GetMutualInformation(), h.MutualInformation(), 1e-12);
  EXPECT_EQ(metric->GetNumberOfValidPixels(), 64 * 64);
  EXPECT_EQ(metric->GetOutput()->GetDimensions()[0], 32);

  wrong->SetDimensions(32, 64, 1);
  wrong->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  metric->SetInputData(1, wrong);
  metric->GlobalWarningDisplayOff();
  metric->Update();
  metric->GlobalWarningDisplayOn();
  EXPECT_EQ(metric->GetOutput()->GetNumberOfPoints(), 0) << "mismatched sizes are refused";
}
