#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"

#include <gtest/gtest.h>
#include <vtkImageData.h>

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
