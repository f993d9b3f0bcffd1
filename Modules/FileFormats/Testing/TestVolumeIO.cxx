#include "xpError.h"
#include "xpImageIO.h"
#include "xpTestFolders.h"
#include "xpVolumeIO.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <gtest/gtest.h>
#include <zlib.h>
#include <sys/stat.h>
#include <vtkImageData.h>
#include <vtkMatrix4x4.h>
#include <vtkNIFTIImageWriter.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>

using xp::testing::FreshFolder;

namespace
{
vtkNew<vtkShortArray> Ramp(int n)
{
  vtkNew<vtkShortArray> values;
  values->SetNumberOfValues(n);
  for (int i = 0; i < n; ++i)
    values->SetValue(i, static_cast<short>(i - 1000));
  return values;
}
} // namespace

TEST(VolumeIO, MetaImageDirectionIsRead)
{
  const std::string dir = FreshFolder("mha");
  const std::string path = dir + "/ct.mha";
  {
    std::ofstream out(path, std::ios::binary);
    out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
        << "TransformMatrix = 0 1 0 -1 0 0 0 0 1\nOffset = 10 20 30\nElementSpacing = 1 2 3\n"
        << "DimSize = 4 3 2\nElementType = MET_SHORT\nElementDataFile = LOCAL\n";
    for (short v = 0; v < 24; ++v)
    {
      const short hu = static_cast<short>(v * 10 - 1000);
      out.write(reinterpret_cast<const char*>(&hu), 2);
    }
  }
  const xp::CTVolume ct = xp::ReadCTVolume(path);
  double p[3];
  const double index[3] = { 1, 1, 1 };
  ct.image->TransformContinuousIndexToPhysicalPoint(index, p);
  // Axis i runs along +y (0 1 0), axis j along -x: (10, 20, 30) + 1*(0,1,0) + 2*(-1,0,0) + 3*(0,0,1).
  EXPECT_NEAR(p[0], 8.0, 1e-9);
  EXPECT_NEAR(p[1], 21.0, 1e-9);
  EXPECT_NEAR(p[2], 33.0, 1e-9);
  EXPECT_EQ(ct.image->GetScalarComponentAsDouble(1, 1, 1, 0), (1 + 4 + 12) * 10 - 1000);
  EXPECT_EQ(ct.image->GetScalarType(), VTK_SHORT); // whole HU stay 16-bit integers
}

TEST(VolumeIO, NIfTIIsConvertedFromRASToLPS)
{
  const std::string dir = FreshFolder("nifti");
  vtkNew<vtkImageData> image;
  image->SetDimensions(4, 3, 2);
  image->SetSpacing(1.5, 1.5, 2.0);
  image->GetPointData()->SetScalars(Ramp(24));
  vtkNew<vtkMatrix4x4> qform; // index*spacing -> RAS: identity axes, offset (5, 6, 7)
  qform->SetElement(0, 3, 5.0);
  qform->SetElement(1, 3, 6.0);
  qform->SetElement(2, 3, 7.0);
  vtkNew<vtkNIFTIImageWriter> writer;
  writer->SetInputData(image);
  writer->SetQFormMatrix(qform);
  writer->SetFileName((dir + "/ct.nii.gz").c_str());
  writer->Write();
  const xp::CTVolume ct = xp::ReadCTVolume(dir + "/ct.nii.gz");
  double p[3];
  const double index[3] = { 2, 1, 1 };
  ct.image->TransformContinuousIndexToPhysicalPoint(index, p);
  EXPECT_NEAR(p[0], -(5.0 + 3.0), 1e-6); // RAS x (right->left) becomes LPS -x
  EXPECT_NEAR(p[1], -(6.0 + 1.5), 1e-6);
  EXPECT_NEAR(p[2], 7.0 + 2.0, 1e-6);
  EXPECT_EQ(ct.image->GetScalarComponentAsDouble(2, 1, 1, 0), (2 + 4 + 12) - 1000);
  EXPECT_EQ(ct.image->GetScalarType(), VTK_SHORT);

  // A rescale slope other than 1 gives fractional HU: kept as float.
  writer->SetRescaleSlope(0.5);
  writer->SetFileName((dir + "/half.nii.gz").c_str());
  writer->Write();
  const xp::CTVolume half = xp::ReadCTVolume(dir + "/half.nii.gz");
  EXPECT_EQ(half.image->GetScalarType(), VTK_FLOAT);
  EXPECT_DOUBLE_EQ(half.image->GetScalarComponentAsDouble(3, 0, 0, 0), 0.5 * (3 - 1000));
}

