// RT Image terms of an imager: the reference views at the gantry angles IEC 61217 gives them, and
// any panel normal to its beam axis (pitched, rotated, off-centre) survives the round trip.
#include "xpReferenceGeometry.h"

#include "xpError.h"
#include "xpRTImageGeometry.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>

namespace
{

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

void ExpectSameView(const xp::XRayView& a, const xp::XRayView& b)
{
  EXPECT_LT((a.source - b.source).norm(), 0.1);
  EXPECT_LT((a.detectorCenter - b.detectorCenter).norm(), 0.1);
  EXPECT_LT(DegreesApart(a.rowDirection, b.rowDirection), 0.01);
  EXPECT_LT(DegreesApart(a.columnDirection, b.columnDirection), 0.01);
  EXPECT_NEAR(a.pixelSpacing[0], b.pixelSpacing[0], 1e-9);
  EXPECT_NEAR(a.pixelSpacing[1], b.pixelSpacing[1], 1e-9);
  EXPECT_EQ(a.size, b.size);
}

} // namespace

TEST(RTImageGeometry, ReferenceViewsAreGantry225And135)
{
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  // Tube A below the patient on the -X side: gantry 225 (gantry 90 puts the source at +X).
  const xp::RTImageGeometry a = xp::RTImageGeometryOf(reference.views[0], reference.isocenter);
  EXPECT_NEAR(a.gantryAngle, 225.0, 1e-3);
  EXPECT_NEAR(a.gantryPitch, 0.0, 1e-6);
  EXPECT_NEAR(a.receptorAngle, 0.0, 1e-3);
  EXPECT_NEAR(a.sad, 1000.0, 1e-2);
  EXPECT_NEAR(a.sid, 1500.0, 1e-2);
  EXPECT_LT(a.receptorTranslation.head<2>().norm(), 1e-3);
  EXPECT_NEAR(a.receptorTranslation.z(), -500.0, 1e-2);
  EXPECT_NEAR(a.imagePosition.x(), -0.5 * 1023 * 0.390625, 1e-9);
  EXPECT_NEAR(a.imagePosition.y(), 0.5 * 767 * 0.390625, 1e-9);
  EXPECT_NEAR(xp::RTImageGeometryOf(reference.views[1], reference.isocenter).gantryAngle, 135.0, 1e-3);
  for (const xp::XRayView& view : reference.views)
    ExpectSameView(xp::ViewOfRTImage(xp::RTImageGeometryOf(view, reference.isocenter), reference.isocenter, view.name), view);
}

TEST(RTImageGeometry, PitchedRotatedOffCentrePanelsSurviveTheRoundTrip)
{
  const Eigen::Vector3d iso(5.0, -10.0, 20.0);
  xp::RTImageGeometry g;
  g.gantryAngle = 300.0;
  g.gantryPitch = -25.0;
  g.receptorAngle = 30.0;
  g.sad = 1200.0;
  g.sid = 1700.0;
  g.receptorTranslation = Eigen::Vector3d(15.0, -8.0, -500.0);
  g.imagePosition = Eigen::Vector2d(-150.0, 110.0);
  g.pixelSpacing = Eigen::Vector2d(0.3, 0.4);
  g.rows = 600;
  g.columns = 800;
  const xp::XRayView view = xp::ViewOfRTImage(g, iso, "P");
  // The source is SAD from the isocentre; the panel is SID from the source, normal to the axis.
  EXPECT_NEAR((view.source - iso).norm(), 1200.0, 1e-9);
  EXPECT_NEAR(view.SourceToPanelDistance(), 1700.0, 1e-9);
  EXPECT_NEAR(std::abs(view.NormalTowardsSource().dot((view.source - iso).normalized())), 1.0, 1e-12);
  const xp::RTImageGeometry back = xp::RTImageGeometryOf(view, iso);
  EXPECT_NEAR(back.gantryAngle, 300.0, 1e-9);
  EXPECT_NEAR(back.gantryPitch, -25.0, 1e-9);
  EXPECT_NEAR(back.receptorAngle, 30.0, 1e-9);
  ExpectSameView(xp::ViewOfRTImage(back, iso, "P"), view);
}

TEST(RTImageGeometry, TiltedOrMirroredPanelsAreRefused)
{
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  xp::XRayView tilted = reference.views[0];
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.02, tilted.columnDirection).toRotationMatrix();
  tilted.rowDirection = tilt * tilted.rowDirection;
  EXPECT_THROW(xp::RTImageGeometryOf(tilted, reference.isocenter), xp::InputError);
  xp::XRayView mirrored = reference.views[0];
  mirrored.columnDirection = -mirrored.columnDirection;
  EXPECT_THROW(xp::RTImageGeometryOf(mirrored, reference.isocenter), xp::InputError);
}
