#include "vtkXPDICOMCTReader.h"
#include "xpDICOMSeries.h"
#include "xpDICOMSeriesWriter.h"
#include "xpError.h"
#include "xpTestFolders.h"
#include "xpVolumeIO.h"

#include <Eigen/Geometry>
#include <cstdio>
#include <fstream>
#include <gtest/gtest.h>
#include <vtkImageData.h>

using xp::testing::FreshFolder;

namespace
{

/** 16 x 12 x 10 voxels, HU = 10 i + 100 j + 1000 k - 1000 (a value that names its voxel). */
xp::CTVolumeData SmallVolume(const Eigen::Matrix3d& direction = Eigen::Matrix3d::Identity())
{
  xp::CTVolumeData v;
  v.dimensions = { 16, 12, 10 };
  v.spacing = { 0.8, 0.9, 2.5 };
  v.origin = { -30.0, 12.0, 400.0 };
  v.direction = direction;
  for (int k = 0; k < 10; ++k)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 16; ++i)
        v.hounsfield.push_back(static_cast<float>(10 * i + 100 * j + 1000 * k - 1000));
  return v;
}

std::string ErrorOf(const std::string& folder, const std::string& uid = "")
{
  try
  {
    xp::ScanCTSeries(folder, uid);
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}

bool Contains(const std::string& text, const std::string& part)
{
  return text.find(part) != std::string::npos;
}

} // namespace

TEST(DICOMCTReader, ReadsGeometryAndHUAndSortsByPositionNotName)
{
  const std::string dir = FreshFolder("dicom-sorted");
  const std::vector<std::string> files = xp::WriteCTSeries(SmallVolume(), dir);
  // Reverse the file names: the name order now runs against the slice positions.
  for (size_t k = 0; k < files.size(); ++k)
    std::rename(files[k].c_str(), (dir + "/tmp" + std::to_string(k)).c_str());
  for (size_t k = 0; k < files.size(); ++k)
    std::rename((dir + "/tmp" + std::to_string(k)).c_str(), files[files.size() - 1 - k].c_str());

  vtkNew<vtkXPDICOMCTReader> reader;
  reader->SetDirectoryName(dir.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  int dims[3];
  image->GetDimensions(dims);
  EXPECT_EQ(dims[0], 16);
  EXPECT_EQ(dims[1], 12);
  EXPECT_EQ(dims[2], 10);
  EXPECT_NEAR(image->GetSpacing()[0], 0.8, 1e-6);
  EXPECT_NEAR(image->GetSpacing()[1], 0.9, 1e-6);
  EXPECT_NEAR(image->GetSpacing()[2], 2.5, 1e-6);
  EXPECT_NEAR(image->GetOrigin()[2], 400.0, 1e-6);
  EXPECT_EQ(image->GetScalarComponentAsDouble(3, 5, 7, 0), 10 * 3 + 100 * 5 + 1000 * 7 - 1000);
  EXPECT_EQ(reader->GetPatientPosition(), "HFS");
}

// A CT stores whole HU in 16 bits: the image keeps them so (half the memory of floats), and the
// few beyond the 16-bit range are clamped to it.
TEST(DICOMCTReader, WholeHUAreKeptAsSixteenBitIntegersAndClampedBeyond)
{
  const std::string dir = FreshFolder("dicom-short");
  xp::CTVolumeData volume = SmallVolume();
  volume.hounsfield[5] = 40000.0f; // beyond any anatomy or metal
  xp::WriteCTSeries(volume, dir);
  vtkNew<vtkXPDICOMCTReader> reader;
  reader->SetDirectoryName(dir.c_str());
  reader->UpdateInformation();
  EXPECT_EQ(vtkImageData::GetScalarType(reader->GetOutputInformation(0)), VTK_SHORT);
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  ASSERT_EQ(image->GetScalarType(), VTK_SHORT);
  EXPECT_EQ(image->GetScalarComponentAsDouble(3, 5, 7, 0), 10 * 3 + 100 * 5 + 1000 * 7 - 1000);
  EXPECT_EQ(image->GetScalarComponentAsDouble(0, 0, 0, 0), -1000);
  EXPECT_EQ(image->GetScalarComponentAsDouble(5, 0, 0, 0), 32767);
}

TEST(DICOMCTReader, KeepsObliqueOrientation)
{
  const Eigen::Matrix3d rotation =
    Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 0.5).normalized()).toRotationMatrix();
  const xp::CTVolumeData volume = SmallVolume(rotation);
  const std::string dir = FreshFolder("dicom-oblique");
  xp::WriteCTSeries(volume, dir);
  const xp::CTVolume ct = xp::ReadCTVolume(dir);
  double p[3];
  const double index[3] = { 5, 7, 3 };
  ct.image->TransformContinuousIndexToPhysicalPoint(index, p);
  const Eigen::Vector3d expected =
    volume.origin + rotation * Eigen::Vector3d(5 * 0.8, 7 * 0.9, 3 * 2.5);
  EXPECT_NEAR((Eigen::Vector3d(p) - expected).norm(), 0.0, 1e-3);
  EXPECT_EQ(ct.image->GetScalarComponentAsDouble(5, 7, 3, 0), 50 + 700 + 3000 - 1000);
}

