#include "xpPlot.h"

#include <gtest/gtest.h>

#include <vtkImageData.h>

namespace
{

/** Pixels of an RGB image that have exactly this colour. */
int CountColour(vtkImageData* image, unsigned char r, unsigned char g, unsigned char b)
{
  int dims[3];
  image->GetDimensions(dims);
  const auto* p = static_cast<const unsigned char*>(image->GetScalarPointer());
  int count = 0;
  for (int i = 0; i < dims[0] * dims[1]; ++i)
    count += p[3 * i] == r && p[3 * i + 1] == g && p[3 * i + 2] == b;
  return count;
}

/** Mean column of the pixels of this colour, and their mean row counted from the top. */
std::pair<double, double> Centroid(vtkImageData* image, unsigned char r, unsigned char g, unsigned char b)
{
  int dims[3];
  image->GetDimensions(dims);
  const auto* p = static_cast<const unsigned char*>(image->GetScalarPointer());
  double sx = 0, sy = 0, n = 0;
  for (int j = 0; j < dims[1]; ++j)
    for (int i = 0; i < dims[0]; ++i)
    {
      const unsigned char* q = p + 3 * (i + dims[0] * j);
      if (q[0] == r && q[1] == g && q[2] == b)
        sx += i, sy += dims[1] - 1 - j, n += 1;
    }
  return { sx / n, sy / n };
}

} // namespace

TEST(Plot, DrawsEverySeriesWhereItsDataIs)
{
  xp::Plot plot("title", "x", "y");
  plot.AddSeries({ "", { 0.0, 10.0 }, { 0.0, 0.0 }, { 250, 0, 0 } });
  plot.AddSeries({ "legend only", {}, {}, { 250, 250, 0 } });
  plot.AddSeries({ "", { 10.0 }, { 10.0 }, { 0, 0, 250 } });
  plot.AddSeries({ "", { 0.0 }, { 10.0 }, { 0, 250, 0 } });
  vtkSmartPointer<vtkImageData> image = plot.Render(600, 400);
  int dims[3];
  image->GetDimensions(dims);
  ASSERT_EQ(dims[0], 600);
  ASSERT_EQ(dims[1], 400);
  ASSERT_EQ(image->GetNumberOfScalarComponents(), 3);
  ASSERT_GT(CountColour(image, 0, 0, 250), 20);
  // (10, 10) is drawn top right, (0, 10) top left: x runs right and y runs up, row 0 at the top.
  const auto [blueX, blueY] = Centroid(image, 0, 0, 250);
  const auto [greenX, greenY] = Centroid(image, 0, 250, 0);
  EXPECT_GT(blueX, 400);
  EXPECT_LT(greenX, 200);
  EXPECT_LT(blueY, 200);
  EXPECT_NEAR(blueY, greenY, 1.0);
  const auto [redX, redY] = Centroid(image, 250, 0, 0);
  EXPECT_GT(redY, blueY + 150);
  // The legend sits above the axes, where it hides no data.
  ASSERT_GT(CountColour(image, 250, 250, 0), 10);
  EXPECT_LT(Centroid(image, 250, 250, 0).second, blueY - 5);
}

TEST(Plot, LogAxisPutsDecadesEvenlyAndKeepsZeros)
{
  xp::Plot plot("log", "x", "y");
  plot.SetLogY(true);
  plot.AddSeries({ "", { 1.0 }, { 0.01 }, { 250, 0, 0 } });
  plot.AddSeries({ "", { 2.0 }, { 1.0 }, { 0, 250, 0 } });
  plot.AddSeries({ "", { 3.0 }, { 100.0 }, { 0, 0, 250 } });
  plot.AddSeries({ "", { 4.0 }, { 0.0 }, { 250, 0, 250 } }); // not representable: at the bottom
  vtkSmartPointer<vtkImageData> image = plot.Render(600, 400);
  const double low = Centroid(image, 250, 0, 0).second, middle = Centroid(image, 0, 250, 0).second,
               high = Centroid(image, 0, 0, 250).second;
  EXPECT_NEAR(low - middle, middle - high, 2.0);
  EXPECT_GT(low - middle, 50.0);
  EXPECT_GE(Centroid(image, 250, 0, 250).second, low - 1.0);
}
