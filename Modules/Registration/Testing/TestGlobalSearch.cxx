// Finding a bone from nothing: a small asymmetric object turned and moved far from the planned
// set-up, found by the global search in both views, then registered from there.
#include "xpGlobalSearch.h"
#include "xpHeadPhantom.h"
#include "xpReferenceGeometry.h"
#include "xpStereoRegistration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace
{

/** A 1 mm "bone": a shaft of radius 5 mm and 60 mm along z with a knob of radius 9 mm at one end,
 *  off the shaft's axis, and a fin at the other, at right angles to the knob's offset (no
 *  symmetry a wrong orientation could share); air around it. */
xp::AttenuationVolume Bone(Eigen::Isometry3d& planned)
{
  const Eigen::Vector3i dims(40, 40, 80);
  std::vector<float> hu(static_cast<size_t>(dims.prod()), -1000.0f);
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const Eigen::Vector3d p(i - 19.5, j - 19.5, k - 39.5);
        const bool shaft = p.head<2>().norm() <= 5.0 && std::abs(p[2]) <= 30.0;
        const bool knob = (p - Eigen::Vector3d(6.0, 0.0, 28.0)).norm() <= 9.0;
        const bool fin = std::abs(p[0]) <= 2.0 && p[1] >= 0.0 && p[1] <= 12.0 && std::abs(p[2] + 20.0) <= 8.0;
        if (shaft || knob || fin)
          hu[static_cast<size_t>((k * dims[1] + j) * dims[0] + i)] = 1200.0f;
      }
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.translation() = -0.5 * (dims.cast<double>() - Eigen::Vector3d::Ones());
  planned = xp::PlannedCTToRoom(xp::PatientPosition::HFS, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  return xp::AttenuationVolume(hu.data(), dims, indexToCT, xp::WaterAttenuationPerMM);
}

double DegreesApart(const xp::Pose& a, const xp::Pose& b)
{
  return Eigen::AngleAxisd(a.Rotation() * b.Rotation().transpose()).angle() * 180.0 / M_PI;
}

} // namespace

TEST(GlobalSearch, OrientationGridCoversEveryRotation)
{
  const std::vector<Eigen::Matrix3d> grid = xp::OrientationGrid(30.0);
  EXPECT_GT(grid.size(), 400u);
  std::mt19937 random(3);
  std::normal_distribution<double> gaussian;
  for (int n = 0; n < 50; ++n)
  {
    const Eigen::Matrix3d rotation =
      Eigen::Quaterniond(gaussian(random), gaussian(random), gaussian(random), gaussian(random)).normalized().toRotationMatrix();
    double nearest = 180.0;
    for (const Eigen::Matrix3d& g : grid)
      nearest = std::min(nearest, Eigen::AngleAxisd(rotation * g.transpose()).angle() * 180.0 / M_PI);
    EXPECT_LT(nearest, 30.0) << n;
  }
}

TEST(GlobalSearch, FindsASmallBoneTurnedAndMovedFarFromThePlan)
{
  Eigen::Isometry3d planned;
  const xp::AttenuationVolume bone = Bone(planned);
  const xp::Pose truth = xp::Pose::Parse("25,-15,20,60,-40,110", "truth");
  std::vector<xp::RegistrationView> views;
  std::mt19937 random(5);
  std::normal_distribution<double> gaussian;
  for (const xp::XRayView& view : xp::testing::ReferenceViews(320, 240))
  {
    xp::RegistrationView item;
    item.view = view;
    std::vector<float> integrals(static_cast<size_t>(view.Columns()) * view.Rows());
    xp::RenderLineIntegrals(bone, xp::MisalignedCTToRoom(planned, truth, Eigen::Vector3d::Zero()), view.source,
      xp::DetectorGrid::TopRowFirst(view), nullptr, integrals.data());
    for (int row = 0; row < view.Rows(); ++row)
      for (int column = 0; column < view.Columns(); ++column)
      {
        // Soft tissue thickening towards the bottom under the bone, as a limb's: raw transmission.
        const double tissue = 1.0 + 1.5 * row / view.Rows();
        const double grey = 3600.0 * std::exp(-integrals[static_cast<size_t>(row) * view.Columns() + column] - tissue);
        item.xray.push_back(static_cast<uint16_t>(std::clamp(std::lround(grey + 4.0 * gaussian(random)), 0L, 4095L)));
      }
    views.push_back(std::move(item));
  }
  xp::GlobalSearchSettings search;
  search.angleStepDegrees = 30.0; // a coarser grid than the default's, for the test's time
  const std::vector<xp::GlobalCandidate> candidates =
    xp::FindGlobalStarts(bone, planned, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), views, search);
  ASSERT_FALSE(candidates.empty());
  // The first candidate: the bone's place to a millimetre, its orientation to a few degrees (a
  // 60 mm bone turned 1.5 degrees moves its ends less than a pixel here).
  const xp::Pose& start = candidates.front().pose;
  EXPECT_LT((start.translation - truth.translation).norm(), 1.5) << start.ToString();
  EXPECT_LT(DegreesApart(start, truth), 5.0) << start.ToString();
  // Registered from there, the bone alone (its shadow only): `ok` only where it is right.
  xp::StereoRegistrationSettings settings;
  settings.initialPose = start;
  const xp::StereoRegistrationResult result = xp::RegisterStereo(bone, planned, Eigen::Vector3d::Zero(), views, settings);
  EXPECT_TRUE(result.boneOnly);
  EXPECT_LT((result.misalignment.translation - truth.translation).norm(), 1.0) << result.misalignment.ToString();
  // A bone's held-out check is on correlation and judges all twelve neighbours, the turned too
  // (here they lead least, so a margin of the translated alone would differ).
  const auto& leads = result.peakLeads;
  ASSERT_LT(*std::min_element(leads.begin() + 6, leads.end()), *std::min_element(leads.begin(), leads.begin() + 6));
  EXPECT_DOUBLE_EQ(result.peakMargin, *std::min_element(leads.begin(), leads.end()));
  if (result.ok)
  {
    EXPECT_LT(DegreesApart(result.misalignment, truth), 1.0) << result.misalignment.ToString();
  }
}

// A bone cut out of a CT has bone for its surface; a head has skin.
TEST(GlobalSearch, ABoneIsToldFromABody)
{
  Eigen::Isometry3d planned;
  EXPECT_TRUE(xp::OuterSurfaceIsBone(Bone(planned)));
  const xp::CTVolumeData head = xp::MakeHeadPhantom(4.0);
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() = head.direction * head.spacing.asDiagonal();
  indexToCT.translation() = head.origin;
  EXPECT_FALSE(xp::OuterSurfaceIsBone(
    xp::AttenuationVolume(head.hounsfield.data(), head.dimensions, indexToCT, xp::WaterAttenuationPerMM)));
}
