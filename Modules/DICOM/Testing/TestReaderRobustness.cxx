// Damaged and inconsistent input is refused with xp::InputError naming the file and the field:
// never a crash, an abort, or a volume padded with zeros.
#include "xpDICOMSeries.h"
#include "xpDICOMSeriesWriter.h"
#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpStereoGeometry.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"
#include "xpVolumeIO.h"

#include <gdcmAttribute.h>
#include <gdcmReader.h>
#include <gdcmWriter.h>
#include <gtest/gtest.h>
#include <vtkImageData.h>

#include <dirent.h>
#include <fstream>
#include <functional>
#include <iterator>

using xp::testing::FreshFolder;

namespace
{

const std::string Regressions = std::string(XP_SOURCE_DIR) + "/Testing/Fuzzing/regressions/";

std::vector<std::string> FilesIn(const std::string& folder)
{
  std::vector<std::string> files;
  if (DIR* d = opendir(folder.c_str()))
  {
    while (dirent* e = readdir(d))
      if (e->d_name[0] != '.')
        files.push_back(folder + "/" + e->d_name);
    closedir(d);
  }
  return files;
}

std::string Bytes(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/** The message of the xp::InputError that `read` must throw ("" and a failure if none). */
std::string Refusal(const std::function<void()>& read, const std::string& what)
{
  try
  {
    read();
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  ADD_FAILURE() << what << " was accepted";
  return "";
}

bool Contains(const std::string& text, const std::string& part)
{
  return text.find(part) != std::string::npos;
}

xp::CTVolumeData TinyVolume()
{
  xp::CTVolumeData v;
  v.dimensions = { 8, 6, 4 };
  v.spacing = { 1.0, 1.0, 2.0 };
  v.hounsfield.assign(8 * 6 * 4, 40.0f);
  return v;
}

/** Replaces one element of a DICOM file (string VRs) through GDCM. */
void SetString(const std::string& file, uint16_t group, uint16_t element, const std::string& value)
{
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::DataElement e(gdcm::Tag(group, element));
  std::string padded = value.size() % 2 ? value + " " : value;
  e.SetByteValue(padded.data(), static_cast<uint32_t>(padded.size()));
  gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  e.SetVR(ds.GetDataElement(gdcm::Tag(group, element)).GetVR());
  ds.Replace(e);
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  writer.SetFileName(file.c_str());
  ASSERT_TRUE(writer.Write());
}

void SetRows(const std::string& file, uint16_t rows)
{
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  ASSERT_TRUE(reader.Read());
  gdcm::Attribute<0x0028, 0x0010> attribute{ rows };
  reader.GetFile().GetDataSet().Replace(attribute.GetAsDataElement());
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  writer.SetFileName(file.c_str());
  ASSERT_TRUE(writer.Write());
}

} // namespace

TEST(ReaderRobustness, EveryRegressionInputIsRefused)
{
  // The inputs that once crashed, aborted or fooled a reader (Testing/Fuzzing/regressions).
  int count = 0;
  for (const std::string& file : FilesIn(Regressions + "DICOMSeries"))
  {
    // As the fuzz target reads them: two slices split at "XPSLICE\n". The refusal must be of
    // the files' content, not only of a folder with one slice.
    const std::string dir = FreshFolder("regression-series");
    const std::string bytes = Bytes(file);
    const size_t split = bytes.find("XPSLICE\n");
    std::ofstream(dir + "/a.dcm", std::ios::binary) << bytes.substr(0, split);
    if (split != std::string::npos)
      std::ofstream(dir + "/b.dcm", std::ios::binary) << bytes.substr(split + 8);
    const std::string message = Refusal([&] { xp::ReadCTVolume(dir); }, file);
    EXPECT_FALSE(Contains(message, "at least two slices")) << file << ": " << message;
    ++count;
  }
  for (const std::string& file : FilesIn(Regressions + "DICOMXRay"))
    Refusal([&] { xp::ReadXRayDICOM(file); }, file), ++count;
  for (const std::string& file : FilesIn(Regressions + "PNG"))
    Refusal([&] { xp::ReadXRayPNG(file); }, file), ++count;
  for (const std::string& file : FilesIn(Regressions + "MetaImage"))
  {
    const std::string dir = FreshFolder("regression-mha");
    std::ofstream(dir + "/ct.mha", std::ios::binary) << Bytes(file);
    Refusal([&] { xp::ReadCTVolume(dir + "/ct.mha"); }, file), ++count;
  }
  for (const std::string& file : FilesIn(Regressions + "NIfTI"))
  {
    const std::string dir = FreshFolder("regression-nii");
    const std::string copy = dir + (file.size() > 3 && file.substr(file.size() - 3) == ".gz" ? "/ct.nii.gz" : "/ct.nii");
    std::ofstream(copy, std::ios::binary) << Bytes(file);
    Refusal([&] { xp::ReadCTVolume(copy); }, file), ++count;
  }
  for (const std::string& file : FilesIn(Regressions + "Geometry"))
    Refusal([&] { xp::ReadStereoGeometry(file); }, file), ++count;
  for (const std::string& file : FilesIn(Regressions + "TIFF"))
  {
    // Refused as an X-ray and as a volume stack alike.
    Refusal([&] { xp::ReadXRayTIFF(file); }, file), ++count;
    Refusal([&] { xp::ReadCTVolume(file, "", { 0.5, 0.5, 1.0 }); }, file);
  }
  EXPECT_GE(count, 20) << "the regression corpus went missing";
}

TEST(ReaderRobustness, ADICOMFileCutAnywhereInItsHeaderIsRefusedNamingIt)
{
  const std::string dir = FreshFolder("cut-everywhere");
  const std::vector<std::string> files = xp::WriteCTSeries(TinyVolume(), dir);
  const std::string whole = Bytes(files[1]);
  for (size_t length = 0; length < whole.size(); length += 7)
  {
    std::ofstream(files[1], std::ios::binary | std::ios::trunc).write(whole.data(), length);
    const std::string message = Refusal([&] { xp::ReadCTVolume(dir); }, "cut at " + std::to_string(length));
    EXPECT_TRUE(Contains(message, files[1])) << length << ": " << message;
  }
}

TEST(ReaderRobustness, NonFiniteGeometryAndRowsBeyondTheDataAreRefused)
{
  const std::string dir = FreshFolder("dicom-bad-tags");
  std::vector<std::string> files = xp::WriteCTSeries(TinyVolume(), dir);
  for (const std::string& file : files)
    SetString(file, 0x0028, 0x0030, "inf\\inf");
  EXPECT_TRUE(Contains(Refusal([&] { xp::ReadCTVolume(dir); }, "Pixel Spacing inf"), "Pixel Spacing (0028,0030)"));

  files = xp::WriteCTSeries(TinyVolume(), FreshFolder("dicom-bad-tags"));
  for (const std::string& file : files)
    SetString(file, 0x0020, 0x0032, "nan\\nan\\nan");
  EXPECT_TRUE(Contains(Refusal([&] { xp::ReadCTVolume(dir); }, "Image Position NaN"), "Image Position (Patient)"));

  files = xp::WriteCTSeries(TinyVolume(), FreshFolder("dicom-bad-tags"));
  SetRows(files[2], 60000);
  const std::string rows = Refusal([&] { xp::ReadCTVolume(dir); }, "Rows beyond the data");
  EXPECT_TRUE(Contains(rows, files[2]) && Contains(rows, "Pixel Data (7FE0,0010)")) << rows;
}

TEST(ReaderRobustness, AnXRayMissingPartOfItsPixelDataIsRefused)
{
  const std::string dir = FreshFolder("dx-cut");
  xp::testing::WriteDX(dir + "/dx.dcm", "DX", false); // 40 x 30 pixels of 16 bits
  EXPECT_NO_THROW(xp::ReadXRayDICOM(dir + "/dx.dcm"));
  const std::string whole = Bytes(dir + "/dx.dcm");
  std::ofstream(dir + "/dx.dcm", std::ios::binary | std::ios::trunc).write(whole.data(), whole.size() - 40 * 30);
  const std::string message = Refusal([&] { xp::ReadXRayDICOM(dir + "/dx.dcm"); }, "half the pixel data");
  EXPECT_TRUE(Contains(message, "dx.dcm") && Contains(message, "(7FE0,0010)")) << message;
}
