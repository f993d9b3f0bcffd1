#include "xpDICOMSeriesWriter.h"
#include "xpHeadPhantom.h"
#include "xpImageGeometry.h"
#include "xpVolumeIO.h"

#include <gtest/gtest.h>
#include <vtkImageData.h>

TEST(HeadPhantom, HasTheTissuesItPromises)
{
  using Eigen::Vector3d;
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(0, 0, 0)), 32.0 + 0.0) << "brain at the centre";
  EXPECT_GT(xp::HeadPhantomHU(Vector3d(0, 0, 0.9 * 98)), 600.0) << "skull vault";
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(0, -72, 36)), -1000.0) << "frontal sinus";
  EXPECT_GT(xp::HeadPhantomHU(Vector3d(36, 12, -26)), 1500.0) << "petrous bone";
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(0, 110, 0)), 250.0) << "head rest";
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(88, -10, 0)), 1400.0) << "mask frame";
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(0, 0, 120)), -1000.0) << "air above the head";
  EXPECT_EQ(xp::HeadPhantomHU(Vector3d(0, 22, -90)), 750.0) << "cervical vertebra";
}

TEST(HeadPhantom, WritesADICOMSeriesTheReaderAccepts)
{
  const xp::CTVolumeData phantom = xp::MakeHeadPhantom(4.0);
  ASSERT_GT(phantom.dimensions.minCoeff(), 40);
  ASSERT_EQ(std::system("rm -rf tmp-phantom && mkdir tmp-phantom"), 0);
  xp::WriteCTSeries(phantom, "tmp-phantom");
  const xp::CTVolume ct = xp::ReadCTVolume("tmp-phantom");
  int dims[3];
  ct.image->GetDimensions(dims);
  EXPECT_EQ(Eigen::Vector3i(dims[0], dims[1], dims[2]), phantom.dimensions);
  const Eigen::Vector3d center = xp::ImageCenter(ct.image);
  EXPECT_NEAR(center[0], 0.0, 1e-3);
  EXPECT_NEAR(center[1], 10.0, 1e-3);
  EXPECT_NEAR(center[2], -23.0, 1e-3);
  const int middle = (dims[2] / 2 * dims[1] + dims[1] / 2) * dims[0] + dims[0] / 2;
  EXPECT_NEAR(ct.image->GetScalarComponentAsDouble(dims[0] / 2, dims[1] / 2, dims[2] / 2, 0),
    phantom.hounsfield[middle], 0.5);
}
