#include "xpBoneCut.h"
#include "xpPose.h"
#include "xpXRayView.h"

#include <gtest/gtest.h>

namespace
{

/** A 1 mm shaft of radius 5 mm along z: rounded (a hemisphere) at its low end, cut flat by the
 *  volume's last slices at its high end. */
xp::AttenuationVolume CutShaft()
{
  const Eigen::Vector3i dims(30, 30, 60);
  std::vector<float> hu(static_cast<size_t>(dims.prod()), -1000.0f);
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const Eigen::Vector3d p(i - 14.5, j - 14.5, k);
        const bool shaft = p.head<2>().norm() <= 5.0 && k >= 10;
        const bool end = (p - Eigen::Vector3d(0, 0, 10)).norm() <= 5.0;
        if (shaft || end)
          hu[static_cast<size_t>((k * dims[1] + j) * dims[0] + i)] = 1200.0f;
      }
  return xp::AttenuationVolume(hu.data(), dims, Eigen::Affine3d::Identity(), xp::WaterAttenuationPerMM);
}

} // namespace

TEST(BoneCut, FindsTheFlatCutAndNotTheRoundedEnd)
{
  const std::vector<Eigen::Vector3d> points = xp::CutFacePoints(CutShaft());
  ASSERT_FALSE(points.empty());
  double lowest = 1e9;
  for (const Eigen::Vector3d& p : points)
    lowest = std::min(lowest, p.z());
  EXPECT_GE(lowest, 50.0) << "only the cut end's layer, none of the rounded end";
  EXPECT_GT(points.size(), 50u); // the shaft's cross-section, about 80 voxels
  EXPECT_LT(points.size(), 120u);
}

TEST(BoneCut, LeavesOutTheCutsShadowWithinTheRadius)
{
  xp::XRayView view;
  view.name = "A";
  view.source = Eigen::Vector3d(0, 0, -1000);
  view.detectorCenter = Eigen::Vector3d(0, 0, 500);
  view.rowDirection = Eigen::Vector3d::UnitX();
  view.columnDirection = Eigen::Vector3d::UnitY();
  view.pixelSpacing = { 1.0, 1.0 };
  view.size = { 101, 101 };
  std::vector<uint8_t> mask;
  // One point at the isocentre: it projects to the middle pixel; 4 mm on the panel around it go.
  xp::LeaveOutAroundPoints(mask, view, { Eigen::Vector3d::Zero() }, Eigen::Isometry3d::Identity(), 4.0);
  ASSERT_EQ(mask.size(), 101u * 101u);
  EXPECT_EQ(mask[50 * 101 + 50], 0);
  EXPECT_EQ(mask[50 * 101 + 54], 0);
  EXPECT_EQ(mask[50 * 101 + 55], 1);
  EXPECT_EQ(mask[53 * 101 + 53], 1) << "a disc, not a square";
  EXPECT_EQ(std::count(mask.begin(), mask.end(), 0), 49) << "the pixels within 4 of the centre";
}
