#include "vtkXPOverlayFilter.h"
#include "xpOverlays.h"

#include <gtest/gtest.h>

#include <vtkExecutive.h>
#include <vtkImageData.h>
#include <vtkNew.h>

#include <cstdint>

namespace
{

constexpr int Columns = 64, Rows = 48;

/** A bright square on a darker ramp, 12-bit, row 0 first, shifted right by `shift` pixels. */
std::vector<uint16_t> Square(int shift)
{
  std::vector<uint16_t> image(Columns * Rows);
  for (int r = 0; r < Rows; ++r)
    for (int c = 0; c < Columns; ++c)
    {
      const bool inside = r >= 12 && r < 36 && c >= 16 + shift && c < 40 + shift;
      image[r * Columns + c] = static_cast<uint16_t>(inside ? 3500 : 500 + 10 * c);
    }
  return image;
}

const uint8_t* Pixel(vtkImageData* image, int column, int row) // row 0 at the top
{
  return static_cast<const uint8_t*>(image->GetScalarPointer(column, Rows - 1 - row, 0));
}

} // namespace

TEST(Overlays, BlendOfAlignedImagesIsGreyAndOfShiftedOnesIsColoured)
{
  vtkSmartPointer<vtkImageData> same = xp::MakeOverlay(xp::OverlayMode::ColourBlend, Square(0), Square(0), Columns, Rows);
  for (int r = 0; r < Rows; ++r)
    for (int c = 0; c < Columns; ++c)
    {
      const uint8_t* p = Pixel(same, c, r);
      ASSERT_EQ(p[0], p[1]);
      ASSERT_EQ(p[1], p[2]);
    }
  vtkSmartPointer<vtkImageData> shifted = xp::MakeOverlay(xp::OverlayMode::ColourBlend, Square(0), Square(8), Columns, Rows);
  const uint8_t* onlyXRay = Pixel(shifted, 18, 20);  // the X-ray's square, not the DRR's: magenta
  const uint8_t* onlyDRR = Pixel(shifted, 44, 20);   // the DRR's square only: green
  EXPECT_GT(onlyXRay[0], onlyXRay[1] + 100);
  EXPECT_GT(onlyDRR[1], onlyDRR[0] + 100);
}

TEST(Overlays, CheckerboardAlternatesSquaresOfBothImages)
{
  vtkSmartPointer<vtkImageData> board = xp::MakeOverlay(xp::OverlayMode::Checkerboard, Square(0), Square(8), Columns, Rows);
  // Square size max(8, 64/8) = 8: (20, 20) is in square (2, 2) -> X-ray; (28, 20) in (3, 2) -> DRR.
  EXPECT_EQ(Pixel(board, 20, 20)[0], Pixel(xp::MakeGreyImage(Square(0), Columns, Rows), 20, 20)[0]);
  EXPECT_EQ(Pixel(board, 28, 20)[0], Pixel(xp::MakeGreyImage(Square(8), Columns, Rows), 28, 20)[0]);
}

TEST(Overlays, EdgesOfTheDRRAreDrawnWhereTheyAre)
{
  vtkSmartPointer<vtkImageData> edges = xp::MakeOverlay(xp::OverlayMode::Edges, Square(0), Square(8), Columns, Rows);
  int yellowNearEdge = 0, yellowElsewhere = 0;
  for (int r = 14; r < 34; ++r)
    for (int c = 0; c < Columns; ++c)
    {
      const uint8_t* p = Pixel(edges, c, r);
      const bool yellow = p[0] == 255 && p[1] == 230 && p[2] == 0;
      const bool nearEdge = std::abs(c - 24) <= 2 || std::abs(c - 47) <= 2;
      (nearEdge ? yellowNearEdge : yellowElsewhere) += yellow;
    }
  EXPECT_GT(yellowNearEdge, 20);
  EXPECT_EQ(yellowElsewhere, 0);
}

TEST(vtkXPOverlayFilter, MasksInAPipelineAndRefusesMismatchedSizes)
{
  const auto image = [](const std::vector<uint16_t>& pixels, int columns, int rows) {
    vtkNew<vtkImageData> out;
    out->SetDimensions(columns, rows, 1);
    out->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    std::copy(pixels.begin(), pixels.end(), static_cast<uint16_t*>(out->GetScalarPointer()));
    return vtkSmartPointer<vtkImageData>(out);
  };
  vtkNew<vtkImageData> mask;
  mask->SetDimensions(Columns, Rows, 1);
  mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* m = static_cast<uint8_t*>(mask->GetScalarPointer());
  for (int i = 0; i < Columns * Rows; ++i)
    m[i] = (i % Columns) < Columns / 2 ? 255 : 0; // left half valid
  vtkNew<vtkXPOverlayFilter> overlay;
  overlay->SetInputData(0, image(Square(0), Columns, Rows));
  overlay->SetInputData(1, image(Square(0), Columns, Rows));
  overlay->SetInputData(2, mask);
  overlay->SetMode(xp::OverlayMode::MaskedXRay);
  overlay->Update();
  vtkImageData* out = overlay->GetOutput();
  ASSERT_EQ(out->GetNumberOfScalarComponents(), 3);
  const auto* left = static_cast<const uint8_t*>(out->GetScalarPointer(10, 5, 0));
  const auto* right = static_cast<const uint8_t*>(out->GetScalarPointer(50, 5, 0));
  EXPECT_EQ(left[0], left[2]);       // valid: grey
  EXPECT_GT(right[2], right[0] + 40); // excluded: dimmed and tinted blue

  overlay->SetInputData(1, image(std::vector<uint16_t>(32 * 24, 100), 32, 24));
  overlay->GlobalWarningDisplayOff();
  EXPECT_EQ(overlay->GetExecutive()->Update(), 0);
}