TEST(DICOMCTReader, SeveralSeriesAreListedAndOneCanBeChosen)
{
  const std::string dir = FreshFolder("dicom-two-series");
  xp::CTSeriesWriteOptions first, second;
  first.seriesInstanceUID = "1.2.3.1";
  first.seriesDescription = "planning";
  second.seriesInstanceUID = "1.2.3.2";
  second.filePrefix = "other";
  xp::WriteCTSeries(SmallVolume(), dir, first);
  xp::WriteCTSeries(SmallVolume(), dir, second);
  const std::string error = ErrorOf(dir);
  EXPECT_TRUE(Contains(error, "several series")) << error;
  EXPECT_TRUE(Contains(error, "1.2.3.1 (10 files, 'planning')")) << error;
  EXPECT_TRUE(Contains(error, "1.2.3.2")) << error;
  EXPECT_EQ(xp::ScanCTSeries(dir, "1.2.3.2").files.size(), 10u);
  EXPECT_TRUE(Contains(ErrorOf(dir, "9.9"), "series 9.9 not found"));
}

TEST(DICOMCTReader, MissingSliceIsRefusedNamingTheFile)
{
  const std::string dir = FreshFolder("dicom-missing");
  const std::vector<std::string> files = xp::WriteCTSeries(SmallVolume(), dir);
  std::remove(files[4].c_str());
  const std::string error = ErrorOf(dir);
  EXPECT_TRUE(Contains(error, "missing slice")) << error;
  EXPECT_TRUE(Contains(error, files[5])) << error;
}

TEST(DICOMCTReader, TruncatedSliceIsRefusedNamingTheFile)
{
  const std::string dir = FreshFolder("dicom-truncated");
  const std::vector<std::string> files = xp::WriteCTSeries(SmallVolume(), dir);
  std::ifstream in(files[3], std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(files[3], std::ios::binary | std::ios::trunc).write(bytes.data(), bytes.size() - 200);
  try
  {
    xp::ReadCTVolume(dir);
    FAIL() << "a truncated slice was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_TRUE(Contains(e.what(), files[3])) << e.what();
  }
  // A file that claims to be DICOM but whose header is garbage.
  std::ofstream(files[6], std::ios::binary | std::ios::trunc) << std::string(128, '\0') << "DICM" << std::string(40, '\xff');
  EXPECT_TRUE(Contains(ErrorOf(dir), files[6]));
}

TEST(DICOMCTReader, NotACTAndGantryTiltAreRefused)
{
  std::string dir = FreshFolder("dicom-mr");
  xp::CTSeriesWriteOptions mr;
  mr.modality = "MR";
  xp::WriteCTSeries(SmallVolume(), dir, mr);
  EXPECT_TRUE(Contains(ErrorOf(dir), "not a CT image (Modality (0008,0060) = 'MR')")) << ErrorOf(dir);

  dir = FreshFolder("dicom-tilt");
  xp::CTSeriesWriteOptions tilted;
  tilted.gantryTiltDegrees = 12.0;
  xp::WriteCTSeries(SmallVolume(), dir, tilted);
  EXPECT_TRUE(Contains(ErrorOf(dir), "Gantry/Detector Tilt")) << ErrorOf(dir);

  dir = FreshFolder("dicom-empty");
  EXPECT_TRUE(Contains(ErrorOf(dir), "no files found")) << ErrorOf(dir);
}

TEST(DICOMCTReader, PipelineReportsErrorsWithoutThrowing)
{
  vtkNew<vtkXPDICOMCTReader> reader;
  reader->SetDirectoryName("tmp-no-such-folder");
  reader->GlobalWarningDisplayOff();
  reader->Update();
  reader->GlobalWarningDisplayOn();
  EXPECT_FALSE(reader->GetErrorText().empty());
}