TEST(VolumeIO, MetaImageCompressedOrBesideItsHeaderIsReadAndRefusedWhenCut)
{
  const std::string dir = FreshFolder("mha-zlib");
  std::vector<short> voxels(4 * 3 * 2);
  for (size_t i = 0; i < voxels.size(); ++i)
    voxels[i] = static_cast<short>(10 * i - 1000);
  std::vector<Bytef> packed(compressBound(voxels.size() * 2));
  uLongf packedSize = packed.size();
  ASSERT_EQ(compress2(packed.data(), &packedSize, reinterpret_cast<const Bytef*>(voxels.data()), voxels.size() * 2, 9), Z_OK);
  const std::string header = "ObjectType = Image\nNDims = 3\nDimSize = 4 3 2\nElementSpacing = 1 1 2\n"
                             "ElementType = MET_SHORT\n";
  const auto write = [&](const std::string& name, const std::string& text, size_t bytes) {
    std::ofstream out(dir + "/" + name, std::ios::binary);
    out << text;
    out.write(reinterpret_cast<const char*>(packed.data()), static_cast<std::streamsize>(bytes));
  };
  write("ct.mha", header + "CompressedData = True\nElementDataFile = LOCAL\n", packedSize);
  EXPECT_EQ(xp::ReadCTVolume(dir + "/ct.mha").image->GetScalarComponentAsDouble(3, 2, 1, 0), 10 * 23 - 1000);
  write("cut.mha", header + "CompressedData = True\nElementDataFile = LOCAL\n", packedSize - 6);
  EXPECT_THROW(xp::ReadCTVolume(dir + "/cut.mha"), xp::InputError);
  // Raw data in a file of its own, after a 16-byte header of that file's own.
  std::ofstream(dir + "/ct.mhd") << header << "HeaderSize = 16\nElementDataFile = ct.raw\n";
  std::ofstream raw(dir + "/ct.raw", std::ios::binary);
  raw << std::string(16, 'h');
  raw.write(reinterpret_cast<const char*>(voxels.data()), static_cast<std::streamsize>(voxels.size() * 2));
  raw.close();
  EXPECT_EQ(xp::ReadCTVolume(dir + "/ct.mhd").image->GetScalarComponentAsDouble(1, 0, 0, 0), -990);
}

// More voxels than the reader converts at a time (2^21), so chunk borders are crossed.
TEST(VolumeIO, LargeMetaImagesAreConvertedInFileOrderAndTheFirstBadVoxelIsNamed)
{
  const std::string dir = FreshFolder("mha-large");
  const int nx = 130, ny = 130, nz = 130;
  const size_t count = static_cast<size_t>(nx) * ny * nz;
  const auto value = [](size_t i) { return static_cast<float>(static_cast<int>(i % 3001) - 1000); };
  const auto write = [&](const std::string& name, bool bigEndian, bool compressed, size_t nanAt, size_t extraBytes) {
    std::vector<unsigned char> bytes(count * 4);
    for (size_t i = 0; i < count; ++i)
    {
      float v = i == nanAt ? std::nanf("") : value(i);
      unsigned char* b = bytes.data() + 4 * i;
      std::memcpy(b, &v, 4);
      if (bigEndian)
        std::reverse(b, b + 4);
    }
    bytes.resize(bytes.size() + extraBytes, 7);
    std::ofstream out(dir + "/" + name, std::ios::binary);
    out << "ObjectType = Image\nNDims = 3\nDimSize = " << nx << " " << ny << " " << nz << "\nElementType = MET_FLOAT\n"
        << "BinaryDataByteOrderMSB = " << (bigEndian ? "True" : "False") << "\n"
        << "CompressedData = " << (compressed ? "True" : "False") << "\nElementDataFile = LOCAL\n";
    if (compressed)
    {
      std::vector<Bytef> packed(compressBound(bytes.size()));
      uLongf packedSize = packed.size();
      ASSERT_EQ(compress2(packed.data(), &packedSize, bytes.data(), bytes.size(), 1), Z_OK);
      out.write(reinterpret_cast<const char*>(packed.data()), static_cast<std::streamsize>(packedSize));
    }
    else
    {
      out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    }
  };
  const size_t none = count;
  const size_t secondChunk = (size_t(1) << 21) + 5;
  for (const bool bigEndian : { false, true })
  {
    for (const bool compressed : { false, true })
    {
      const std::string name = std::string(bigEndian ? "msb" : "lsb") + (compressed ? "-z" : "") + ".mha";
      SCOPED_TRACE(name);
      write(name, bigEndian, compressed, none, 0);
      const xp::CTVolume ct = xp::ReadCTVolume(dir + "/" + name);
      const float* hu = static_cast<const float*>(ct.image->GetScalarPointer());
      for (const size_t i : { size_t(0), size_t(1) << 21, secondChunk, count - 1 })
        EXPECT_EQ(hu[i], value(i)) << "voxel " << i;
      write("nan-" + name, bigEndian, compressed, secondChunk, 0);
      try
      {
        xp::ReadCTVolume(dir + "/nan-" + name);
        ADD_FAILURE() << "a NaN voxel was read";
      }
      catch (const xp::InputError& e)
      {
        EXPECT_NE(std::string(e.what()).find("voxel " + std::to_string(secondChunk) + " "), std::string::npos) << e.what();
      }
    }
  }
  // 16-bit voxels, big-endian: converted a chunk at a time into 16-bit HU.
  {
    std::vector<unsigned char> bytes(count * 2);
    for (size_t i = 0; i < count; ++i)
    {
      const int16_t v = static_cast<int16_t>(value(i));
      bytes[2 * i] = static_cast<unsigned char>((v >> 8) & 0xff);
      bytes[2 * i + 1] = static_cast<unsigned char>(v & 0xff);
    }
    std::ofstream out(dir + "/short-msb.mha", std::ios::binary);
    out << "ObjectType = Image\nNDims = 3\nDimSize = " << nx << " " << ny << " " << nz << "\nElementType = MET_SHORT\n"
        << "BinaryDataByteOrderMSB = True\nElementDataFile = LOCAL\n";
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  const xp::CTVolume shortCT = xp::ReadCTVolume(dir + "/short-msb.mha");
  ASSERT_EQ(shortCT.image->GetScalarType(), VTK_SHORT);
  const int16_t* shortHU = static_cast<const int16_t*>(shortCT.image->GetScalarPointer());
  for (const size_t i : { size_t(0), size_t(1) << 21, secondChunk, count - 1 })
    EXPECT_EQ(shortHU[i], value(i)) << "voxel " << i;
  write("long-z.mha", false, true, none, 8);
  try
  {
    xp::ReadCTVolume(dir + "/long-z.mha");
    ADD_FAILURE() << "compressed data longer than DimSize was read";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("holds more"), std::string::npos) << e.what();
  }
}

