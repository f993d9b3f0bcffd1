// An image intensifier's circular field is found where it is, and nothing else is taken for one:
// not a raw image whose dark body touches the border, not a flat image.
#include "xpEntropyMask.h"
#include "xpFieldOfView.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace
{
constexpr int Columns = 200, Rows = 160;

/** A disc of radius 70 at (95, 82) holding bright field and a darker hand; black outside. */
std::vector<uint16_t> IntensifierImage()
{
  std::vector<uint16_t> image(Columns * Rows, 0);
  for (int r = 0; r < Rows; ++r)
    for (int c = 0; c < Columns; ++c)
    {
      const double d = std::hypot(c - 95.0, r - 82.0);
      if (d <= 70.0)
        image[r * Columns + c] = static_cast<uint16_t>(c > 100 && r > 60 ? 120 : 220);
    }
  return image;
}
} // namespace

TEST(FieldOfView, FindsTheDiscAndLeavesOutItsCornersAndRim)
{
  const xp::CircularField field = xp::FindCircularField(IntensifierImage(), Columns, Rows);
  ASSERT_TRUE(field.found);
  EXPECT_NEAR(field.center[0], 95.0, 1.0);
  EXPECT_NEAR(field.center[1], 82.0, 1.0);
  EXPECT_NEAR(field.radius, 70.0, 1.0);
  ASSERT_EQ(field.mask.size(), static_cast<size_t>(Columns * Rows));
  EXPECT_EQ(field.mask[82 * Columns + 95], 1);    // the centre
  EXPECT_EQ(field.mask[82 * Columns + 95 + 69], 0); // the vignetted rim
  EXPECT_EQ(field.mask[0], 0);                      // a corner
}

TEST(FieldOfView, ARawImageWhoseDarkBodyTouchesTheBorderIsNoField)
{
  // A thick body's raw transmission: dark from the left border to the middle, open field beyond.
  std::vector<uint16_t> image(Columns * Rows, 3600);
  for (int r = 0; r < Rows; ++r)
    for (int c = 0; c < Columns / 2; ++c)
      image[r * Columns + c] = static_cast<uint16_t>(5 + (r + c) % 7);
  EXPECT_FALSE(xp::FindCircularField(image, Columns, Rows).found);
  EXPECT_FALSE(xp::FindCircularField(std::vector<uint16_t>(Columns * Rows, 500), Columns, Rows).found);
}

TEST(DilateMask, WidensByTheRadiusOnEachAxis)
{
  std::vector<uint8_t> mask(10 * 8, 0);
  mask[4 * 10 + 5] = 1;
  const std::vector<uint8_t> wide = xp::DilateMask(mask, 10, 8, 2);
  for (int r = 0; r < 8; ++r)
    for (int c = 0; c < 10; ++c)
      EXPECT_EQ(wide[r * 10 + c], std::abs(r - 4) <= 2 && std::abs(c - 5) <= 2 ? 1 : 0) << c << "," << r;
  EXPECT_EQ(xp::DilateMask(mask, 10, 8, 0), mask);
}
