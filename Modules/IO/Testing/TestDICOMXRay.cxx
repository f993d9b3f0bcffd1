#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpTestFolders.h"

#include <gdcmImageWriter.h>
#include <gtest/gtest.h>
#include <vtkImageData.h>

namespace
{

/** A 40x30 DX image: value = 100 * column + row (14 bits stored), row 0 first. */
void WriteDX(const std::string& path, const char* modality, bool monochrome1)
{
  std::vector<uint16_t> pixels(40 * 30);
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 40; ++c)
      pixels[r * 40 + c] = static_cast<uint16_t>(100 * c + r);
  gdcm::ImageWriter writer;
  gdcm::Image& image = writer.GetImage();
  image.SetNumberOfDimensions(2);
  image.SetDimension(0, 40);
  image.SetDimension(1, 30);
  image.SetPixelFormat(gdcm::PixelFormat(1, 16, 14, 13, 0));
  image.SetPhotometricInterpretation(
    monochrome1 ? gdcm::PhotometricInterpretation::MONOCHROME1 : gdcm::PhotometricInterpretation::MONOCHROME2);
  gdcm::DataElement data(gdcm::Tag(0x7fe0, 0x0010));
  data.SetByteValue(reinterpret_cast<const char*>(pixels.data()), static_cast<uint32_t>(pixels.size() * 2));
  image.SetDataElement(data);
  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  gdcm::DataElement mod(gdcm::Tag(0x0008, 0x0060));
  mod.SetVR(gdcm::VR::CS);
  std::string value = modality;
  if (value.size() % 2)
    value += ' ';
  mod.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  ds.Replace(mod);
  writer.SetFileName(path.c_str());
  ASSERT_TRUE(writer.Write());
}

} // namespace

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