TEST(VolumeIO, UnknownPathsAreRefused)
{
  EXPECT_THROW(xp::ReadCTVolume("no/such/ct.mha"), xp::InputError);
  const std::string dir = FreshFolder("unknown");
  std::ofstream(dir + "/ct.txt") << "text";
  EXPECT_THROW(xp::ReadCTVolume(dir + "/ct.txt"), xp::InputError);
}

// PNG's first row is the top: VTK's last row. 16-bit samples keep their value (byte order).
TEST(ImageIO, PNGRoundTripKeepsRowsAndSixteenBitValues)
{
  const std::string dir = FreshFolder("png");
  vtkNew<vtkImageData> image;
  image->SetDimensions(3, 2, 1);
  image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  auto* pixels = static_cast<unsigned short*>(image->GetScalarPointer());
  for (int i = 0; i < 6; ++i)
    pixels[i] = static_cast<unsigned short>(1 + 700 * i); // up to 3501: 12-bit, both bytes used
  xp::WritePNG(image, dir + "/x.png");
  vtkSmartPointer<vtkImageData> back = xp::ReadXRayPNG(dir + "/x.png");
  ASSERT_EQ(back->GetNumberOfPoints(), 6);
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i)
      EXPECT_EQ(back->GetScalarComponentAsDouble(i, j, 0, 0), pixels[j * 3 + i]) << i << "," << j;
  // The mask reader sees the same layout in 8 bits.
  vtkNew<vtkImageData> mask;
  mask->SetDimensions(3, 2, 1);
  mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* m = static_cast<unsigned char*>(mask->GetScalarPointer());
  for (int i = 0; i < 6; ++i)
    m[i] = i == 1 ? 255 : 0;
  xp::WritePNG(mask, dir + "/m.png");
  vtkSmartPointer<vtkImageData> maskBack = xp::ReadMaskPNG(dir + "/m.png", 3, 2);
  for (int i = 0; i < 6; ++i)
    EXPECT_EQ(static_cast<const unsigned char*>(maskBack->GetScalarPointer())[i], i == 1 ? 1 : 0) << i;
  EXPECT_THROW(xp::WritePNG(mask, dir + "/no/such/folder/m.png"), xp::Error);
}

TEST(StagedOutputDirectory, NothingAppearsUnlessCommitted)
{
  const std::string dir = FreshFolder("staged");
  struct stat status;
  {
    xp::StagedOutputDirectory out(dir);
    std::ofstream(out.Path("a.txt")) << "a";
  }
  EXPECT_NE(stat((dir + "/a.txt").c_str(), &status), 0) << "uncommitted output appeared";
  {
    xp::StagedOutputDirectory out(dir);
    std::ofstream(out.Path("b.txt")) << "b";
    out.Commit();
  }
  EXPECT_EQ(stat((dir + "/b.txt").c_str(), &status), 0);
  {
    xp::StagedOutputDirectory nested(dir + "/new/deeper"); // parents are created
    std::ofstream(nested.Path("c.txt")) << "c";
    nested.Commit();
  }
  EXPECT_EQ(stat((dir + "/new/deeper/c.txt").c_str(), &status), 0);
  EXPECT_EQ(std::system(("test $(ls -A '" + dir + "' | wc -l) -eq 2").c_str()), 0) << "staging folder left behind";
}
