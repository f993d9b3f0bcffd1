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

namespace
{
/** A camera 1000 mm from the origin looking along `axis`, its K with fx != fy (by 0.25 %, as a
 *  real calibration's) and the principal point off the image centre. */
xp::CameraCalibration TestCamera(const Eigen::Vector3d& axis, const Eigen::Vector3d& up)
{
  xp::CameraCalibration camera;
  camera.size = Eigen::Vector2i(640, 480);
  camera.intrinsics << 5000.0, 0.0, 300.5, 0.0, 5012.5, 250.25, 0.0, 0.0, 1.0;
  const Eigen::Vector3d z = axis.normalized(), x = up.cross(z).normalized(), y = z.cross(x);
  camera.rotation.row(0) = x.transpose();
  camera.rotation.row(1) = y.transpose();
  camera.rotation.row(2) = z.transpose();
  const Eigen::Vector3d source = Eigen::Vector3d(10.0, -20.0, 30.0) - 1000.0 * z;
  camera.translation = -camera.rotation * source;
  return camera;
}

void WriteCalibration(const xp::CameraCalibration& c, const std::string& path)
{
  std::ofstream out(path);
  out.precision(17);
  out << "image size\n" << c.size[0] << "," << c.size[1] << "\n\ncamera matrix\n";
  for (int r = 0; r < 3; ++r)
    out << c.intrinsics(r, 0) << "," << c.intrinsics(r, 1) << "," << c.intrinsics(r, 2) << "\n";
  out << "\nrotation\n";
  for (int r = 0; r < 3; ++r)
    out << c.rotation(r, 0) << "," << c.rotation(r, 1) << "," << c.rotation(r, 2) << "\n";
  out << "\ntranslation\n" << c.translation[0] << "\n" << c.translation[1] << "\n" << c.translation[2] << "\n";
}
} // namespace

// The view made from an XMALab calibration projects every point where the pinhole model puts it
// (OpenCV: u = fx x/z + cx, v = fy y/z + cy, v down), although fx != fy: the rows' spacing takes
// the difference. A flipped axis, a transposed R or the wrong sign of t moves the points.
TEST(CameraCalibration, ViewProjectsAsThePinholeModel)
{
  const xp::CameraCalibration written = TestCamera(Eigen::Vector3d(1.0, 0.3, -0.2), Eigen::Vector3d(0.0, 0.0, 1.0));
  WriteCalibration(written, "cam-good.txt");
  const xp::CameraCalibration camera = xp::ReadCameraCalibration("cam-good.txt");
  EXPECT_EQ(camera.size, written.size);
  EXPECT_LT((camera.rotation - written.rotation).norm(), 1e-12);
  EXPECT_LT((camera.Source() - (Eigen::Vector3d(10.0, -20.0, 30.0) - 1000.0 * written.Axis())).norm(), 1e-9);
  const Eigen::Vector2d spacing = camera.PixelSpacing(0.2);
  EXPECT_NEAR(spacing[1] / spacing[0], 5000.0 / 5012.5, 1e-12);
  const xp::XRayView view = xp::ViewFromProjectionMatrix(
    camera.Projection(), spacing, camera.size, Eigen::Vector3d(10.0, -20.0, 30.0), "A", "cam-good.txt");
  EXPECT_NEAR(view.SourceToPanelDistance(), 5000.0 * 0.2, 1e-6);
  for (const Eigen::Vector3d& point : { Eigen::Vector3d(10.0, -20.0, 30.0), Eigen::Vector3d(40.0, 25.0, -10.0),
         Eigen::Vector3d(-30.0, 5.0, 60.0) })
  {
    const Eigen::Vector3d c = camera.rotation * point + camera.translation;
    const Eigen::Vector2d pinhole(5000.0 * c[0] / c[2] + 300.5, 5012.5 * c[1] / c[2] + 250.25);
    EXPECT_LT((view.Project(point) - pinhole).norm(), 1e-6) << point.transpose();
  }
}

TEST(CameraCalibration, IncompleteOrWrongFilesAreRefusedNamingTheSection)
{
  const xp::CameraCalibration good = TestCamera(Eigen::Vector3d(0.0, 1.0, 0.0), Eigen::Vector3d(0.0, 0.0, 1.0));
  WriteCalibration(good, "cam-ok.txt");
  std::ifstream in("cam-ok.txt");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto refused = [](const std::string& name, const std::string& content, const std::string& field)
  {
    std::ofstream(name) << content;
    try
    {
      xp::ReadCameraCalibration(name);
      ADD_FAILURE() << name << " was read";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  };
  refused("cam-no-translation.txt", text.substr(0, text.find("translation")), "translation");
  std::string scaled = text;
  scaled.replace(scaled.find("rotation\n") + 9, 1, "2"); // R's first entry doubled or more
  refused("cam-scaled.txt", scaled, "rotation");
  refused("cam-word.txt", "image size\n640,abc\n", "abc");
  refused("cam-unknown.txt", "lens\n1,2\n", "lens");
  EXPECT_THROW(xp::ReadCameraCalibration("cam-missing.txt"), xp::InputError);
}

// Two rays 4 mm apart at their closest: the midpoint of the common perpendicular, and the gap.
TEST(CameraCalibration, ClosestApproachOfCentralRays)
{
  double gap = 0.0;
  const Eigen::Vector3d point = xp::ClosestApproach(
    { { Eigen::Vector3d(-500.0, 0.0, 2.0), Eigen::Vector3d(1.0, 0.0, 0.0) },
      { Eigen::Vector3d(7.0, -300.0, -2.0), Eigen::Vector3d(0.0, 2.0, 0.0) } },
    &gap);
  EXPECT_LT((point - Eigen::Vector3d(7.0, 0.0, 0.0)).norm(), 1e-9) << point.transpose();
  EXPECT_NEAR(gap, 4.0, 1e-9);
  EXPECT_THROW(xp::ClosestApproach({ { Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX() },
                 { Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX() } }),
    xp::InputError);
}
