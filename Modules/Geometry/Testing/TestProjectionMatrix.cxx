// Projection matrices: a view survives the round trip view -> P -> view, P projects as the view
// does, and matrices that describe no flat panel are refused.
#include "xpReferenceGeometry.h"

#include "xpError.h"
#include "xpProjectionMatrix.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>

namespace
{

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

/** A reference view with its panel shifted off the central ray and tilted: a general case. */
xp::XRayView GeneralView()
{
  xp::XRayView view = xp::testing::ReferenceStereoGeometry().views[1];
  view.detectorCenter += 12.5 * view.rowDirection - 7.0 * view.columnDirection;
  const Eigen::Matrix3d tilt = Eigen::AngleAxisd(0.05, view.columnDirection).toRotationMatrix();
  view.rowDirection = tilt * view.rowDirection;
  view.pixelSpacing = { 0.4, 0.3 };
  return view;
}

} // namespace

TEST(ProjectionMatrix, ProjectsEveryPointAsTheViewDoes)
{
  const xp::XRayView view = GeneralView();
  const xp::ProjectionMatrix p = xp::ProjectionMatrixOf(view);
  for (const Eigen::Vector3d point : { Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(40, -25, 60), Eigen::Vector3d(-80, 30, -10) })
  {
    const Eigen::Vector3d h = p * point.homogeneous();
    ASSERT_GT(h[2], 0.0) << "in front of the source";
    EXPECT_LT((h.hnormalized() - view.Project(point)).norm(), 1e-9) << point.transpose();
  }
}

TEST(ProjectionMatrix, RoundTripsAViewWithinAMicrometre)
{
  // A micrometre, not exactly: the geometry file's directions are orthogonal to 1e-7, P's are exactly.
  for (xp::XRayView view : { xp::testing::ReferenceStereoGeometry().views[0], GeneralView() })
  {
    // Any scale, of either sign, describes the same imager.
    for (const double scale : { 1.0, -0.004 })
    {
      const xp::XRayView back = xp::ViewFromProjectionMatrix(
        scale * xp::ProjectionMatrixOf(view), view.pixelSpacing, view.size, Eigen::Vector3d::Zero(), view.name, "P");
      EXPECT_LT((back.source - view.source).norm(), 1e-3) << view.name;
      EXPECT_LT((back.detectorCenter - view.detectorCenter).norm(), 1e-3) << view.name;
      EXPECT_LT(DegreesApart(back.rowDirection, view.rowDirection), 1e-4);
      EXPECT_LT(DegreesApart(back.columnDirection, view.columnDirection), 1e-4);
      EXPECT_EQ(back.size, view.size);
    }
  }
}

TEST(ProjectionMatrix, RefusesMatricesOfNoFlatPanel)
{
  const xp::XRayView view = GeneralView();
  const xp::ProjectionMatrix good = xp::ProjectionMatrixOf(view);
  const auto refused = [&](const xp::ProjectionMatrix& p, const Eigen::Vector2d& spacing)
  {
    try
    {
      xp::ViewFromProjectionMatrix(p, spacing, view.size, Eigen::Vector3d::Zero(), "A", "P_A.txt");
    }
    catch (const xp::InputError& e)
    {
      return std::string(e.what()).find("P_A.txt") != std::string::npos;
    }
    return false;
  };
  EXPECT_FALSE(refused(good, view.pixelSpacing));
  EXPECT_TRUE(refused(good, { 0.4, 0.4 })) << "the spacing's ratio must be the focal lengths'";
  xp::ProjectionMatrix singular = good;
  singular.row(2) = singular.row(0);
  EXPECT_TRUE(refused(singular, view.pixelSpacing));
  xp::ProjectionMatrix skewed = good;
  skewed.row(0) += 0.01 * skewed.row(1); // rows and columns 0.6 degree off a right angle
  EXPECT_TRUE(refused(skewed, view.pixelSpacing));
  xp::ProjectionMatrix notFinite = good;
  notFinite(1, 3) = std::nan("");
  EXPECT_TRUE(refused(notFinite, view.pixelSpacing));
}

TEST(ProjectionMatrix, ReadsTwelveNumbersAndNamesTheFileOtherwise)
{
  {
    std::ofstream("pm-good.txt") << "# P of imager A\n1 0 0 10\n0 2 0 20  # second row\n0 0 1 1000\n";
    std::ofstream("pm-short.txt") << "1 0 0 10\n0 2 0 20\n0 0 1\n";
    std::ofstream("pm-word.txt") << "1 0 0 10\n0 2 0 20\n0 0 1 x\n";
  }
  {
    std::ofstream("pm-K.txt") << "1000 0 512\n0 1000 384\n0 0 1\n";
    std::ofstream("pm-Rt.txt") << "1 0 0 0\n0 1 0 0\n0 0 1 1000\n";
    std::ofstream("pm-Rt-scaled.txt") << "2 0 0 0\n0 2 0 0\n0 0 2 1000\n";
  }
  const xp::ProjectionMatrix pinhole = xp::ReadPinholeCalibration("pm-K.txt", "pm-Rt.txt");
  EXPECT_DOUBLE_EQ(pinhole(0, 2), 512.0);
  EXPECT_DOUBLE_EQ(pinhole(0, 3), 512.0 * 1000.0) << "K times t";
  try
  {
    xp::ReadPinholeCalibration("pm-K.txt", "pm-Rt-scaled.txt");
    ADD_FAILURE() << "a scaled R was taken for a rotation";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("pm-Rt-scaled.txt"), std::string::npos) << e.what();
  }
  const xp::ProjectionMatrix p = xp::ReadProjectionMatrix("pm-good.txt");
  EXPECT_DOUBLE_EQ(p(1, 1), 2.0);
  EXPECT_DOUBLE_EQ(p(2, 3), 1000.0);
  for (const char* bad : { "pm-short.txt", "pm-word.txt", "pm-missing.txt" })
  {
    try
    {
      xp::ReadProjectionMatrix(bad);
      ADD_FAILURE() << bad << " was read";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
}
