// DICOM X-ray files written with GDCM, for the IO tests.
#ifndef xpTestDICOM_h
#define xpTestDICOM_h

#include <gdcmImageWriter.h>
#include <gtest/gtest.h>

#include "xpWholeFile.h"

#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace xp::testing
{

/** A text element of a test file. */
struct TestElement
{
  uint16_t group, element;
  gdcm::VR vr;
  std::string value;
};

/** A 40x30 DX image: value = 100 * column + row (14 bits stored), row 0 first, with `extra`
 *  elements. */
inline void WriteDX(const std::string& path, const char* modality, bool monochrome1, const std::vector<TestElement>& extra = {})
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
  for (const TestElement& e : extra) // ImageWriter writes Imager Pixel Spacing from the image's spacing
    if (e.group == 0x0018 && e.element == 0x1164)
    {
      double between[2] = { 1.0, 1.0 };
      std::sscanf(e.value.c_str(), "%lf\\%lf", &between[0], &between[1]);
      image.SetSpacing(0, between[1]); // along a row: between columns
      image.SetSpacing(1, between[0]);
    }
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
  for (const TestElement& e : extra)
  {
    gdcm::DataElement de(gdcm::Tag(e.group, e.element));
    de.SetVR(e.vr);
    std::string text = e.value;
    if (text.size() % 2)
      text += e.vr == gdcm::VR::UI ? '\0' : ' ';
    de.SetByteValue(text.data(), static_cast<uint32_t>(text.size()));
    ds.Replace(de);
  }
  writer.SetFileName(path.c_str());
  ASSERT_TRUE(writer.Write());
}


/** Whether dicom3tools' dciodvfy is installed (Debian package dicom3tools). */
inline bool HaveDciodvfy()
{
  return std::system("command -v dciodvfy > /dev/null 2>&1") == 0;
}

/** dciodvfy's report on the DICOM file at `path` (its IOD check), kept beside it. */
inline std::string DciodvfyReport(const std::string& path)
{
  std::system(("dciodvfy " + path + " > " + path + ".dciodvfy.txt 2>&1").c_str());
  return xp::ReadWholeFile(path + ".dciodvfy.txt");
}

/** dcmtk, an independent reader, reads the whole file without complaint (when installed). */
inline void ExpectDcmtkReads(const std::string& path)
{
  if (std::system("command -v dcmdump > /dev/null 2>&1") == 0)
    EXPECT_EQ(std::system(("dcmdump -q " + path + " > /dev/null").c_str()), 0) << path;
}

} // namespace xp::testing

#endif
