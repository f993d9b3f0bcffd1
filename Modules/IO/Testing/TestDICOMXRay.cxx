#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"

#include <gtest/gtest.h>
#include <vtkImageData.h>

using xp::testing::WriteDX;

TEST(DICOMXRay, ReadsRowsInOrderScaledTo12Bits)
{
  const std::string dir = xp::testing::FreshFolder("dicom-dx");
  WriteDX(dir + "/dx.dcm", "DX", false);
  vtkSmartPointer<vtkImageData> image = xp::ReadXRayImage(dir + "/dx.dcm");
  ASSERT_EQ(image->GetDimensions()[0], 40);
  const auto* p = static_cast<const uint16_t*>(image->GetScalarPointer());
  // DICOM row 0 is VTK row 29; 14 bits are scaled to 12: (100 c + r) * 4095 / 16383.
  EXPECT_EQ(p[29 * 40 + 10], static_cast<uint16_t>(1000 * 4095.0 / 16383.0 + 0.5));
  EXPECT_EQ(p[0 * 40 + 10], static_cast<uint16_t>(1029 * 4095.0 / 16383.0 + 0.5));
}

TEST(DICOMXRay, Monochrome1IsInvertedAndOtherModalitiesRefused)
{
  const std::string dir = xp::testing::FreshFolder("dicom-cr");
  WriteDX(dir + "/cr.dcm", "CR", true);
  vtkSmartPointer<vtkImageData> image = xp::ReadXRayImage(dir + "/cr.dcm");
  const auto* p = static_cast<const uint16_t*>(image->GetScalarPointer());
  EXPECT_EQ(p[29 * 40 + 0], 4095) << "0 in MONOCHROME1 is full transmission";
  WriteDX(dir + "/mr.dcm", "MR", false);
  EXPECT_THROW(xp::ReadXRayImage(dir + "/mr.dcm"), xp::InputError);
  EXPECT_THROW(xp::ReadXRayImage(dir + "/none.dcm"), xp::InputError);
}
