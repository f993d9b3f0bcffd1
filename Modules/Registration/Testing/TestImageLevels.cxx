// The X-ray's 3x3 median: outliers go, edges stay where they are.
#include "xpImageLevels.h"

#include <gtest/gtest.h>

namespace
{

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

} // namespace
