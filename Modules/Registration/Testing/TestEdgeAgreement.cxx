#include "xpEdgeAgreement.h"
#include "xpError.h"

#include <gtest/gtest.h>
#include <random>

namespace
{

/** A columns x rows image, dark outside and bright inside a disc at (cx, cy), with noise. */
std::vector<uint16_t> Disc(int columns, int rows, double cx, double cy, double radius, double noise, unsigned seed)
{
  std::mt19937 random(seed);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::vector<uint16_t> image(static_cast<size_t>(columns) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const bool in = (c - cx) * (c - cx) + (r - cy) * (r - cy) < radius * radius;
      image[static_cast<size_t>(r) * columns + c] =
        static_cast<uint16_t>(std::clamp(1000.0 + (in ? 2000.0 : 0.0) + noise * gaussian(random), 0.0, 4095.0));
    }
  return image;
}

} // namespace

TEST(EdgeAgreement, TheDRRsEdgesOnTheXRaysLieCloserThanMovedOnes)
{
  const int columns = 120, rows = 100;
  const std::vector<uint16_t> drr = Disc(columns, rows, 60, 50, 25, 0.0, 1);
  const std::vector<uint16_t> xray = Disc(columns, rows, 60, 50, 25, 150.0, 2);
  const xp::EdgeAgreement same = xp::MeasureEdgeAgreement(xray, drr, {}, columns, rows, 5);
  EXPECT_GT(same.drrEdgePixels, 100);
  EXPECT_LE(same.medianPixels, 1.0);
  // A circle moved 5 pixels: radially 5 off at its sides, tangentially at top and bottom.
  EXPECT_GE(same.shiftedMedianPixels, 2.5);

  // The DRR's disc 4 pixels to the right: about half its outline is 4 pixels off, the rest less.
  const std::vector<uint16_t> moved = Disc(columns, rows, 64, 50, 25, 0.0, 1);
  const xp::EdgeAgreement off = xp::MeasureEdgeAgreement(xray, moved, {}, columns, rows, 5);
  EXPECT_GE(off.medianPixels, 1.5);
  EXPECT_LE(off.medianPixels, 4.5);
  EXPECT_GT(off.medianPixels, same.medianPixels + 1.0);
}

TEST(EdgeAgreement, TheRegionsBorderIsNoEdgeAndAFlatXRayHasNone)
{
  const int columns = 120, rows = 100;
  const std::vector<uint16_t> drr = Disc(columns, rows, 60, 50, 25, 0.0, 1);
  // A region that cuts the disc in half: its straight border must not count as the DRR's edge.
  std::vector<uint8_t> left(drr.size(), 0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < 60; ++c)
      left[static_cast<size_t>(r) * columns + c] = 1;
  const xp::EdgeAgreement half = xp::MeasureEdgeAgreement(drr, drr, left, columns, rows, 5);
  EXPECT_EQ(half.medianPixels, 0.0) << "the same image's edges coincide";
  const xp::EdgeAgreement whole = xp::MeasureEdgeAgreement(drr, drr, {}, columns, rows, 5);
  EXPECT_LT(half.drrEdgePixels, 0.6 * whole.drrEdgePixels) << "only the left half of the outline counts";

  const std::vector<uint16_t> flat(drr.size(), 2000);
  const xp::EdgeAgreement none = xp::MeasureEdgeAgreement(flat, drr, {}, columns, rows, 5);
  EXPECT_EQ(none.medianPixels, -1.0);
  EXPECT_THROW(xp::MeasureEdgeAgreement(flat, drr, left, columns + 1, rows, 5), xp::InputError);
  EXPECT_THROW(xp::MeasureEdgeAgreement(drr, drr, {}, columns, rows, 0), xp::InputError) << "no chance level without a shift";
}
