// TIFF input: X-rays of 8 and 16 bits with their rows in place, bone volumes as page stacks
// placed with their axes along the room's, and damaged or unsuitable files refused by name.
#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpPose.h"
#include "xpTestFolders.h"
#include "xpVolumeIO.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <tiffio.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>

#include <cstdint>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

using xp::testing::FreshFolder;

namespace
{

/** Writes `pages` pages of columns x rows grey pixels, value(column, row, page), top row first. */
void WriteTIFF(const std::string& path, int columns, int rows, int pages, int bits,
  const std::function<int(int, int, int)>& value, uint16_t photometric = PHOTOMETRIC_MINISBLACK, int samples = 1)
{
  TIFF* tiff = TIFFOpen(path.c_str(), "w");
  ASSERT_NE(tiff, nullptr) << path;
  for (int page = 0; page < pages; ++page)
  {
    TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, columns);
    TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, rows);
    TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, bits);
    TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, samples);
    TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, photometric);
    TIFFSetField(tiff, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
    TIFFSetField(tiff, TIFFTAG_ROWSPERSTRIP, 1);
    if (pages > 1)
    {
      TIFFSetField(tiff, TIFFTAG_SUBFILETYPE, FILETYPE_PAGE);
      TIFFSetField(tiff, TIFFTAG_PAGENUMBER, page, pages);
    }
    std::vector<uint8_t> line(static_cast<size_t>(columns) * samples * bits / 8);
    for (int row = 0; row < rows; ++row)
    {
      for (int i = 0; i < columns * samples; ++i)
      {
        const int v = value(i / samples, row, page);
        if (bits == 8)
          line[i] = static_cast<uint8_t>(v);
        else
          reinterpret_cast<uint16_t*>(line.data())[i] = static_cast<uint16_t>(v);
      }
      TIFFWriteScanline(tiff, line.data(), row, 0);
    }
    TIFFWriteDirectory(tiff);
  }
  TIFFClose(tiff);
}

