#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"

#include <gtest/gtest.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

#include "xpImageIO.h"

using xp::testing::WriteDX;

TEST(DICOMXRay, ReadsRowsInOrderWithTheirStoredValues)
{
  const std::string dir = xp::testing::FreshFolder("dicom-dx");
  WriteDX(dir + "/dx.dcm", "DX", false);
  vtkSmartPointer<vtkImageData> image = xp::ReadXRayImage(dir + "/dx.dcm");
  ASSERT_EQ(image->GetDimensions()[0], 40);
  const auto* p = static_cast<const uint16_t*>(image->GetScalarPointer());
  // DICOM row 0 is VTK row 29; 14 stored bits are kept as they are: 100 c + r.
  EXPECT_EQ(p[29 * 40 + 10], 1000);
  EXPECT_EQ(p[0 * 40 + 10], 1029);
}

TEST(DICOMXRay, Monochrome1IsInvertedAndOtherModalitiesRefused)
{
  const std::string dir = xp::testing::FreshFolder("dicom-cr");
  WriteDX(dir + "/cr.dcm", "CR", true);
  vtkSmartPointer<vtkImageData> image = xp::ReadXRayImage(dir + "/cr.dcm");
  const auto* p = static_cast<const uint16_t*>(image->GetScalarPointer());
  EXPECT_EQ(p[29 * 40 + 0], 16383) << "0 in MONOCHROME1 (14 bits) is full transmission";
  WriteDX(dir + "/mr.dcm", "MR", false);
  EXPECT_THROW(xp::ReadXRayImage(dir + "/mr.dcm"), xp::InputError);
  EXPECT_THROW(xp::ReadXRayImage(dir + "/none.dcm"), xp::InputError);
}

TEST(XRayPNG, SixteenAndEightBitGreyAreReadAsStoredAndColourRefused)
{
  const std::string dir = xp::testing::FreshFolder("xray-png");
  for (int type : { VTK_UNSIGNED_SHORT, VTK_UNSIGNED_CHAR })
  {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(8, 4, 1);
    image->AllocateScalars(type, 1);
    for (int i = 0; i < 32; ++i)
      image->GetPointData()->GetScalars()->SetComponent(i, 0, type == VTK_UNSIGNED_SHORT ? 2000 * i + 1 : 8 * i);
    const std::string path = dir + (type == VTK_UNSIGNED_SHORT ? "/raw16.png" : "/processed8.png");
    xp::WritePNG(image, path);
    vtkSmartPointer<vtkImageData> read = xp::ReadXRayImage(path);
    const auto* p = static_cast<const uint16_t*>(read->GetScalarPointer());
    // A raw panel's 16 bits are kept (no refusal above 4095, no scaling); 8 bits stay 0..255.
    EXPECT_EQ(p[31], type == VTK_UNSIGNED_SHORT ? 62001 : 248);
    EXPECT_EQ(p[0], type == VTK_UNSIGNED_SHORT ? 1 : 0);
  }
  auto colour = vtkSmartPointer<vtkImageData>::New();
  colour->SetDimensions(8, 4, 1);
  colour->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  xp::WritePNG(colour, dir + "/colour.png");
  EXPECT_THROW(xp::ReadXRayImage(dir + "/colour.png"), xp::InputError);
}
