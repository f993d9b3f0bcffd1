#include "xpReferenceGeometry.h"

#include "xpError.h"

#include <gtest/gtest.h>

using xp::testing::ReferenceStereoGeometry;

TEST(XRayView, IsocentreProjectsToPanelCentre)
{
  for (const xp::XRayView& view : ReferenceStereoGeometry().views)
  {
    const Eigen::Vector2d p = view.Project(Eigen::Vector3d::Zero());
    EXPECT_NEAR(p[0], 511.5, 1e-3) << view.name;
    EXPECT_NEAR(p[1], 383.5, 1e-3) << view.name;
  }
}

TEST(XRayView, TowardsGantryIsUpInTheImage)
{
  // column_direction is -Y: a point 10 mm towards the gantry moves up (smaller row), magnified 1.5x.
  const xp::XRayView a = ReferenceStereoGeometry().views[0];
  const Eigen::Vector2d p = a.Project({ 0, 10, 0 });
  EXPECT_NEAR(p[0], 511.5, 1e-3);
  EXPECT_NEAR(p[1], 383.5 - 15.0 / 0.390625, 1e-2);
}

TEST(XRayView, RowDirectionIncreasesColumn)
{
  const xp::XRayView a = ReferenceStereoGeometry().views[0];
  // 10 mm along A's row direction in the isocentric plane: +15 mm on the panel, +38.4 columns.
  const Eigen::Vector2d p = a.Project(10.0 * a.rowDirection);
  EXPECT_NEAR(p[0], 511.5 + 15.0 / 0.390625, 1e-2);
  EXPECT_NEAR(p[1], 383.5, 1e-3);
  // Row directions: A (-s, 0, s), B (-s, 0, -s). Lateral +X lowers the column in both views;
  // vertical +Z raises it in A and lowers it in B.
  const xp::XRayView b = ReferenceStereoGeometry().views[1];
  EXPECT_LT(a.Project({ 10, 0, 0 })[0], 511.5 - 10);
  EXPECT_LT(b.Project({ 10, 0, 0 })[0], 511.5 - 10);
  EXPECT_GT(a.Project({ 0, 0, 10 })[0], 511.5 + 10);
  EXPECT_LT(b.Project({ 0, 0, 10 })[0], 511.5 - 10);
}

TEST(XRayView, PixelRayPassesThroughProjectedPoint)
{
  const xp::XRayView a = ReferenceStereoGeometry().views[0];
  const Eigen::Vector3d point(12.0, -31.0, 7.5);
  const Eigen::Vector2d pixel = a.Project(point);
  const xp::Ray ray = a.PixelRay(pixel[0], pixel[1]);
  const Eigen::Vector3d toPoint = point - ray.origin;
  // The reference directions are given to 6 digits, hence the micrometre tolerance.
  EXPECT_NEAR((toPoint - toPoint.dot(ray.direction) * ray.direction).norm(), 0.0, 1e-5);
  EXPECT_NEAR(ray.direction.norm(), 1.0, 1e-12);
  // The pixel centre formula of Coordinates.md, corner pixel (0, 0).
  const Eigen::Vector3d corner = a.detectorCenter - 511.5 * 0.390625 * a.rowDirection - 383.5 * 0.390625 * a.columnDirection;
  EXPECT_NEAR((a.PixelCenter(0, 0) - corner).norm(), 0.0, 1e-9);
}

TEST(XRayView, ResampledKeepsPanelExtent)
{
  const xp::XRayView a = ReferenceStereoGeometry().views[0];
  const xp::XRayView small = a.Resampled(256, 192);
  EXPECT_DOUBLE_EQ(small.pixelSpacing[0], 0.390625 * 4);
  const Eigen::Vector3d p(5, 6, 7);
  const Eigen::Vector2d full = a.Project(p), coarse = small.Project(p);
  EXPECT_NEAR((full[0] + 0.5) / 4.0 - 0.5, coarse[0], 1e-9);
  EXPECT_NEAR((full[1] + 0.5) / 4.0 - 0.5, coarse[1], 1e-9);
}

TEST(XRayView, PointBehindSourceHasNoProjection)
{
  const xp::XRayView a = ReferenceStereoGeometry().views[0];
  EXPECT_THROW(a.Project(a.source + a.NormalTowardsSource()), xp::Error);
}
