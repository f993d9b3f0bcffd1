#include "xpError.h"
#include "xpImageIO.h"
#include "xpTestFolders.h"
#include "xpVolumeIO.h"

#include <Eigen/Geometry>
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

TEST(VolumeIO, UnknownPathsAreRefused)
{
  EXPECT_THROW(xp::ReadCTVolume("no/such/ct.mha"), xp::InputError);
  const std::string dir = FreshFolder("unknown");
  std::ofstream(dir + "/ct.txt") << "text";
  EXPECT_THROW(xp::ReadCTVolume(dir + "/ct.txt"), xp::InputError);
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
