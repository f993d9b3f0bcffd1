#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageRows.h"

#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkNew.h>

TEST(ImageGeometry, UsesDirectionSpacingOriginAndExtentStart)
{
  vtkNew<vtkImageData> image;
  image->SetExtent(2, 11, 0, 4, 1, 3); // memory index 0 is structured index (2, 0, 1)
  image->SetSpacing(0.5, 2.0, 3.0);
  image->SetOrigin(10, 20, 30);
  image->SetDirectionMatrix(0, -1, 0, 1, 0, 0, 0, 0, 1); // i runs along +y, j along -x
  const Eigen::Vector3d p = xp::IndexToPhysical(image) * Eigen::Vector3d(1, 1, 1);
  // structured (3, 1, 2): origin + 3*0.5*(+y) + 1*2*(-x) + 2*3*(+z)
  EXPECT_NEAR((p - Eigen::Vector3d(8, 21.5, 36)).norm(), 0.0, 1e-12);
  // centre: structured (6.5, 2, 2)
  EXPECT_NEAR((xp::ImageCenter(image) - Eigen::Vector3d(6, 23.25, 36)).norm(), 0.0, 1e-12);
}

TEST(ImageRows, VTKRowsRunUpAndRowZeroComesFirst)
{
  vtkNew<vtkImageData> image;
  image->SetDimensions(3, 2, 1);
  image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  const std::vector<uint16_t> top = { 1, 2, 3, 4, 5, 6 }; // row 0 = 1 2 3
  xp::CopyRowsTopFirst(top, image.GetPointer());
  EXPECT_EQ(static_cast<uint16_t*>(image->GetScalarPointer())[0], 4) << "VTK row 0 is the bottom row";
  EXPECT_EQ(xp::RowsTopFirst<uint16_t>(image), top);
}

TEST(Error, NamesWhereAndWhat)
{
  EXPECT_STREQ(xp::Error("file.json: field", "is bad").what(), "file.json: field: is bad");
}
