// DICOM X-ray files written with GDCM, for the IO tests.
#ifndef xpTestDICOM_h
#define xpTestDICOM_h

#include <gdcmImageWriter.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace xp::testing
{

/** A 40x30 DX image: value = 100 * column + row (14 bits stored), row 0 first. */
inline void WriteDX(const std::string& path, const char* modality, bool monochrome1)
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


} // namespace xp::testing

#endif
