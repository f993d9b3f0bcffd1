#include "vtkXPEntropyMaskFilter.h"
#include "xpEntropyMask.h"
#include "xpError.h"
#include "xpXRayView.h"

#include <cmath>
#include <gtest/gtest.h>
#include <random>
#include <vtkImageData.h>
#include <vtkNew.h>

namespace
{

/** Left half flat (one grey level), right half textured (many grey levels per window). */
std::vector<uint16_t> HalfFlatHalfTextured(int columns, int rows)
{
  std::mt19937 random(11);
  std::uniform_int_distribution<int> grey(0, 4095);
  std::vector<uint16_t> image(static_cast<size_t>(columns) * rows);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < columns; ++x)
      image[static_cast<size_t>(y) * columns + x] = x < columns / 2 ? 2000 : static_cast<uint16_t>(grey(random));
  return image;
}

} // namespace

TEST(EntropyMask, ConstantImageHasZeroEntropy)
{
  std::vector<uint16_t> flat(128 * 96, 1234);
  const xp::EntropyMaskResult result = xp::ComputeEntropyMask(flat.data(), 128, 96);
  EXPECT_EQ(result.imageEntropy, 0.0);
  for (float h : result.entropy)
    ASSERT_EQ(h, 0.0f);
}

TEST(EntropyMask, KeepsTheTexturedHalfAndDropsTheFlatHalf)
{
  const int columns = 160, rows = 120;
  const std::vector<uint16_t> image = HalfFlatHalfTextured(columns, rows);
  const xp::EntropyMaskResult result = xp::ComputeEntropyMask(image.data(), columns, rows);
  // Uniform noise averaged over 2x2 and smoothed still spreads a 49-pixel window over many of the
  // 128 bins; the most a 7x7 window can reach is ln 49 / ln 128 = 0.80.
  const int y = rows / 2;
  EXPECT_GT(result.entropy[static_cast<size_t>(y) * columns + 120], 0.45);
  EXPECT_LE(result.entropy[static_cast<size_t>(y) * columns + 120], std::log(49.0) / std::log(128.0) + 1e-6);
  EXPECT_EQ(result.entropy[static_cast<size_t>(y) * columns + 20], 0.0f);
  EXPECT_EQ(result.mask[static_cast<size_t>(y) * columns + 20], 0) << "flat half masked";
  EXPECT_EQ(result.mask[static_cast<size_t>(y) * columns + 120], 1) << "textured half valid";
  EXPECT_EQ(result.mask[0], 0) << "no entropy where the window leaves the image";
  EXPECT_GT(result.validFraction, 0.3);
  EXPECT_LT(result.validFraction, 0.5);
  // H(X) is the mean over the defined windows: between the halves' entropies.
  EXPECT_GT(result.imageEntropy, 0.2);
  EXPECT_LT(result.imageEntropy, 0.6);
}

TEST(EntropyMask, ROIIsAndCombinedAndBlocksAre14PixelsAtFullSize)
{
  const int columns = 160, rows = 120;
  const std::vector<uint16_t> image = HalfFlatHalfTextured(columns, rows);
  std::vector<uint8_t> roi(image.size(), 0);
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < columns; ++x)
      roi[static_cast<size_t>(y) * columns + x] = y < rows / 2;
  const xp::EntropyMaskResult plain = xp::ComputeEntropyMask(image.data(), columns, rows);
  const xp::EntropyMaskResult withROI = xp::ComputeEntropyMask(image.data(), columns, rows, roi.data());
  for (size_t i = 0; i < image.size(); ++i)
    ASSERT_EQ(withROI.mask[i], plain.mask[i] && roi[i]) << i;
  // Full-size pixels come in 2x2 groups from the half-resolution map.
  EXPECT_EQ(plain.entropy[static_cast<size_t>(61) * columns + 121], plain.entropy[static_cast<size_t>(60) * columns + 120]);
}

TEST(EntropyMask, TooSmallImagesAreRefused)
{
  std::vector<uint16_t> tiny(20 * 20, 7);
  EXPECT_THROW(xp::ComputeEntropyMask(tiny.data(), 20, 20), xp::InputError);
}

TEST(EntropyMask, TransferIsIdentityOnTheSamePanelAndResamplesOtherwise)
{
  xp::XRayView view;
  view.source = { 0, 0, -1000 };
  view.detectorCenter = { 0, 0, 500 };
  view.rowDirection = { 1, 0, 0 };
  view.columnDirection = { 0, -1, 0 };
  view.pixelSpacing = { 1, 1 };
  view.size = { 40, 30 };
  std::vector<uint8_t> mask(40 * 30, 0);
  for (int y = 5; y < 12; ++y)
    for (int x = 20; x < 33; ++x)
      mask[y * 40 + x] = 1;
  EXPECT_EQ(xp::TransferMask(mask, view, view), mask);
  const std::vector<uint8_t> coarse = xp::TransferMask(mask, view, view.Resampled(20, 15));
  EXPECT_EQ(coarse[4 * 20 + 13], 1); // centre (27, 9) of the block
  EXPECT_EQ(coarse[10 * 20 + 5], 0);
}

TEST(vtkXPEntropyMaskFilter, ProducesMaskAndEntropyMap)
{
  const std::vector<uint16_t> image = HalfFlatHalfTextured(160, 120);
  vtkNew<vtkImageData> xray;
  xray->SetDimensions(160, 120, 1);
  xray->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  std::copy(image.begin(), image.end(), static_cast<uint16_t*>(xray->GetScalarPointer()));
  vtkNew<vtkXPEntropyMaskFilter> filter;
  filter->SetInputData(xray);
  filter->Update();
  EXPECT_GT(filter->GetValidFraction(), 0.3);
  EXPECT_EQ(filter->GetOutput(0)->GetScalarType(), VTK_UNSIGNED_CHAR);
  EXPECT_EQ(static_cast<uint8_t*>(filter->GetOutput(0)->GetScalarPointer())[60 * 160 + 120], 255);
  EXPECT_EQ(filter->GetOutput(1)->GetScalarType(), VTK_FLOAT);
}