void ExpectRefusal(const std::function<void()>& read, const std::string& name, const std::string& words)
{
  try
  {
    read();
    ADD_FAILURE() << name << " was read";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

} // namespace

// TIFF row 0 is the detector's top row: VTK's last. 16-bit values keep both bytes, 8-bit ones
// their value; a white-is-zero image is turned round so that larger is brighter in every file.
TEST(TIFF, XRaysOfEightAndSixteenBitsKeepTheirRowsAndValues)
{
  const std::string dir = FreshFolder("tiff-xray");
  const auto value = [](int column, int row, int) { return 1 + 700 * (row * 3 + column); };
  WriteTIFF(dir + "/x16.tif", 3, 2, 1, 16, value);
  WriteTIFF(dir + "/x8.tif", 3, 2, 1, 8, [](int column, int row, int) { return 10 * (row * 3 + column); });
  WriteTIFF(dir + "/white.tif", 3, 2, 1, 8, [](int column, int row, int) { return 10 * (row * 3 + column); },
    PHOTOMETRIC_MINISWHITE);
  // Read by content, as the register command does: the extension does not decide.
  std::ifstream from(dir + "/x16.tif", std::ios::binary);
  std::ofstream(dir + "/x16.img", std::ios::binary) << from.rdbuf();
  for (const std::string name : { "x16.tif", "x16.img" })
  {
    vtkSmartPointer<vtkImageData> image = xp::ReadXRayImage(dir + "/" + name);
    ASSERT_EQ(image->GetScalarType(), VTK_UNSIGNED_SHORT);
    for (int row = 0; row < 2; ++row)
      for (int column = 0; column < 3; ++column)
        EXPECT_EQ(image->GetScalarComponentAsDouble(column, 1 - row, 0, 0), value(column, row, 0)) << name;
  }
  vtkSmartPointer<vtkImageData> eight = xp::ReadXRayTIFF(dir + "/x8.tif");
  vtkSmartPointer<vtkImageData> white = xp::ReadXRayTIFF(dir + "/white.tif");
  for (int row = 0; row < 2; ++row)
    for (int column = 0; column < 3; ++column)
    {
      EXPECT_EQ(eight->GetScalarComponentAsDouble(column, 1 - row, 0, 0), 10 * (row * 3 + column));
      EXPECT_EQ(white->GetScalarComponentAsDouble(column, 1 - row, 0, 0), 255 - 10 * (row * 3 + column));
    }
}

TEST(TIFF, UnsuitableOrDamagedXRaysAreRefusedByName)
{
  const std::string dir = FreshFolder("tiff-bad");
  const auto flat = [](int, int, int) { return 100; };
  WriteTIFF(dir + "/stack.tif", 4, 4, 2, 16, flat);
  ExpectRefusal([&] { xp::ReadXRayTIFF(dir + "/stack.tif"); }, "stack.tif", "2 pages");
  WriteTIFF(dir + "/rgb.tif", 4, 4, 1, 8, flat, PHOTOMETRIC_RGB, 3);
  ExpectRefusal([&] { xp::ReadXRayTIFF(dir + "/rgb.tif"); }, "rgb.tif", "grey");
  // Cut short: the header promises pixels the file does not hold.
  WriteTIFF(dir + "/whole.tif", 64, 64, 1, 16, [](int c, int r, int) { return c * r; });
  std::ifstream in(dir + "/whole.tif", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir + "/cut.tif", std::ios::binary) << bytes.substr(0, bytes.size() / 3);
  EXPECT_THROW(xp::ReadXRayTIFF(dir + "/cut.tif"), xp::InputError);
  std::ofstream(dir + "/header.tif", std::ios::binary) << bytes.substr(0, 6);
  ExpectRefusal([&] { xp::ReadXRayTIFF(dir + "/header.tif"); }, "header.tif", "TIFF");
}

// Columns along x, rows along y, pages along z; at pose zero the index axes are the room's (HFS
// turns the stored LPS directions into Room x, y, z); values are CT numbers + 1000.
TEST(TIFF, VolumeStacksTakeTheirVoxelSizeAndTheRoomsAxes)
{
  const std::string dir = FreshFolder("tiff-volume");
  const auto value = [](int column, int row, int page) { return 1000 + column + 10 * row + 100 * page; };
  WriteTIFF(dir + "/bone.tif", 4, 3, 5, 16, value);
  const xp::CTVolume volume = xp::ReadCTVolume(dir + "/bone.tif", "", { 0.5, 0.25, 2.0 });
  int dims[3];
  volume.image->GetDimensions(dims);
  EXPECT_EQ(dims[0], 4);
  EXPECT_EQ(dims[1], 3);
  EXPECT_EQ(dims[2], 5);
  double spacing[3];
  volume.image->GetSpacing(spacing);
  EXPECT_DOUBLE_EQ(spacing[0], 0.5);
  EXPECT_DOUBLE_EQ(spacing[1], 0.25);
  EXPECT_DOUBLE_EQ(spacing[2], 2.0);
  EXPECT_EQ(volume.patientPosition, "HFS");
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 4; ++i)
        EXPECT_EQ(volume.image->GetScalarComponentAsDouble(i, j, k, 0), value(i, j, k) - 1000) << i << j << k;
  Eigen::Matrix3d direction;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      direction(r, c) = volume.image->GetDirectionMatrix()->GetElement(r, c);
  const Eigen::Matrix3d indexToRoom = xp::PatientToRoomRotation(xp::PatientPosition::HFS) * direction;
  EXPECT_LT((indexToRoom - Eigen::Matrix3d::Identity()).norm(), 1e-12) << indexToRoom;

  ExpectRefusal([&] { xp::ReadCTVolume(dir + "/bone.tif"); }, "--voxel-size", "bone.tif");
  ExpectRefusal([&] { xp::ReadCTVolume(dir + "/no.mha", "", { 1, 1, 1 }); }, "no.mha", "no such");
  std::ofstream(dir + "/ct.mha") << "ObjectType = Image\n";
  ExpectRefusal([&] { xp::ReadCTVolume(dir + "/ct.mha", "", { 1, 1, 1 }); }, "--voxel-size", "TIFF volumes only");
  WriteTIFF(dir + "/one.tif", 4, 3, 1, 16, value);
  ExpectRefusal([&] { xp::ReadCTVolume(dir + "/one.tif", "", { 1, 1, 1 }); }, "one.tif", "one page");
  ExpectRefusal([&] { xp::ParseVoxelSize("0.4,0.4", "--voxel-size"); }, "--voxel-size", "three");
  ExpectRefusal([&] { xp::ParseVoxelSize("0.4,-1,2", "--voxel-size"); }, "--voxel-size", "three");
  EXPECT_EQ(xp::ParseVoxelSize("0.4,0.5,2", "--voxel-size")[1], 0.5);
}

TEST(TIFF, StacksWhosePagesDifferAreRefusedNamingThePage)
{
  const std::string dir = FreshFolder("tiff-mixed");
  TIFF* tiff = TIFFOpen((dir + "/mixed.tif").c_str(), "w");
  ASSERT_NE(tiff, nullptr);
  for (int page = 0; page < 2; ++page)
  {
    const int width = page == 0 ? 4 : 5;
    TIFFSetField(tiff, TIFFTAG_IMAGEWIDTH, width);
    TIFFSetField(tiff, TIFFTAG_IMAGELENGTH, 3);
    TIFFSetField(tiff, TIFFTAG_BITSPERSAMPLE, 16);
    TIFFSetField(tiff, TIFFTAG_SAMPLESPERPIXEL, 1);
    TIFFSetField(tiff, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
    std::vector<uint16_t> line(width, 7);
    for (int row = 0; row < 3; ++row)
      TIFFWriteScanline(tiff, line.data(), row, 0);
    TIFFWriteDirectory(tiff);
  }
  TIFFClose(tiff);
  ExpectRefusal([&] { xp::ReadCTVolume(dir + "/mixed.tif", "", { 1, 1, 1 }); }, "mixed.tif", "page 2");
}
