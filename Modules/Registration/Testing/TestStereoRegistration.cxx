// The 6-DOF objective and optimiser recover known misalignments of the head phantom from
// simulated stereo X-rays, with the signs of Coordinates.md.
#include "xpBodyMask.h"
#include "xpCTCoverage.h"
#include "xpEntropyMask.h"
#include "xpError.h"
#include "xpHeadPhantom.h"
#include "xpLinearizedRefinement.h"
#include "xpPoseOptimizer.h"
#include "xpReferenceGeometry.h"
#include "xpStereoRegistration.h"
#include "xpStereoSimilarity.h"

#include <gtest/gtest.h>
#include <algorithm>
#include <map>
#include <memory>
#include <random>
#include <set>

namespace
{

bool FailedWith(const xp::StereoRegistrationResult& result, xp::GateCode code)
{
  return std::any_of(result.failures.begin(), result.failures.end(), [&](const xp::GateFailure& f) { return f.code == code; });
}

std::string Described(const xp::StereoRegistrationResult& result)
{
  std::string text = result.misalignment.ToString();
  for (const xp::GateFailure& failure : result.failures)
    text += std::string("; ") + xp::GateCodeName(failure.code) + ": " + failure.message;
  return text;
}

std::vector<xp::XRayView> StereoViews(int columns, int rows)
{
  return xp::testing::ReferenceViews(columns, rows);
}

struct Scene
{
  xp::CTVolumeData ct;
  xp::AttenuationVolume volume;
  Eigen::Isometry3d planned;
  explicit Scene(xp::CTVolumeData data = xp::MakeHeadPhantom(2.0))
    : ct(std::move(data))
  {
    Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
    indexToCT.linear() = ct.direction * ct.spacing.asDiagonal();
    indexToCT.translation() = ct.origin;
    volume = xp::AttenuationVolume(ct.hounsfield.data(), ct.dimensions, indexToCT, xp::WaterAttenuationPerMM);
    const Eigen::Vector3d centre = indexToCT * (0.5 * (ct.dimensions.cast<double>() - Eigen::Vector3d::Ones()));
    planned = xp::PlannedCTToRoom(xp::PatientPosition::HFS, centre, Eigen::Vector3d::Zero());
  }
};

/** X-rays of the scene at `truth`, with quantum noise. */
std::vector<xp::RegistrationView> Simulate(const Scene& scene, const xp::Pose& truth, unsigned seed)
{
  std::mt19937 random(seed);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::vector<xp::RegistrationView> views;
  for (const xp::XRayView& view : StereoViews(160, 120))
  {
    xp::RegistrationView item;
    item.view = view;
    std::vector<float> integral(160 * 120);
    xp::RenderLineIntegrals(scene.volume, xp::MisalignedCTToRoom(scene.planned, truth, Eigen::Vector3d::Zero()),
      view.source, xp::DetectorGrid::TopRowFirst(view), nullptr, integral.data());
    item.xray.resize(integral.size());
    for (size_t i = 0; i < integral.size(); ++i)
    {
      const double grey = 4095.0 * std::exp(-integral[i]);
      item.xray[i] = static_cast<uint16_t>(std::clamp(std::lround(grey + 8.0 * std::sqrt(grey / 4095.0) * gaussian(random)), 0L, 4095L));
    }
    views.push_back(std::move(item));
  }
  return views;
}

} // namespace

TEST(StereoSimilarity, PeaksAtTheTruePose)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("3,-2,1.5,1,-1,2", "truth");
  xp::StereoSimilarity similarity(scene.volume, scene.planned, Eigen::Vector3d::Zero(), Simulate(scene, truth, 1), 32);
  const double atTruth = similarity.Evaluate(truth);
  for (const char* off : { "4,-2,1.5,1,-1,2", "3,-2,2.5,1,-1,2", "3,-2,1.5,1,0,2", "0,0,0,0,0,0" })
  {
    EXPECT_GT(atTruth, similarity.Evaluate(xp::Pose::Parse(off, "off"))) << off;
  }
  EXPECT_EQ(similarity.RenderedDRRs(), 10);
}

TEST(StereoSimilarity, CorrelationOfStructurePeaksAtTheTruePose)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("3,-2,1.5,1,-1,2", "truth");
  std::vector<xp::RegistrationView> views = Simulate(scene, truth, 1);
  xp::SimilarityLevels levels;
  levels.correlationHighPassMM = 10.0;
  xp::StereoSimilarity similarity(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32, levels);
  const double atTruth = similarity.Evaluate(truth);
  for (double correlation : similarity.LastCorrelation())
    EXPECT_GT(correlation, 0.6); // ranks against line integrals: monotone, not linear
  EXPECT_NEAR(atTruth, similarity.LastCorrelation()[0] + similarity.LastCorrelation()[1], 1e-12);
  EXPECT_GT(similarity.LastMutualInformation()[0], 0.0); // MI is still measured for the gate
  for (const char* off : { "4,-2,1.5,1,-1,2", "3,-2,2.5,1,-1,2", "3,-2,1.5,1,0,2", "3,-2,1.5,1,-1,3", "0,0,0,0,0,0" })
    EXPECT_GT(atTruth, similarity.Evaluate(xp::Pose::Parse(off, "off"))) << off;
  // Bone bright (a log image, not turned over as the registration turns it): the sign says so.
  for (xp::RegistrationView& item : views)
    for (uint16_t& grey : item.xray)
      grey = static_cast<uint16_t>(4095 - grey);
  xp::StereoSimilarity inverted(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32, levels);
  EXPECT_LT(inverted.Evaluate(truth), -1.2);
}

TEST(StereoSimilarity, RenderStrideCastsEveryNthRayAndInterpolatesBetween)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("3,-2,1.5,1,-1,2", "truth");
  std::vector<xp::RegistrationView> views = Simulate(scene, truth, 1);
  for (xp::RegistrationView& item : views) // a mask whose edges fall between nodes
  {
    item.mask.assign(item.xray.size(), 0);
    for (int r = 15; r < 101; ++r)
      for (int c = 23; c < 137; ++c)
        item.mask[static_cast<size_t>(r) * 160 + c] = 1;
  }
  const xp::SimilarityLevels plain{ false, 0.0 };
  xp::StereoSimilarity everyRay(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32, plain);
  xp::SimilarityCost allRays, someRays;
  everyRay.SetCostSink(&allRays);
  everyRay.Evaluate(truth);
  // Both axes alike, and each alone (a CT's slices may allow nodes farther apart than its pixels).
  for (const xp::RenderStride stride : { xp::RenderStride{ 2, 2 }, xp::RenderStride{ 3, 3 }, xp::RenderStride{ 1, 2 }, xp::RenderStride{ 3, 1 } })
  {
    const int sc = stride.columns, sr = stride.rows;
    const std::string name = std::to_string(sc) + "x" + std::to_string(sr);
    xp::StereoSimilarity sparse(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32, plain);
    sparse.SetRenderStride(stride);
    someRays = {};
    sparse.SetCostSink(&someRays);
    sparse.Evaluate(truth);
    // The nodes that valid pixels read, about one pixel in sc sr, and no others.
    EXPECT_LT(someRays.rays, allRays.rays / (sc * sr) + 2 * (86 + 114)) << name;
    EXPECT_GT(someRays.rays, allRays.rays / (sc * sr)) << name;
    for (size_t v = 0; v < views.size(); ++v)
    {
      const std::vector<uint16_t>& exact = everyRay.LastDRR(v);
      const std::vector<uint16_t>& interpolated = sparse.LastDRR(v);
      int checked = 0;
      for (int r = 0; r < 120; ++r)
        for (int c = 0; c < 160; ++c)
        {
          const size_t i = static_cast<size_t>(r) * 160 + c;
          const bool nodeColumn = c % sc == 0, nodeRow = r % sr == 0;
          if (!views[v].mask[i])
            EXPECT_EQ(interpolated[i], 0);
          else if (nodeColumn && nodeRow)
            EXPECT_EQ(interpolated[i], exact[i]) << name << " node " << c << ", " << r; // the same ray
          else if (nodeColumn != nodeRow)
          {
            // Between two nodes of a row or a column: the line integrals interpolated, so the
            // transmission is the nodes' weighted geometric mean.
            const bool alongRow = nodeRow;
            const int offset = alongRow ? c % sc : r % sr, span = alongRow ? sc : sr;
            const size_t step = alongRow ? 1 : 160;
            if ((alongRow ? c : r) + span - offset >= (alongRow ? 160 : 120))
              continue; // beyond the last node
            const double w = double(offset) / span;
            const double before = exact[i - offset * step], after = exact[i + (span - offset) * step];
            if (before < 200 || after < 200)
              continue; // the 12-bit rounding of dark nodes decides there
            EXPECT_NEAR(interpolated[i], std::pow(before, 1.0 - w) * std::pow(after, w), 2.0)
              << name << " pixel " << c << ", " << r;
            ++checked;
          }
        }
      EXPECT_GT(checked, 500) << name;
    }
    for (const char* off : { "4,-2,1.5,1,-1,2", "3,-2,2.5,1,-1,2", "0,0,0,0,0,0" })
      EXPECT_GT(sparse.Evaluate(truth), sparse.Evaluate(xp::Pose::Parse(off, "off"))) << name << " " << off;
  }
  xp::StereoSimilarity wrong(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32, plain);
  EXPECT_THROW(wrong.SetRenderStride(0), xp::InputError);
  EXPECT_THROW(wrong.SetRenderStride(xp::RenderStride{ 2, 9 }), xp::InputError);
}

// The projector on its own: each view's line integrals at a pose are the ray caster's for that
// view (not the other's), 0 wherever the mask leaves a pixel out, every valid pixel's ray cast
// once; a mask that does not cover its panel is refused.
TEST(DRRProjector, CastsEachViewsValidRaysAtThePose)
{
  Scene scene;
  std::vector<xp::RegistrationView> views = Simulate(scene, xp::Pose{}, 1);
  for (xp::RegistrationView& item : views)
  {
    item.mask.assign(item.xray.size(), 1);
    for (size_t i = 0; i < item.mask.size(); i += 3)
      item.mask[i] = 0;
  }
  const xp::DRRProjector projector(scene.volume, views);
  const Eigen::Isometry3d ctToRoom = xp::MisalignedCTToRoom(scene.planned, xp::Pose::Parse("3,-2,1.5,1,-1,2", "pose"),
    Eigen::Vector3d::Zero());
  const long long rays = projector.Render(ctToRoom);
  long long valid = 0;
  for (size_t v = 0; v < views.size(); ++v)
  {
    std::vector<float> expected(views[v].xray.size(), 0.0f);
    xp::RenderLineIntegrals(scene.volume, ctToRoom, views[v].view.source, xp::DetectorGrid::TopRowFirst(views[v].view),
      views[v].mask.data(), expected.data());
    const std::vector<float>& integrals = projector.Integrals(v);
    ASSERT_EQ(integrals.size(), expected.size());
    double largest = 0.0, differs = 0.0;
    for (size_t i = 0; i < expected.size(); ++i)
    {
      valid += views[v].mask[i];
      if (!views[v].mask[i])
        EXPECT_EQ(integrals[i], 0.0f) << "view " << v << " pixel " << i;
      largest = std::max(largest, double(expected[i]));
      differs = std::max(differs, std::abs(double(integrals[i]) - expected[i]));
    }
    EXPECT_GT(largest, 1.0) << "the phantom is in view " << v;
    EXPECT_LT(differs, 1e-6) << "view " << v;
  }
  EXPECT_EQ(rays, valid);
  views[1].mask.pop_back();
  EXPECT_THROW(xp::DRRProjector(scene.volume, views), xp::InputError);
}

// Two pixels at the isocentre (the panel's pixel over the magnification, 1.5 here) against the CT's
// sample spacing along each panel axis: the phantom's 2 mm voxels allow stride 2 at 256x192
// (1.04 mm at the isocentre) and not at 240x180 (1.11 mm).
TEST(StereoSimilarity, RenderStrideForKeepsNodesWithinTheCTsVoxel)
{
  Scene scene; // 2 mm voxels
  const auto viewsAt = [](int columns, int rows)
  {
    std::vector<xp::RegistrationView> views;
    for (const xp::XRayView& view : StereoViews(columns, rows))
      views.push_back({ view, std::vector<uint16_t>(static_cast<size_t>(columns) * rows), {} });
    return views;
  };
  const auto strideFor = [&](const xp::AttenuationVolume& volume, int columns, int rows, const Eigen::Vector3d& isocenter)
  {
    const xp::RenderStride stride = xp::RenderStrideFor(volume, viewsAt(columns, rows), scene.planned, isocenter);
    return std::to_string(stride.columns) + "x" + std::to_string(stride.rows);
  };
  EXPECT_EQ(strideFor(scene.volume, 256, 192, Eigen::Vector3d::Zero()), "2x2");
  EXPECT_EQ(strideFor(scene.volume, 240, 180, Eigen::Vector3d::Zero()), "1x1");
  EXPECT_EQ(strideFor(scene.volume, 1024, 768, Eigen::Vector3d::Zero()), "2x2");
  // An isocentre nearer the source magnifies more: the same pixels are finer there.
  EXPECT_EQ(strideFor(scene.volume, 240, 180, Eigen::Vector3d(0.0, 0.0, -100.0)), "2x2");
  // Pixels of 0.8 mm and slices of 3 mm. The panels' columns run along the patient (room y, the
  // CT's slice axis): nodes 1.04 mm apart down a column stay within a slice, along a row they
  // would skip the CT's pixels.
  const std::vector<float> water(16 * 16 * 16, 0.0f);
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() = Eigen::Vector3d(0.8, 0.8, 3.0).asDiagonal();
  const xp::AttenuationVolume thinPixels(water.data(), Eigen::Vector3i(16, 16, 16), indexToCT, xp::WaterAttenuationPerMM);
  EXPECT_EQ(strideFor(thinPixels, 256, 192, Eigen::Vector3d::Zero()), "1x2");
  EXPECT_EQ(strideFor(thinPixels, 1024, 768, Eigen::Vector3d::Zero()), "2x2");
  // Thick along the CT's x instead: down a column the 0.8 mm slices decide, along a row (the
  // oblique beam's mix of the CT's x and y) the finer y.
  indexToCT.linear() = Eigen::Vector3d(3.0, 0.8, 0.8).asDiagonal();
  const xp::AttenuationVolume thickColumns(water.data(), Eigen::Vector3i(16, 16, 16), indexToCT, xp::WaterAttenuationPerMM);
  EXPECT_EQ(strideFor(thickColumns, 256, 192, Eigen::Vector3d::Zero()), "1x1");
}

TEST(StereoRegistration, HalvingFactorsHalveOnlyTheAxesThatStayFine)
{
  const std::vector<float> water(8 * 8 * 8, 0.0f);
  const auto factorsFor = [&](const Eigen::Vector3d& spacing)
  {
    Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
    indexToCT.linear() = spacing.asDiagonal();
    const xp::AttenuationVolume volume(water.data(), Eigen::Vector3i(8, 8, 8), indexToCT, xp::WaterAttenuationPerMM);
    const Eigen::Vector3i f = xp::HalvingFactors(volume, 2.5);
    return std::to_string(f[0]) + std::to_string(f[1]) + std::to_string(f[2]);
  };
  EXPECT_EQ(factorsFor(Eigen::Vector3d(1.0, 1.0, 1.0)), "222");
  EXPECT_EQ(factorsFor(Eigen::Vector3d(1.25, 1.25, 1.25)), "222"); // 2.5 mm halved: at the limit
  EXPECT_EQ(factorsFor(Eigen::Vector3d(1.5, 1.5, 1.5)), "111");
  EXPECT_EQ(factorsFor(Eigen::Vector3d(0.9, 0.9, 3.0)), "221"); // thick slices keep their slices
  EXPECT_EQ(factorsFor(Eigen::Vector3d(3.0, 0.9, 0.9)), "122");
}

TEST(StereoRegistration, TheRefinementSkipsPlanesOnlyWhereTheHalvedCTWouldStayFine)
{
  const std::vector<float> water(8 * 8 * 8, 0.0f);
  const auto stepsFor = [&](const Eigen::Vector3d& spacing, const xp::StereoRegistrationSettings& settings)
  {
    Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
    indexToCT.linear() = spacing.asDiagonal();
    const xp::AttenuationVolume volume(water.data(), Eigen::Vector3i(8, 8, 8), indexToCT, xp::WaterAttenuationPerMM);
    const std::array<int, 3> s = xp::FinePlaneSteps(volume, settings);
    return std::to_string(s[0]) + std::to_string(s[1]) + std::to_string(s[2]);
  };
  xp::StereoRegistrationSettings automatic;
  automatic.finePlaneStep = 0;
  EXPECT_EQ(stepsFor(Eigen::Vector3d(1.0, 1.0, 1.0), automatic), "222");
  EXPECT_EQ(stepsFor(Eigen::Vector3d(0.9, 0.9, 3.0), automatic), "221"); // thick slices: every one
  EXPECT_EQ(stepsFor(Eigen::Vector3d(1.5, 1.5, 1.5), automatic), "111");
  EXPECT_EQ(stepsFor(Eigen::Vector3d(2.0, 2.0, 2.0), automatic), "111");
  EXPECT_EQ(stepsFor(Eigen::Vector3d(1.0, 1.0, 1.0), xp::StereoRegistrationSettings{}), "111") << "every plane by default";
  xp::StereoRegistrationSettings second = automatic;
  second.finePlaneStep = 2;
  EXPECT_EQ(stepsFor(Eigen::Vector3d(2.0, 2.0, 2.0), second), "222");
  xp::StereoRegistrationSettings gpu = automatic;
  gpu.device = xp::ComputeDevice::CUDA;
  EXPECT_EQ(stepsFor(Eigen::Vector3d(1.0, 1.0, 1.0), gpu), "111") << "the GPU samples every plane";
}

TEST(StereoSimilarity, CTSpacingAlongADirectionIsTheVoxelsExtentAlongIt)
{
  const std::vector<float> water(8 * 8 * 8, 0.0f);
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() = Eigen::Vector3d(0.8, 1.0, 3.0).asDiagonal();
  const xp::AttenuationVolume volume(water.data(), Eigen::Vector3i(8, 8, 8), indexToCT, xp::WaterAttenuationPerMM);
  const Eigen::Isometry3d identity = Eigen::Isometry3d::Identity();
  EXPECT_NEAR(xp::CTSpacingAlong(volume, identity, Eigen::Vector3d::UnitX()), 0.8, 1e-12);
  EXPECT_NEAR(xp::CTSpacingAlong(volume, identity, Eigen::Vector3d::UnitY()), 1.0, 1e-12);
  EXPECT_NEAR(xp::CTSpacingAlong(volume, identity, -Eigen::Vector3d::UnitZ()), 3.0, 1e-12);
  // Between x and z: 1 / |(cos/0.8, sin/3)| at 45 degrees.
  EXPECT_NEAR(xp::CTSpacingAlong(volume, identity, Eigen::Vector3d(1.0, 0.0, 1.0)), 1.0 / std::hypot(M_SQRT1_2 / 0.8, M_SQRT1_2 / 3.0), 1e-12);
  // The CT turned a quarter about room x: its slice axis now lies along room y.
  const Eigen::Isometry3d turned(Eigen::AngleAxisd(M_PI / 2.0, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(xp::CTSpacingAlong(volume, turned, Eigen::Vector3d::UnitY()), 3.0, 1e-12);
  EXPECT_NEAR(xp::CTSpacingAlong(volume, turned, Eigen::Vector3d::UnitZ()), 1.0, 1e-12);
}

TEST(PoseOptimizer, RecoversAKnownMisalignmentWithTheRightSigns)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  xp::StereoSimilarity similarity(scene.volume, scene.planned, Eigen::Vector3d::Zero(), Simulate(scene, truth, 2), 32);
  // Tolerances of 0.02 mm and 0.01 degrees are far below this small phantom's 2 mm voxels: give
  // the simplex room to reach them.
  xp::PoseOptimizerSettings settings;
  settings.maxEvaluations = 600;
  const xp::PoseOptimizerResult result =
    xp::MaximizePose([&](const xp::Pose& p) { return similarity.Evaluate(p); }, xp::Pose{}, settings);
  EXPECT_TRUE(result.converged) << result.stopReason;
  EXPECT_NEAR(result.pose.translation[0], 4.0, 0.5);
  EXPECT_NEAR(result.pose.translation[1], -3.0, 0.5);
  EXPECT_NEAR(result.pose.translation[2], 2.0, 0.5);
  EXPECT_NEAR(result.pose.pitch, 1.5, 0.3);
  EXPECT_NEAR(result.pose.roll, -1.0, 0.3);
  EXPECT_NEAR(result.pose.yaw, 2.0, 0.3);
  std::printf("recovered %s in %d evaluations (%s)\n", result.pose.ToString().c_str(), result.evaluations,
    result.stopReason.c_str());
}

#include "xpPreAlignment.h"

TEST(PoseOptimizer, StopsAtTheTargetWithThePoseThatReachedIt)
{
  // A smooth peak at (3, -2, 1) mm, (1, 0.5, -1) degrees; the target is its 1 mm neighbourhood.
  const xp::Pose peak = xp::Pose::FromParameters(std::array<double, 6>{ 3.0, -2.0, 1.0, 1.0, 0.5, -1.0 }.data());
  const auto distance = [&](const xp::Pose& p)
  {
    return (p.translation - peak.translation).norm() + std::abs(p.pitch - peak.pitch) + std::abs(p.roll - peak.roll) +
      std::abs(p.yaw - peak.yaw);
  };
  const auto objective = [&](const xp::Pose& p) { return -distance(p) * distance(p); };
  xp::PoseOptimizerSettings settings;
  settings.maxEvaluations = 2000;
  const xp::PoseOptimizerResult full = xp::MaximizePose(objective, xp::Pose{}, settings);
  ASSERT_TRUE(full.converged);
  EXPECT_FALSE(full.reachedTarget);
  EXPECT_LT(distance(full.pose), 0.1);

  settings.stopWhen = [&](const xp::Pose& p, double value)
  {
    EXPECT_DOUBLE_EQ(value, objective(p));
    return distance(p) < 1.0;
  };
  const xp::PoseOptimizerResult early = xp::MaximizePose(objective, xp::Pose{}, settings);
  EXPECT_TRUE(early.reachedTarget);
  EXPECT_TRUE(early.converged);
  EXPECT_LT(distance(early.pose), 1.0);
  EXPECT_GT(distance(early.pose), 0.1); // stopped on arrival, not at the peak
  EXPECT_DOUBLE_EQ(early.value, objective(early.pose));
  EXPECT_LT(early.evaluations, full.evaluations);
}

// A target that first holds at the k-th evaluation ends every method's search there, whatever
// the method was doing: the pose and value of that evaluation, k evaluations, target reached.
// NLopt's C++ interface hands the algorithm HUGE_VAL where the objective stops it, and BOBYQA
// (NLopt 2.7.1) may then end with XTOL_REACHED and an infinite optimum instead of FORCED_STOP
// (the second search's stop at the first one's end went unseen at its 14th evaluation).
TEST(PoseOptimizer, ATargetReachedAtAnyEvaluationEndsEveryMethodThere)
{
  const auto objective = [](const std::vector<double>& x)
  {
    double sum = 0.0;
    for (size_t i = 0; i < x.size(); ++i)
      sum += (1.0 + static_cast<double>(i)) * std::pow(x[i] - 0.5 * static_cast<double>(i), 2);
    return -sum;
  };
  for (const xp::PoseOptimizerMethod method : { xp::PoseOptimizerMethod::NelderMead, xp::PoseOptimizerMethod::Subplex,
         xp::PoseOptimizerMethod::BOBYQA, xp::PoseOptimizerMethod::COBYLA })
  {
    xp::ParameterSearch search;
    search.method = method;
    search.lower.assign(6, -20.0);
    search.upper.assign(6, 20.0);
    search.step.assign(6, 2.0);
    search.tolerance.assign(6, 1e-3);
    search.maxEvaluations = 1000;
    std::vector<double> free(6, 3.0);
    const int evaluations = xp::MaximizeParameters(objective, free, search).evaluations;
    ASSERT_GT(evaluations, 20) << xp::PoseOptimizerMethodName(method);
    for (int k = 1; k <= evaluations; ++k)
    {
      int asked = 0;
      std::vector<double> atTarget;
      double targetValue = 0.0;
      search.stopWhen = [&](const std::vector<double>& x, double value)
      {
        if (++asked != k)
          return false;
        atTarget = x;
        targetValue = value;
        return true;
      };
      std::vector<double> x(6, 3.0);
      const xp::ParameterSearchResult found = xp::MaximizeParameters(objective, x, search);
      const std::string where = std::string(xp::PoseOptimizerMethodName(method)) + ", target at evaluation " + std::to_string(k);
      ASSERT_TRUE(found.reachedTarget) << where << ": " << found.stopReason;
      EXPECT_TRUE(found.converged) << where;
      EXPECT_EQ(found.evaluations, k) << where;
      EXPECT_EQ(found.value, targetValue) << where;
      EXPECT_EQ(x, atTarget) << where;
    }
  }
}

namespace
{

/** A quadratic peak at (3, -2, 1 mm; 1, 0.5, -1 degrees), each parameter's curvature its own. */
double SkewedPeak(const xp::Pose& p)
{
  const std::array<double, 6> x = p.Parameters(), top{ 3.0, -2.0, 1.0, 1.0, 0.5, -1.0 };
  double sum = 0.0;
  for (int i = 0; i < 6; ++i)
    sum += (1.0 + i) * (x[i] - top[i]) * (x[i] - top[i]);
  return -sum;
}

} // namespace

// A restart begins at the optimum it restarts from, whose value is known: it is not evaluated
// again. Every evaluation counted is a call of the objective, and no pose is evaluated twice.
TEST(PoseOptimizer, ARestartDoesNotEvaluateItsStartAgain)
{
  for (const xp::PoseOptimizerMethod method : { xp::PoseOptimizerMethod::BOBYQA, xp::PoseOptimizerMethod::NelderMead })
  {
    std::vector<std::array<double, 6>> asked;
    const auto objective = [&](const xp::Pose& p)
    {
      asked.push_back(p.Parameters());
      return SkewedPeak(p);
    };
    xp::PoseOptimizerSettings settings;
    settings.method = method;
    settings.initialStepMM = 2.0;
    settings.initialStepDegrees = 1.0; // powers of two: a restart's first point is its start to the bit
    settings.toleranceMM = 0.5;
    settings.toleranceDegrees = 0.25;
    settings.maxEvaluations = 2000;
    settings.maxRestarts = 0;
    const int once = xp::MaximizePose(objective, xp::Pose{}, settings).evaluations;
    asked.clear();
    settings.maxRestarts = 3;
    const xp::PoseOptimizerResult restarted = xp::MaximizePose(objective, xp::Pose{}, settings);
    const std::string name = xp::PoseOptimizerMethodName(method);
    ASSERT_GT(restarted.evaluations, once) << name << ": no restart ran, nothing is tested";
    EXPECT_EQ(restarted.evaluations, static_cast<int>(asked.size())) << name << ": every evaluation counted is a call";
    std::vector<std::array<double, 6>> distinct = asked;
    std::sort(distinct.begin(), distinct.end());
    EXPECT_EQ(std::unique(distinct.begin(), distinct.end()) - distinct.begin(), static_cast<long>(asked.size()))
      << name << ": a pose evaluated twice";
  }
}

// endsRestarts: a run whose end satisfies it gets no restart (the second search's quarter-size
// travel ending on the first one's peak, which a restart would climb again); one whose end does
// not is restarted as without it. The predicate is asked about the run's end and its value.
TEST(PoseOptimizer, NoRestartFollowsARunWhoseEndEndsTheRestarts)
{
  const std::function<double(const xp::Pose&)> objective = SkewedPeak;
  for (const xp::PoseOptimizerMethod method : { xp::PoseOptimizerMethod::BOBYQA, xp::PoseOptimizerMethod::NelderMead })
  {
    const std::string name = xp::PoseOptimizerMethodName(method);
    xp::PoseOptimizerSettings settings;
    settings.method = method;
    settings.toleranceMM = 0.5;
    settings.toleranceDegrees = 0.25;
    settings.maxEvaluations = 2000;
    settings.maxRestarts = 0;
    const xp::PoseOptimizerResult once = xp::MaximizePose(objective, xp::Pose{}, settings);
    settings.maxRestarts = 3;
    const xp::PoseOptimizerResult restarted = xp::MaximizePose(objective, xp::Pose{}, settings);
    ASSERT_GT(restarted.evaluations, once.evaluations) << name << ": no restart ran, nothing is tested";

    std::vector<std::pair<std::array<double, 6>, double>> asked;
    bool ends = true;
    settings.endsRestarts = [&](const xp::Pose& end, double value)
    {
      asked.emplace_back(end.Parameters(), value);
      return ends;
    };
    const xp::PoseOptimizerResult ended = xp::MaximizePose(objective, xp::Pose{}, settings);
    EXPECT_EQ(ended.evaluations, once.evaluations) << name << ": the first run only";
    EXPECT_EQ(ended.pose.Parameters(), once.pose.Parameters()) << name;
    ASSERT_EQ(asked.size(), 1u) << name << ": asked once, about the first run's end";
    EXPECT_EQ(asked[0].first, once.pose.Parameters()) << name;
    EXPECT_EQ(asked[0].second, once.value) << name;

    asked.clear();
    ends = false;
    const xp::PoseOptimizerResult going = xp::MaximizePose(objective, xp::Pose{}, settings);
    EXPECT_EQ(going.evaluations, restarted.evaluations) << name << ": restarted as without it";
    EXPECT_EQ(going.pose.Parameters(), restarted.pose.Parameters()) << name;
    EXPECT_FALSE(asked.empty()) << name;
  }
}

// The optimiser component on its own, as the pre-alignment's 2D registrations use it: a peak in
// three parameters of different scales found within their tolerances, each parameter in its
// place; the box respected where the peak lies outside it; a parameter without its bound, step
// or tolerance refused.
TEST(PoseOptimizer, MaximizeParametersFindsAPeakWithinItsBox)
{
  const std::vector<double> peak = { 12.0, -7.5, 1.25 };
  const auto objective = [&](const std::vector<double>& x)
  { return -(std::pow(x[0] - peak[0], 2) + std::pow(x[1] - peak[1], 2) + 100.0 * std::pow(x[2] - peak[2], 2)); };
  xp::ParameterSearch search;
  search.lower = { -50.0, -50.0, -20.0 };
  search.upper = { 50.0, 50.0, 20.0 };
  search.step = { 5.0, 5.0, 2.0 };
  search.tolerance = { 0.05, 0.05, 0.02 };
  search.maxEvaluations = 2000;
  std::vector<double> x = { 0.0, 0.0, 0.0 };
  const xp::ParameterSearchResult found = xp::MaximizeParameters(objective, x, search);
  EXPECT_TRUE(found.converged) << found.stopReason;
  EXPECT_NEAR(x[0], peak[0], 0.1);
  EXPECT_NEAR(x[1], peak[1], 0.1);
  EXPECT_NEAR(x[2], peak[2], 0.04);
  EXPECT_DOUBLE_EQ(found.value, objective(x));
  EXPECT_GT(found.evaluations, 0);
  search.upper[0] = 10.0; // the peak beyond the box: the search ends on its face
  x = { 0.0, 0.0, 0.0 };
  xp::MaximizeParameters(objective, x, search);
  EXPECT_LE(x[0], 10.0);
  EXPECT_NEAR(x[0], 10.0, 0.1);
  search.tolerance.pop_back();
  EXPECT_THROW(xp::MaximizeParameters(objective, x, search), xp::Error);
}

// The vertex step: onto a quadratic peak exactly, halfway down a cone, and not along an axis
// whose values do not bracket a maximum; each axis moves towards its own peak (a sign flip or
// an axis swap moves it away).
TEST(PoseOptimizer, ParabolaVertexStepFindsThePeakAlongEachAxis)
{
  const std::array<double, 6> peak{ 3.0, -2.0, 1.0, 1.0, 0.5, -1.0 }, bend{ 1.0, 2.0, 0.5, 3.0, 1.5, 0.7 };
  const std::array<double, 6> off{ 0.4, -0.3, 0.6, -0.5, 0.2, 0.35 }; // the end's offsets from the peak
  std::array<double, 6> endParameters;
  for (int a = 0; a < 6; ++a)
    endParameters[a] = peak[a] + off[a];
  const xp::Pose end = xp::Pose::FromParameters(endParameters.data());
  int evaluations = 0;
  const auto quadratic = [&](const xp::Pose& p)
  {
    ++evaluations;
    const std::array<double, 6> q = p.Parameters();
    double value = 0.0;
    for (int a = 0; a < 6; ++a)
      value -= bend[a] * (q[a] - peak[a]) * (q[a] - peak[a]);
    return value;
  };
  const std::array<double, 6> onPeak = xp::MoveToParabolaVertex(quadratic, end, quadratic(end), 1.5, 1.0).Parameters();
  EXPECT_EQ(evaluations, 13);
  for (int a = 0; a < 6; ++a)
    EXPECT_NEAR(onPeak[a], peak[a], 1e-9) << a;

  const auto cone = [&](const xp::Pose& p)
  {
    const std::array<double, 6> q = p.Parameters();
    double value = 0.0;
    for (int a = 0; a < 6; ++a)
      value -= std::abs(q[a] - peak[a]);
    return value;
  };
  const std::array<double, 6> downCone = xp::MoveToParabolaVertex(cone, end, cone(end), 1.5, 1.0).Parameters();
  for (int a = 0; a < 6; ++a)
  {
    const double remaining = downCone[a] - peak[a];
    EXPECT_GE(remaining * off[a], -1e-12) << a;            // towards the peak, not past it
    EXPECT_LT(std::abs(remaining), 0.5 * std::abs(off[a])) << a; // at least halfway
  }

  // Yaw rises across the whole bracket: no peak there, so yaw stays.
  const auto slope = [&](const xp::Pose& p) { return quadratic(p) + bend[5] * std::pow(p.Parameters()[5] - peak[5], 2) + p.Parameters()[5]; };
  const std::array<double, 6> sloped = xp::MoveToParabolaVertex(slope, end, slope(end), 1.5, 1.0).Parameters();
  EXPECT_DOUBLE_EQ(sloped[5], endParameters[5]);
  EXPECT_NEAR(sloped[0], peak[0], 1e-9);
}

// The landscape reads the polish's probes: on a peak f0 - k x^2 (f0 = 10) the curvature is 2 k
// whichever point the probes bracket, so the uncertainty is sqrt(0.1 f0 / 2k) along each axis,
// as the landscape measured around the peak itself would find; an axis whose probes do not
// bracket a maximum has none (infinite).
TEST(Polish, ItsProbesGiveTheLandscapesUncertainty)
{
  const std::array<double, 6> peak{ 3.0, -2.0, 1.0, 1.0, 0.5, -1.0 }, k{ 0.01, 0.02, 0.005, 0.03, 0.015, 0.007 };
  const std::array<double, 6> off{ 0.4, -0.3, 0.6, -0.5, 0.2, 0.35 };
  const auto quadratic = [&](const xp::Pose& p)
  {
    const std::array<double, 6> q = p.Parameters();
    double value = 10.0;
    for (int a = 0; a < 6; ++a)
      value -= k[a] * (q[a] - peak[a]) * (q[a] - peak[a]);
    return value;
  };
  std::array<double, 6> start;
  for (int a = 0; a < 6; ++a)
    start[a] = peak[a] + off[a];
  const xp::Pose end = xp::Pose::FromParameters(start.data());
  xp::AxisProbes probes;
  const xp::Pose polished = xp::MoveToParabolaVertex(quadratic, end, quadratic(end), 1.5, 1.0, &probes);
  EXPECT_DOUBLE_EQ(probes.atCenter, quadratic(end));
  EXPECT_DOUBLE_EQ(probes.Step(0), 1.5);
  EXPECT_DOUBLE_EQ(probes.Step(4), 1.0);
  std::array<double, 6> below = start;
  below[4] -= 1.0;
  EXPECT_DOUBLE_EQ(probes.below[4], quadratic(xp::Pose::FromParameters(below.data()))) << "roll one degree below";
  const std::array<double, 6> uncertainty = xp::UncertaintyFromProbes(probes, quadratic(polished));
  for (int a = 0; a < 6; ++a)
    EXPECT_NEAR(uncertainty[a], std::sqrt(0.1 * 10.0 / (2.0 * k[a])), 1e-6) << a;

  // Yaw rising across its probes, the vertex beyond them: no maximum along yaw.
  xp::AxisProbes rising = probes;
  rising.above[5] = rising.atCenter + 1.0; // bend 0.2, vertex 5.5 steps out
  rising.below[5] = rising.atCenter - 1.2;
  const std::array<double, 6> open = xp::UncertaintyFromProbes(rising, quadratic(polished));
  EXPECT_TRUE(std::isinf(open[5]));
  EXPECT_TRUE(std::isfinite(open[0]));
  // A dip instead of a peak: none either.
  xp::AxisProbes dip = probes;
  dip.above[2] = dip.below[2] = dip.atCenter + 0.1;
  EXPECT_TRUE(std::isinf(xp::UncertaintyFromProbes(dip, quadratic(polished))[2]));
}

// Rounds of parabola vertices: on a peak with independent axes the first round lands on it and
// the second settles; along a valley coupling roll with the lateral translation (the pelvis's)
// each round lands nearer, so rounds until one settles end nearer than one round, and the stop
// on moves ends them before the cap.
TEST(Polish, RoundsUntilOneSettles)
{
  const std::array<double, 6> peak{ 1.0, -0.5, 0.3, 0.4, -0.6, 0.2 };
  const auto valley = [&](double coupling)
  {
    return [=](const xp::Pose& p)
    {
      const std::array<double, 6> q = p.Parameters();
      std::array<double, 6> d;
      for (int a = 0; a < 6; ++a)
        d[a] = q[a] - peak[a];
      double value = 10.0 - 0.05 * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) - 0.08 * (d[3] * d[3] + d[4] * d[4] + d[5] * d[5]);
      return value - coupling * d[0] * d[4]; // x and roll coupled: a tilted valley
    };
  };
  std::array<double, 6> start = peak;
  start[0] += 0.5;
  start[4] += 0.3;
  const xp::Pose end = xp::Pose::FromParameters(start.data());
  const auto distance = [&](const xp::Pose& p)
  {
    const std::array<double, 6> q = p.Parameters();
    double sum = 0.0;
    for (int a = 0; a < 6; ++a)
      sum += (q[a] - peak[a]) * (q[a] - peak[a]);
    return std::sqrt(sum);
  };

  const auto independent = valley(0.0);
  const xp::VertexPolish straight = xp::PolishToVertex(independent, end, independent(end), 1.5, 1.0, 6, 0.01, 0.01);
  EXPECT_EQ(straight.rounds, 2) << "lands, then settles";
  EXPECT_LT(distance(straight.pose), 1e-9);

  const auto coupled = valley(0.06);
  const xp::VertexPolish once = xp::PolishToVertex(coupled, end, coupled(end), 1.5, 1.0, 1, 0.01, 0.01);
  const xp::VertexPolish rounds = xp::PolishToVertex(coupled, end, coupled(end), 1.5, 1.0, 20, 0.01, 0.01);
  EXPECT_EQ(once.rounds, 1);
  EXPECT_GT(rounds.rounds, 2);
  EXPECT_LT(rounds.rounds, 20) << "the stop on moves ends it";
  EXPECT_LT(distance(rounds.pose), 0.5 * distance(once.pose));
  EXPECT_LT(distance(rounds.pose), 0.05);
  EXPECT_DOUBLE_EQ(rounds.value, coupled(rounds.pose));
  // The probes are the last round's, about the pose it started from.
  EXPECT_NEAR(rounds.probes.atCenter, coupled(rounds.pose), 1e-3);
}

TEST(PreAlignment, InverseProjectionOfProjectedMotionsGivesTheTranslation)
{
  // A pure 3D translation seen by both views: the projected shifts give it back exactly.
  const std::vector<xp::XRayView> views = StereoViews(160, 120);
  const Eigen::Vector3d t(6.0, -4.0, 3.0);
  std::vector<xp::Motion2D> motions;
  for (const xp::XRayView& view : views)
  {
    xp::Motion2D m;
    m.shift = view.Project(t) - view.Project(Eigen::Vector3d::Zero());
    motions.push_back(m);
  }
  const xp::Pose update = xp::InverseProjection(views, motions, Eigen::Vector3d::Zero());
  EXPECT_NEAR((update.translation - t).norm(), 0.0, 0.05);
  EXPECT_NEAR(update.yaw, 0.0, 1e-9);
}

namespace
{

/** A 160 x 120 texture of soft blobs (12-bit), seen with its rows stretched by `stretch` about
 *  the middle row, plus Gaussian noise of sd `noise` levels. */
std::vector<uint16_t> Blobs(double stretch, double noise, unsigned seed)
{
  std::mt19937 layout(11), random(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::vector<Eigen::Vector3d> blobs; // column, row, weight
  for (int b = 0; b < 400; ++b)
    blobs.emplace_back(160.0 * uniform(layout), 120.0 * uniform(layout), uniform(layout) < 0.5 ? -1.0 : 1.0);
  std::vector<uint16_t> image(160 * 120);
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 160; ++c)
    {
      const double row = 59.5 + (r - 59.5) / stretch;
      double value = 2048.0;
      for (const Eigen::Vector3d& blob : blobs)
        value += 600.0 * blob[2] * std::exp(-(std::pow(c - blob[0], 2) + std::pow(row - blob[1], 2)) / (2.0 * 2.5 * 2.5));
      image[static_cast<size_t>(r) * 160 + c] = static_cast<uint16_t>(std::clamp(std::lround(value + noise * gaussian(random)), 0L, 4095L));
    }
  return image;
}

} // namespace

TEST(PreAlignment, TheHalvesOfAStretchedImageRegisterApartThroughTheMasksBlanks)
{
  // A DRR rendered only in 4 x 4 blocks of a checkerboard (0 between them, as the entropy mask
  // leaves it), an X-ray of the same texture 10 % longer along the rows: the halves above and
  // below the middle row match about 3 pixels up and down (their centroids lie 60 rows apart).
  // Each half moving the DRR's blanks over the X-ray stays near its start; the X-ray stretched
  // under the whole DRR finds the stretch and the halves' distance.
  std::vector<uint8_t> mask(160 * 120);
  for (int r = 0; r < 120; ++r)
    for (int c = 0; c < 160; ++c)
      mask[static_cast<size_t>(r) * 160 + c] = ((r / 4) + (c / 4)) % 2 == 0;
  std::vector<uint16_t> drr = Blobs(1.0, 0.0, 1);
  for (size_t i = 0; i < drr.size(); ++i)
    drr[i] = mask[i] ? drr[i] : 0;
  const std::vector<uint16_t> longer = Blobs(1.1, 40.0, 2), same = Blobs(1.0, 40.0, 3);
  const Eigen::Vector2d centre(79.5, 59.5);
  xp::Motion2D motion;
  const double together = xp::StretchedHalvesApart(drr, longer, mask, 160, 120, 32, 3.0, &motion);
  const double separately = xp::HalvesApart(longer, drr, mask, 160, 120, centre, 32, 3.0);
  const double sameTogether = xp::StretchedHalvesApart(drr, same, mask, 160, 120, 32, 3.0);
  std::printf("halves apart on the 10 %% longer texture: %.2f pixels at once (scale %.3f x %.3f), %.2f each on its own; "
              "%.2f at once on the same texture\n", together, motion.scale[0], motion.scale[1], separately, sameTogether);
  EXPECT_NEAR(motion.scale[1], 1.0 / 1.1, 0.01); // the X-ray's rows shrunk back onto the DRR's
  EXPECT_NEAR(motion.scale[0], 1.0, 0.01);
  EXPECT_GT(together, 4.5);
  EXPECT_LT(separately, 3.0);
  EXPECT_LT(sameTogether, 0.5);
  EXPECT_DOUBLE_EQ(xp::StretchedHalvesApart(drr, drr, std::vector<uint8_t>(160 * 120, 0), 160, 120, 32, 3.0), 0.0);
  EXPECT_THROW(xp::StretchedHalvesApart(drr, drr, std::vector<uint8_t>(10, 1), 160, 120, 32, 3.0), xp::InputError);
}

TEST(PreAlignment, TheWarpFourOrEightPixelsAtATimeIsBitForBitTheWarpOneAtATime)
{
  // Random 12-bit pixels, every pixel of a 37 x 23 image and a scattered subset (odd counts, so
  // both the vectorised loop and its tail run), under motions whose sources fall inside, across
  // the borders, exactly on whole pixels and nowhere (NaN): the same values and validity.
  const int columns = 37, rows = 23;
  std::mt19937 random(7);
  std::uniform_int_distribution<int> grey(0, 4095);
  std::vector<uint16_t> moving(columns * rows);
  for (uint16_t& value : moving)
    value = static_cast<uint16_t>(grey(random));
  std::vector<xp::PixelIndex> every, some;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      every.push_back({ c, r });
      if ((r * columns + c) % 3 == 1)
        some.push_back({ c, r });
    }
  std::vector<xp::Motion2D> motions(5);
  motions[1].shift = { 2.37, -1.6 };
  motions[1].rotation = 7.5;
  motions[1].center = { 18.0, 11.0 };
  motions[2].shift = { -30.0, 0.25 };
  motions[2].scale = { 1.07, 0.93 };
  motions[3].shift = { 1.0, -2.0 }; // whole pixels: fx = fy = 0, and the last column and row outside
  motions[4].shift = { std::nan(""), 0.0 };
  for (const xp::Motion2D& motion : motions)
    for (const std::vector<xp::PixelIndex>* pixels : { &every, &some })
    {
      std::vector<uint16_t> one, wide;
      std::vector<uint8_t> oneValid, wideValid;
      xp::WarpPixels(moving, columns, rows, motion, *pixels, one, oneValid, xp::WarpLanes::One);
      for (const xp::WarpLanes lanes : { xp::WarpLanes::Four, xp::WarpLanes::Eight, xp::WarpLanes::Widest })
      {
        if (!xp::WarpLanesAvailable(lanes))
        {
          EXPECT_THROW(xp::WarpPixels(moving, columns, rows, motion, *pixels, wide, wideValid, lanes), xp::Error);
          continue;
        }
        xp::WarpPixels(moving, columns, rows, motion, *pixels, wide, wideValid, lanes);
        EXPECT_EQ(one, wide) << static_cast<int>(lanes) << " lanes";
        EXPECT_EQ(oneValid, wideValid) << static_cast<int>(lanes) << " lanes";
      }
    }
  // The identity keeps every pixel but the last column and row (their neighbour lies outside).
  std::vector<uint16_t> out;
  std::vector<uint8_t> valid;
  xp::WarpPixels(moving, columns, rows, motions[0], every, out, valid);
  EXPECT_EQ(std::count(valid.begin(), valid.end(), 1), (columns - 1) * (rows - 1));
  EXPECT_EQ(out[5 * columns + 9], moving[5 * columns + 9]);
  // Half a pixel to the right: the mean of two neighbours, rounded half up.
  xp::Motion2D half;
  half.shift = { -0.5, 0.0 };
  xp::WarpPixels(moving, columns, rows, half, every, out, valid);
  EXPECT_EQ(out[5 * columns + 9], (moving[5 * columns + 9] + moving[5 * columns + 10] + 1) / 2);
  EXPECT_THROW(xp::WarpPixels(std::vector<uint16_t>(10), columns, rows, half, every, out, valid), xp::InputError);
}

TEST(PreAlignment, BringsALargeMisalignmentIntoTheFineRange)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("12,-9,7,0,0,3", "truth");
  xp::StereoSimilarity similarity(scene.volume, scene.planned, Eigen::Vector3d::Zero(), Simulate(scene, truth, 3), 32);
  const xp::PreAlignmentResult result = xp::PreAlign(similarity, xp::Pose{}, Eigen::Vector3d::Zero());
  const double remaining = (result.pose.translation - truth.translation).norm();
  std::printf("pre-alignment: %s after %d iterations, %lld DRRs; %.2f mm from the truth\n",
    result.pose.ToString().c_str(), result.iterations, result.drrs, remaining);
  EXPECT_LT(remaining, 3.0) << "from " << truth.translation.norm() << " mm";
}

#include "vtkXPStereoRegistrationFilter.h"

#include <vtkCallbackCommand.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

namespace
{

/** `ct` as the filter's VTK input. */
vtkSmartPointer<vtkImageData> CTImage(const xp::CTVolumeData& ct)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(ct.dimensions.data());
  image->SetSpacing(ct.spacing.data());
  image->SetOrigin(ct.origin.data());
  vtkNew<vtkFloatArray> hu;
  hu->SetNumberOfValues(static_cast<vtkIdType>(ct.hounsfield.size()));
  std::copy(ct.hounsfield.begin(), ct.hounsfield.end(), hu->GetPointer(0));
  image->GetPointData()->SetScalars(hu);
  return image;
}

/** A detector's rows, top first, as a VTK image (whose rows run up). */
vtkSmartPointer<vtkImageData> XRayImage(const xp::RegistrationView& item)
{
  const int columns = item.view.Columns(), rows = item.view.Rows();
  auto xray = vtkSmartPointer<vtkImageData>::New();
  xray->SetDimensions(columns, rows, 1);
  xray->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  auto* p = static_cast<uint16_t*>(xray->GetScalarPointer());
  for (int r = 0; r < rows; ++r)
    std::copy(item.xray.begin() + r * columns, item.xray.begin() + (r + 1) * columns, p + (rows - 1 - r) * columns);
  return xray;
}

} // namespace

TEST(vtkXPStereoRegistrationFilter, RecoversTheMisalignmentInAPipeline)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("-4,2,3,-1,1.5,-2", "truth");
  const std::vector<xp::RegistrationView> simulated = Simulate(scene, truth, 4);
  vtkNew<vtkXPStereoRegistrationFilter> registration;
  registration->SetCTData(CTImage(scene.ct));
  xp::StereoGeometry geometry;
  for (const xp::RegistrationView& item : simulated)
  {
    geometry.views.push_back(item.view);
    registration->AddXRayData(XRayImage(item));
  }
  registration->SetGeometry(geometry);
  // Progress: every stage reported, rising to 1, and every similarity evaluation heard.
  struct Heard
  {
    std::vector<double> fractions;
    std::set<std::string> stages;
    int evaluations = 0;
  } heard;
  vtkNew<vtkCallbackCommand> onProgress, onEvaluation;
  onProgress->SetClientData(&heard);
  onProgress->SetCallback([](vtkObject* caller, unsigned long, void* data, void*)
    {
      auto* filter = static_cast<vtkXPStereoRegistrationFilter*>(caller);
      static_cast<Heard*>(data)->fractions.push_back(filter->GetProgress());
      if (filter->GetProgressText()) // the executive's own events carry none
        static_cast<Heard*>(data)->stages.insert(filter->GetProgressText());
    });
  onEvaluation->SetClientData(&heard);
  onEvaluation->SetCallback([](vtkObject*, unsigned long, void* data, void*) { ++static_cast<Heard*>(data)->evaluations; });
  registration->AddObserver(vtkCommand::ProgressEvent, onProgress);
  registration->AddObserver(vtkXPStereoRegistrationFilter::EvaluationEvent, onEvaluation);
  registration->Update();
  const xp::StereoRegistrationResult& result = registration->GetResult();
  EXPECT_TRUE(result.ok) << (result.Reasons().empty() ? "" : result.Reasons().front());
  EXPECT_EQ(heard.evaluations, static_cast<int>(result.objectiveTrace.size()));
  EXPECT_TRUE(std::is_sorted(heard.fractions.begin(), heard.fractions.end())) << "progress never goes back";
  ASSERT_FALSE(heard.fractions.empty());
  EXPECT_EQ(heard.fractions.back(), 1.0);
  for (const char* stage : { "pre-alignment", "coarse search", "second coarse search", "fine", "quality gate" })
    EXPECT_TRUE(heard.stages.count(stage)) << stage;
  EXPECT_LT((result.misalignment.translation - truth.translation).norm(), 0.5);
  EXPECT_NEAR(result.misalignment.yaw, -2.0, 0.3);
  EXPECT_NEAR(result.correction.translation[0], 4.0, 0.6) << "correction undoes a -4 mm lateral shift";
  EXPECT_EQ(registration->GetOutput(0)->GetScalarType(), VTK_UNSIGNED_SHORT);
  EXPECT_EQ(registration->GetOutput(1)->GetScalarType(), VTK_UNSIGNED_CHAR);
  EXPECT_EQ(registration->GetOutput(2)->GetScalarType(), VTK_FLOAT);
  EXPECT_EQ(registration->GetOutput(4)->GetDimensions()[0], 160);

  // A shrink factor of 2 registers the same X-rays on 80x60 panels: outputs on that grid, the
  // same pose within the accuracy asked.
  // 80x60 panels keep too few pixels for 32 x 32 histogram cells (the gate's too_few_pixels):
  // 16 bins, a quarter of the cells.
  registration->SetShrinkFactor(2);
  xp::StereoRegistrationSettings coarser = registration->GetSettings();
  coarser.bins = 16;
  // Pixels of 3.3 mm at the isocentre: each half's 2D registration resolves about a third of one,
  // and the halves of view B end 0.7-1.2 mm apart with poses 0.06-0.12 mm from the truth. The
  // default 1 mm limit is for panels of about 0.5 mm pixels (512x384 here).
  coarser.maxHalvesApartMM = 1.5;
  registration->SetSettings(coarser);
  registration->Update();
  EXPECT_TRUE(registration->GetResult().ok) << (registration->GetResult().Reasons().empty() ? "" : registration->GetResult().Reasons().front());
  EXPECT_LT((registration->GetResult().misalignment.translation - truth.translation).norm(), 0.6);
  EXPECT_EQ(registration->GetOutput(3)->GetDimensions()[0], 80);
  EXPECT_EQ(registration->GetOutput(3)->GetDimensions()[1], 60);
  EXPECT_DOUBLE_EQ(registration->GetOutput(3)->GetSpacing()[0], 2.0 * vtkImageData::SafeDownCast(registration->GetInput(1))->GetSpacing()[0]);
  registration->SetShrinkFactor(7); // divides neither 160 nor 120
  registration->GlobalWarningDisplayOff();
  registration->Update();
  registration->GlobalWarningDisplayOn();
  ASSERT_FALSE(registration->GetResult().failures.empty());
  EXPECT_EQ(registration->GetResult().failures.front().code, xp::GateCode::InvalidInput);
  EXPECT_EQ(registration->GetCorrectionParameters()[0], 0.0) << "a refused run leaves no earlier correction to read";
  registration->SetShrinkFactor(1);

  // The Python face: bad text is refused with a reason, never thrown through the interpreter.
  registration->GlobalWarningDisplayOff();
  EXPECT_FALSE(registration->SetPatientPosition("sideways"));
  EXPECT_FALSE(registration->ReadGeometry("no-such-geometry.json"));
  registration->GlobalWarningDisplayOn();
  EXPECT_NE(std::string(registration->GetLastError()).find("no-such-geometry.json"), std::string::npos);
  EXPECT_TRUE(registration->SetPatientPosition("HFS"));

  // A patient set-up whose room isocentre is not the geometry's would place the CT elsewhere
  // than the X-rays see it: refused, and the result says why.
  xp::PatientSetup elsewhere;
  elsewhere.roomIsocenter = Eigen::Vector3d(0, 0, 5);
  registration->SetPatientSetup(elsewhere);
  registration->GlobalWarningDisplayOff();
  registration->Update();
  registration->GlobalWarningDisplayOn();
  EXPECT_FALSE(registration->GetResult().ok);
  ASSERT_FALSE(registration->GetResult().failures.empty());
  EXPECT_EQ(registration->GetResult().failures.front().code, xp::GateCode::InvalidInput);
  EXPECT_NE(registration->GetResult().failures.front().message.find("room isocentre"), std::string::npos);
}

namespace
{

/** X-rays with kV contrast (bone +40 % above 100 HU, water 6 % denser) and quantum noise. */
std::vector<xp::RegistrationView> SimulateKV(const Scene& scene, const xp::Pose& truth, unsigned seed, int columns, int rows)
{
  std::vector<float> hu = scene.ct.hounsfield;
  for (float& v : hu)
    v = v > 100.0f ? 100.0f + 1.4f * (v - 100.0f) : v;
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() = scene.ct.direction * scene.ct.spacing.asDiagonal();
  indexToCT.translation() = scene.ct.origin;
  const xp::AttenuationVolume kv(hu.data(), scene.ct.dimensions, indexToCT, 0.0205);
  std::mt19937 random(seed);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::vector<xp::RegistrationView> views;
  for (const xp::XRayView& view : StereoViews(columns, rows))
  {
    xp::RegistrationView item;
    item.view = view;
    std::vector<float> integral(static_cast<size_t>(columns) * rows);
    xp::RenderLineIntegrals(kv, xp::MisalignedCTToRoom(scene.planned, truth, Eigen::Vector3d::Zero()), view.source,
      xp::DetectorGrid::TopRowFirst(view), nullptr, integral.data());
    item.xray.resize(integral.size());
    for (size_t i = 0; i < integral.size(); ++i)
    {
      const double grey = 0.97 * 4095.0 * std::exp(-integral[i]) + 0.03 * 1024.0;
      item.xray[i] = static_cast<uint16_t>(std::clamp(std::lround(grey + 20.0 * std::sqrt(grey / 4095.0) * gaussian(random)), 0L, 4095L));
    }
    views.push_back(std::move(item));
  }
  return views;
}

/** Seeded misalignments: translations up to `mm` per axis, rotations up to `degrees`. */
xp::Pose RandomPose(std::mt19937& random, double mm, double degrees)
{
  std::uniform_real_distribution<double> t(-mm, mm), r(-degrees, degrees);
  xp::Pose pose;
  pose.translation = { t(random), t(random), t(random) };
  pose.pitch = r(random);
  pose.roll = r(random);
  pose.yaw = r(random);
  return pose;
}

/** Registers `cases` seeded misalignments; returns how many meet 0.5 mm and 0.2 degrees per axis. */
int AccurateCases(const Scene& scene, int cases, double mm, double degrees, unsigned seed)
{
  std::mt19937 random(seed);
  int accurate = 0;
  for (int k = 0; k < cases; ++k)
  {
    const xp::Pose truth = RandomPose(random, mm, degrees);
    const xp::StereoRegistrationResult result = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(),
      SimulateKV(scene, truth, seed + k, 256, 192));
    const xp::Pose& m = result.misalignment;
    const double translation = (m.translation - truth.translation).cwiseAbs().maxCoeff();
    const double rotation = std::max({ std::abs(m.pitch - truth.pitch), std::abs(m.roll - truth.roll), std::abs(m.yaw - truth.yaw) });
    const bool good = result.ok && translation <= 0.5 && rotation <= 0.2;
    accurate += good;
    std::printf("case %d: truth %s -> error %.3f mm, %.3f deg, %s%s\n", k, truth.ToString().c_str(), translation, rotation,
      result.ok ? "ok" : "failed", good ? "" : "  <-- outside 0.5 mm / 0.2 deg");
  }
  return accurate;
}

} // namespace

// Every optimiser on offer finds a smooth peak (each axis scaled differently), and a wrong name
// is refused with the field named.
TEST(PoseOptimizer, EveryMethodFindsASmoothPeak)
{
  const std::array<double, 6> peak{ 3.0, -2.0, 1.0, 1.0, 0.5, -1.0 };
  const auto objective = [&](const xp::Pose& p)
  {
    const std::array<double, 6> x = p.Parameters();
    double value = 0.0;
    for (int i = 0; i < 6; ++i)
      value -= (1.0 + i) * (x[i] - peak[i]) * (x[i] - peak[i]);
    return value;
  };
  for (const std::string& name : xp::PoseOptimizerMethodNames())
  {
    xp::PoseOptimizerSettings settings;
    settings.method = xp::ParsePoseOptimizerMethod(name, "test");
    EXPECT_STREQ(xp::PoseOptimizerMethodName(settings.method), name.c_str());
    settings.maxEvaluations = 3000;
    const xp::PoseOptimizerResult result = xp::MaximizePose(objective, xp::Pose{}, settings);
    EXPECT_TRUE(result.converged) << name << ": " << result.stopReason; // BOBYQA ends with NLopt's plain SUCCESS
    const std::array<double, 6> x = result.pose.Parameters();
    for (int i = 0; i < 6; ++i)
      EXPECT_NEAR(x[i], peak[i], 0.05) << name << " parameter " << i;
    std::printf("%s: %d evaluations\n", name.c_str(), result.evaluations);
  }
  try
  {
    xp::ParsePoseOptimizerMethod("simplex", "--optimizers");
    FAIL() << "an unknown optimiser was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("--optimizers"), std::string::npos) << e.what();
  }
}

// Each 6-DOF stage's cost is its own: a coarse search renders two DRRs (one per view) for each
// evaluation it traces and nothing else; the landscape renders the CT's shadow, whose rays are
// the DRRs measured "at the result", which renders none; the stages and the pre-alignment never
// count more DRRs than the registration rendered.
TEST(StereoRegistration, CostsAreAccountedPerStage)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), SimulateKV(scene, truth, 5, 256, 192));
  ASSERT_GE(result.stages.size(), 3u);
  EXPECT_GT(result.prealignCost.drrs, 0);
  long long staged = result.prealignCost.drrs;
  for (size_t s = 0; s < result.stages.size(); ++s)
  {
    const xp::RegistrationStage& stage = result.stages[s];
    const int next = s + 1 < result.stages.size() ? result.stages[s + 1].firstEvaluation : static_cast<int>(result.objectiveTrace.size());
    if (stage.name.find("coarse search") != std::string::npos)
      EXPECT_EQ(stage.cost.drrs, 2 * (next - stage.firstEvaluation)) << stage.name;
    if (stage.name == "landscape")
      EXPECT_EQ(stage.cost.drrs, 2) << "the shadow at the result, one DRR per view";
    if (stage.name == "at the result")
      EXPECT_EQ(stage.cost.drrs, 0) << "measured on the landscape's shadow, not rendered again";
    else
    {
      EXPECT_GT(stage.cost.rays, 0) << stage.name;
      EXPECT_GT(stage.cost.renderSeconds, 0.0) << stage.name;
      EXPECT_GT(stage.cpuSeconds, 0.0) << stage.name;
    }
    EXPECT_GE(stage.cost.metricSeconds, 0.0) << stage.name;
    EXPECT_LE(stage.cost.renderSeconds + stage.cost.metricSeconds, stage.seconds + 1e-3) << stage.name;
    staged += stage.cost.drrs;
  }
  EXPECT_LE(staged, result.drrCount);
}

// A CT of 1.25 mm voxels: the refinement on every second voxel plane (--fine-plane-step 0) ends
// where the one on every plane ends.
TEST(StereoRegistration, TheRefinementOnEveryOtherPlaneEndsWhereEveryPlaneEnds)
{
  const Scene scene(xp::MakeHeadPhantom(1.25));
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 256, 192);
  xp::StereoRegistrationSettings skip;
  skip.finePlaneStep = 0;
  const xp::StereoRegistrationResult skipping = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, skip);
  const xp::StereoRegistrationResult all = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views);
  EXPECT_EQ(skipping.finePlaneSteps, (std::array<int, 3>{ { 2, 2, 2 } }));
  EXPECT_EQ(all.finePlaneSteps, (std::array<int, 3>{ { 1, 1, 1 } }));
  const std::string against = Described(skipping) + " against " + Described(all);
  EXPECT_TRUE(skipping.ok) << against;
  EXPECT_TRUE(all.ok) << against;
  EXPECT_LE((skipping.misalignment.translation - all.misalignment.translation).norm(), 0.15) << against;
  EXPECT_LE(std::abs(skipping.misalignment.pitch - all.misalignment.pitch), 0.1) << against;
  EXPECT_LE(std::abs(skipping.misalignment.roll - all.misalignment.roll), 0.1) << against;
  EXPECT_LE(std::abs(skipping.misalignment.yaw - all.misalignment.yaw), 0.1) << against;
  EXPECT_LE((skipping.misalignment.translation - truth.translation).norm(), 0.3) << against;
  // The setting reached the renderer: ignored there, both runs would be the same to the bit.
  ASSERT_EQ(skipping.drrs.size(), all.drrs.size());
  EXPECT_NE(skipping.drrs[0], all.drrs[0]);
}

// The schedule is the registration's plan: its stages in order, each at its size and within its
// budget; the trace's stages are the 6-DOF ones that ran, their evaluations adding up to the total.
TEST(RegistrationSchedule, ListsTheMethodsStagesInOrder)
{
  using K = xp::StageKind;
  xp::StereoRegistrationSettings settings;
  settings.schedule = xp::ScheduleChoice::Standard; // the economy's own test follows
  const auto kinds = [](const xp::RegistrationSchedule& schedule)
  {
    std::vector<K> out;
    for (const xp::ScheduledStage& stage : schedule.stages)
      out.push_back(stage.kind);
    return out;
  };
  const xp::RegistrationSchedule body = xp::MakeSchedule(settings, true, true, false);
  EXPECT_EQ(kinds(body), (std::vector<K>{ K::PreAlignment, K::Masks, K::Search, K::Search, K::Refinement, K::Polish,
                           K::Landscape, K::Gate }));
  EXPECT_EQ(body.stages[0].imageDivisor, 2) << "the pre-alignment at half size";
  EXPECT_EQ(body.stages[0].rounds, 6);
  EXPECT_EQ(body.stages[2].track, 0);
  EXPECT_EQ(body.stages[3].track, 1);
  EXPECT_FALSE(body.stages[2].stopAtFirstEnd);
  EXPECT_TRUE(body.stages[3].stopAtFirstEnd) << "the robustness search stops on the first one's optimum";
  EXPECT_EQ(body.stages[2].imageDivisor, 2);
  EXPECT_EQ(body.stages[4].imageDivisor, 1) << "the refinement at the registration's size";
  EXPECT_TRUE(body.stages[4].stopAtFirstEnd) << "the second end's refinement stops on the first one's optimum";
  EXPECT_NE(xp::DescribeSchedule(body).find("the second end's stops at the first's"), std::string::npos);
  EXPECT_LT(body.stages[4].optimizer.toleranceMM, body.stages[2].optimizer.toleranceMM);
  for (size_t s = 1; s < body.stages.size(); ++s)
    EXPECT_GE(body.stages[s].progressFrom, body.stages[s - 1].progressTo - 1e-12) << body.stages[s].name;

  const xp::RegistrationSchedule small = xp::MakeSchedule(settings, false, false, false);
  EXPECT_EQ(small.stages[2].imageDivisor, 1) << "no pyramid under 256x192";
  EXPECT_EQ(small.stages[2].name, "coarse search");

  settings.quarterSizeTravel = true;
  const xp::RegistrationSchedule travel = xp::MakeSchedule(settings, true, true, false);
  ASSERT_EQ(travel.stages.size(), body.stages.size() + 2);
  EXPECT_EQ(travel.stages[2].imageDivisor, 4);
  EXPECT_EQ(travel.stages[3].imageDivisor, 2);
  EXPECT_EQ(travel.stages[3].track, 0);
  EXPECT_DOUBLE_EQ(travel.stages[3].optimizer.initialStepMM, 0.25 * travel.stages[2].optimizer.initialStepMM);
  EXPECT_EQ(xp::MakeSchedule(settings, true, false, false).stages.size(), body.stages.size()) << "no quarter under 512x384";

  settings.quarterSizeTravel = false;
  settings.maxSearchDisagreementMM = 0.0;
  EXPECT_EQ(kinds(xp::MakeSchedule(settings, true, true, false)),
    (std::vector<K>{ K::PreAlignment, K::Masks, K::Search, K::Refinement, K::Polish, K::Landscape, K::Gate }));

  xp::StereoRegistrationSettings standard;
  standard.schedule = xp::ScheduleChoice::Standard;
  const xp::RegistrationSchedule bone = xp::MakeSchedule(standard, true, true, true);
  EXPECT_EQ(bone.stages[0].rounds, 0) << "a bone's start is evaluated, not pre-aligned";
  EXPECT_EQ(bone.stages[5].kind, K::Restarts);
  EXPECT_EQ(bone.stages[5].rounds, 4);
  EXPECT_LE(bone.stages[5].optimizer.maxEvaluations, 150);
  EXPECT_NE(xp::DescribeSchedule(body).find("refinement"), std::string::npos);
}

TEST(RegistrationSchedule, StageKindsReadBackByTheirNames)
{
  for (xp::StageKind kind : { xp::StageKind::PreAlignment, xp::StageKind::Masks, xp::StageKind::Search, xp::StageKind::Refinement,
         xp::StageKind::Polish, xp::StageKind::Restarts, xp::StageKind::Landscape, xp::StageKind::Gate })
  {
    const std::optional<xp::StageKind> read = xp::StageKindNamed(xp::StageKindName(kind));
    ASSERT_TRUE(read.has_value()) << xp::StageKindName(kind);
    EXPECT_EQ(*read, kind);
  }
  EXPECT_FALSE(xp::StageKindNamed("fine").has_value()) << "a stage's name is not its kind";
  EXPECT_FALSE(xp::StageKindNamed("").has_value());
}

TEST(RegistrationSchedule, TheEconomyTravelsAtQuarterSizeAndStopsLooser)
{
  xp::StereoRegistrationSettings settings;
  settings.schedule = xp::ScheduleChoice::Economy;
  xp::StereoRegistrationSettings standardSettings;
  standardSettings.schedule = xp::ScheduleChoice::Standard;
  const xp::RegistrationSchedule standard = xp::MakeSchedule(standardSettings, true, true, false);
  const xp::RegistrationSchedule economy = xp::MakeSchedule(settings, true, true, false);
  EXPECT_EQ(xp::StereoRegistrationSettings{}.schedule, xp::ScheduleChoice::Economy) << "the default";
  ASSERT_EQ(economy.stages.size(), standard.stages.size() + 2) << "a quarter-size travel for each search";
  const xp::ScheduledStage& standardSearch = standard.stages[2];
  const xp::ScheduledStage& standardRefinement = standard.stages[4];
  int quarter = 0;
  for (const xp::ScheduledStage& e : economy.stages)
  {
    if (e.kind == xp::StageKind::Search)
    {
      EXPECT_LT(e.optimizer.maxRestarts, standardSearch.optimizer.maxRestarts) << e.name;
      quarter += e.imageDivisor == 4;
      if (e.imageDivisor == 2)
      {
        EXPECT_GT(e.optimizer.toleranceMM, standardSearch.optimizer.toleranceMM) << e.name;
        EXPECT_GT(e.optimizer.toleranceDegrees, standardSearch.optimizer.toleranceDegrees) << e.name;
        EXPECT_EQ(e.stopAtFirstEnd, e.track == 1) << e.name;
        EXPECT_LE(e.optimizer.maxEvaluations, e.track == 1 ? 60 : standardSearch.optimizer.maxEvaluations) << e.name;
      }
    }
    if (e.kind == xp::StageKind::Refinement)
    {
      EXPECT_GT(e.optimizer.toleranceMM, standardRefinement.optimizer.toleranceMM);
      EXPECT_GT(e.optimizer.toleranceDegrees, standardRefinement.optimizer.toleranceDegrees);
    }
  }
  EXPECT_EQ(quarter, 2);
  for (const xp::ScheduledStage& e : economy.stages)
    EXPECT_EQ(e.joinsFirstTrack, e.kind == xp::StageKind::Search && e.track == 1 && e.imageDivisor == 4) << e.name;
  // Each track's last stage on the same images: the two ends' objectives compare.
  for (const xp::RegistrationSchedule* schedule : { &standard, &economy })
  {
    int lastDivisor[2] = { 0, 0 };
    for (const xp::ScheduledStage& stage : schedule->stages)
      if (stage.kind == xp::StageKind::Search)
        lastDivisor[stage.track] = stage.imageDivisor;
    EXPECT_EQ(lastDivisor[0], lastDivisor[1]);
  }
  EXPECT_EQ(xp::MakeSchedule(settings, true, false, false).stages.size(), standard.stages.size()) << "no quarter size under 512x384";
  EXPECT_EQ(xp::ParseScheduleChoice("economy", "--schedule"), xp::ScheduleChoice::Economy);
  try
  {
    xp::ParseScheduleChoice("fast", "--schedule");
    FAIL() << "an unknown schedule is refused";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("--schedule"), std::string::npos) << e.what();
  }
}

// The economy schedule finds the same pose casting fewer rays (more of its evaluations are on
// quarter-size images).
TEST(RegistrationSchedule, TheEconomyScheduleFindsThePoseCastingFewerRays)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 512, 384);
  xp::StereoRegistrationSettings economy;
  economy.schedule = xp::ScheduleChoice::Economy;
  const xp::StereoRegistrationResult fewer = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, economy);
  xp::StereoRegistrationSettings standardSettings;
  standardSettings.schedule = xp::ScheduleChoice::Standard;
  const xp::StereoRegistrationResult standard =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, standardSettings);
  EXPECT_TRUE(fewer.ok) << (fewer.Reasons().empty() ? "" : fewer.Reasons().front());
  EXPECT_LT((fewer.misalignment.translation - truth.translation).norm(), 0.5);
  EXPECT_NEAR(fewer.misalignment.yaw, truth.yaw, 0.3);
  const auto rays = [](const xp::StereoRegistrationResult& r)
  {
    long long total = 0;
    for (const xp::RegistrationStage& stage : r.stages)
      total += stage.cost.rays;
    return total;
  };
  std::printf("economy: %d evaluations, %lld rays; standard: %d, %lld\n", fewer.evaluations, rays(fewer), standard.evaluations, rays(standard));
  EXPECT_LT(rays(fewer), rays(standard));
  bool quarter = false;
  for (const xp::RegistrationStage& stage : fewer.stages)
    quarter |= stage.name == "second coarse search (quarter resolution)" && stage.imageDivisor == 4;
  EXPECT_TRUE(quarter);
  // Each traced stage records the kind of the scheduled stage it runs (the landscape's held-out
  // check and its evaluation at the result the landscape's), and a second end's refinement says so.
  for (const xp::StereoRegistrationResult* r : { &fewer, &standard })
    for (const xp::RegistrationStage& stage : r->stages)
    {
      const std::string second = " from the second search's end";
      const bool secondEnd = stage.name.size() > second.size() && stage.name.compare(stage.name.size() - second.size(), second.size(), second) == 0;
      const std::string scheduledName = secondEnd ? stage.name.substr(0, stage.name.size() - second.size()) : stage.name;
      const auto scheduled = std::find_if(r->schedule.stages.begin(), r->schedule.stages.end(),
        [&](const xp::ScheduledStage& s) { return s.name == scheduledName; });
      const xp::StageKind expected = scheduled != r->schedule.stages.end() ? scheduled->kind : xp::StageKind::Landscape;
      EXPECT_EQ(xp::StageKindName(stage.kind), std::string(xp::StageKindName(expected))) << stage.name;
      EXPECT_EQ(stage.secondEnd, secondEnd) << stage.name;
      if (scheduled == r->schedule.stages.end())
        EXPECT_TRUE(stage.name == "held-out check" || stage.name == "at the result") << stage.name;
    }
}

namespace
{

/** The evaluations of a registration's stage `name` on images of 1 / `divisor` per side; -1 where
 *  it has no such stage. */
int EvaluationsOf(const xp::StereoRegistrationResult& result, const std::string& name, int divisor)
{
  for (const xp::RegistrationStage& stage : result.stages)
    if (stage.name == name && stage.imageDivisor == divisor)
      return stage.evaluations;
  return -1;
}

} // namespace

// Where the second search's quarter-size travel meets the first one's end, or ends within the
// searches' agreement of it, the second search ends there: its half-size stage is not run, and the result is the one the climb on at half
// size gives (secondSearchJoins false), within a tenth of the searches' agreement.
TEST(RegistrationSchedule, TheSecondSearchEndsWhereItMeetsTheFirst)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 512, 384);
  EXPECT_TRUE(xp::StereoRegistrationSettings{}.secondSearchJoins) << "the default";
  // The phantom's two quarter-size travels end 0.38 mm and 0.2 degree apart, the second 9 % lower:
  // on the same peak, which the second did not meet on its way.
  const xp::StereoRegistrationSettings joining;
  xp::StereoRegistrationSettings climbing = joining;
  climbing.secondSearchJoins = false;
  const xp::StereoRegistrationResult joined = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, joining);
  const xp::StereoRegistrationResult climbed = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, climbing);
  const std::string against = Described(joined) + " against " + Described(climbed);
  ASSERT_TRUE(joined.ok) << against;
  ASSERT_TRUE(climbed.ok) << against;
  EXPECT_GT(EvaluationsOf(joined, "second coarse search (quarter resolution)", 4), 0);
  EXPECT_EQ(EvaluationsOf(joined, "second coarse search", 2), -1) << "the second search met the first at quarter size";
  const int halfSize = EvaluationsOf(climbed, "second coarse search", 2);
  EXPECT_GT(halfSize, 0);
  EXPECT_EQ(joined.evaluations, climbed.evaluations - halfSize) << "the same registration but for the half-size climb";
  EXPECT_LE(joined.searchDisagreementMM, joining.maxSearchDisagreementMM);
  EXPECT_LE(joined.searchDisagreementDegrees, joining.maxSearchDisagreementDegrees);
  EXPECT_LT((joined.misalignment.translation - climbed.misalignment.translation).norm(), 0.05) << against;
  EXPECT_LT(std::abs(joined.misalignment.yaw - climbed.misalignment.yaw), 0.05) << against;
  bool joins = false;
  for (const xp::ScheduledStage& stage : joined.schedule.stages)
    joins |= stage.joinsFirstTrack;
  EXPECT_TRUE(joins) << "the schedule says so";
  EXPECT_NE(xp::DescribeSchedule(joined.schedule).find("ends the track there"), std::string::npos);
  for (const xp::ScheduledStage& stage : climbed.schedule.stages)
    EXPECT_FALSE(stage.joinsFirstTrack) << stage.name;
}

// The search stages' optimisers as the default schedule gives them: track 0's as scheduled; track
// 1's stop on a pose agreeing with track 0's end about as high; the stage that joins the first
// track (the second quarter-size travel) ends its restarts where a run ends within twice its stops
// of a converged first end, along a translation or an angle, and no other stage does.
TEST(RegistrationSchedule, TheSecondTravelEndsItsRestartsWithinTwiceItsStopsOfTheFirstEnd)
{
  const xp::StereoRegistrationSettings settings;
  const xp::RegistrationSchedule schedule = xp::MakeSchedule(settings, true, true, false);
  const xp::ScheduledStage* joining = nullptr;
  const xp::ScheduledStage* halfSize = nullptr;
  const xp::ScheduledStage* first = nullptr;
  for (const xp::ScheduledStage& stage : schedule.stages)
    if (stage.kind == xp::StageKind::Search)
    {
      if (stage.track == 0 && !first)
        first = &stage;
      else if (stage.track == 1 && stage.joinsFirstTrack)
        joining = &stage;
      else if (stage.track == 1)
        halfSize = &stage;
    }
  ASSERT_NE(first, nullptr);
  ASSERT_NE(joining, nullptr) << xp::DescribeSchedule(schedule);
  ASSERT_NE(halfSize, nullptr) << xp::DescribeSchedule(schedule);
  ASSERT_GT(joining->optimizer.toleranceMM, 0.0);
  ASSERT_GT(joining->optimizer.toleranceDegrees, 0.0);

  const xp::PoseOptimizerSettings alone = xp::SearchStageOptimizer(*first, nullptr, settings);
  EXPECT_FALSE(alone.stopWhen) << "track 0 has no end to meet";
  EXPECT_FALSE(alone.endsRestarts);
  EXPECT_EQ(alone.maxRestarts, first->optimizer.maxRestarts);
  EXPECT_EQ(alone.maxEvaluations, first->optimizer.maxEvaluations);

  xp::PoseOptimizerResult firstEnd;
  firstEnd.pose = xp::Pose::Parse("3,-2,1,1,-1,0.5", "first end");
  firstEnd.value = 0.8;
  firstEnd.converged = true;
  const double mm = joining->optimizer.toleranceMM, degrees = joining->optimizer.toleranceDegrees;
  auto moved = [&](double dx, double droll)
  {
    xp::Pose pose = firstEnd.pose;
    pose.translation.x() += dx;
    pose.roll += droll;
    return pose;
  };
  const xp::PoseOptimizerSettings joins = xp::SearchStageOptimizer(*joining, &firstEnd, settings);
  ASSERT_TRUE(joins.endsRestarts);
  EXPECT_TRUE(joins.endsRestarts(moved(1.9 * mm, 0.0), 0.1)) << "within twice the stops, whatever its value";
  EXPECT_TRUE(joins.endsRestarts(moved(0.0, -1.9 * degrees), 0.1));
  EXPECT_FALSE(joins.endsRestarts(moved(2.1 * mm, 0.0), 0.8)) << "beyond twice the stops in x";
  EXPECT_FALSE(joins.endsRestarts(moved(0.0, -2.1 * degrees), 0.8)) << "beyond twice the stops in roll";
  ASSERT_TRUE(joins.stopWhen);
  EXPECT_TRUE(joins.stopWhen(firstEnd.pose, settings.sameOptimumObjectiveRatio * firstEnd.value));
  EXPECT_FALSE(joins.stopWhen(firstEnd.pose, 0.9 * settings.sameOptimumObjectiveRatio * firstEnd.value)) << "clearly lower";
  EXPECT_FALSE(joins.stopWhen(moved(settings.maxSearchDisagreementMM + 0.1, 0.0), firstEnd.value)) << "not in agreement";

  const xp::PoseOptimizerSettings climbs = xp::SearchStageOptimizer(*halfSize, &firstEnd, settings);
  EXPECT_TRUE(climbs.stopWhen) << "the half-size stage still stops on the first end";
  EXPECT_FALSE(climbs.endsRestarts) << "it does not join the first track";

  xp::PoseOptimizerResult unconverged = firstEnd;
  unconverged.converged = false;
  EXPECT_FALSE(xp::SearchStageOptimizer(*joining, &unconverged, settings).endsRestarts)
    << "an end that stopped on its budget is no peak";

  // The optimiser keeps its own copy of the first end: the caller's may change.
  firstEnd.pose.translation.x() += 10.0;
  EXPECT_TRUE(joins.endsRestarts(moved(-10.0 + 1.9 * mm, 0.0), 0.1));
}

// --half-size-refinement: a refinement at half size on the refinement's objective, then the
// full-size one from its end, which has no more to climb (on this scene the searches end near the
// peak; on the pelvis it took half the evaluations: Algorithms.md); the pose as near the truth.
TEST(RegistrationSchedule, AHalfSizeRefinementComesBeforeTheFullSizeOne)
{
  xp::StereoRegistrationSettings settings;
  settings.halfSizeRefinement = true;
  const xp::RegistrationSchedule schedule = xp::MakeSchedule(settings, true, true, false);
  std::vector<std::pair<xp::StageKind, int>> refinements;
  for (const xp::ScheduledStage& stage : schedule.stages)
    if (stage.kind == xp::StageKind::Refinement)
      refinements.emplace_back(stage.kind, stage.imageDivisor);
  ASSERT_EQ(refinements.size(), 2u);
  EXPECT_EQ(refinements[0].second, 2);
  EXPECT_EQ(refinements[1].second, 1);
  EXPECT_EQ(xp::MakeSchedule(settings, false, false, false).stages.size(), xp::MakeSchedule({}, false, false, false).stages.size())
    << "no half size without a pyramid";

  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 512, 384);
  const xp::StereoRegistrationResult plain = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views);
  const xp::StereoRegistrationResult halved =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
  ASSERT_TRUE(halved.ok) << (halved.Reasons().empty() ? "" : halved.Reasons().front());
  EXPECT_LT((halved.misalignment.translation - truth.translation).norm(), 0.5);
  EXPECT_NEAR(halved.misalignment.yaw, truth.yaw, 0.3);
  EXPECT_GT(EvaluationsOf(halved, "fine (half resolution)", 2), 0);
  EXPECT_EQ(EvaluationsOf(plain, "fine (half resolution)", 2), -1);
  std::printf("full-size refinement: %d evaluations after the half-size one, %d alone\n", EvaluationsOf(halved, "fine", 1),
    EvaluationsOf(plain, "fine", 1));
  EXPECT_LE(EvaluationsOf(halved, "fine", 1), EvaluationsOf(plain, "fine", 1));
}

// --high-pass-after-travel: the half-size searches of both tracks maximise the refinement's
// high-passed objective (its MI is far below the shaded one's, where the shading's broad levels
// match); the quarter-size travel keeps the shading, and without the travel (no pyramid, or
// quarter-size images too small) nothing changes. On X-rays with a ramp the DRR does not have,
// the pose is found as near.
TEST(RegistrationSchedule, TheHalfSizeSearchesAfterTheTravelAreHighPassed)
{
  xp::StereoRegistrationSettings settings;
  settings.highPassAfterTravel = true;
  int highPassed = 0;
  for (const xp::ScheduledStage& stage : xp::MakeSchedule(settings, true, true, false).stages)
  {
    if (stage.kind != xp::StageKind::Search)
      continue;
    EXPECT_EQ(stage.highPassMM, stage.imageDivisor == 2 ? settings.fineHighPassMM : 0.0) << stage.name;
    highPassed += stage.highPassMM > 0.0;
  }
  EXPECT_EQ(highPassed, 2) << "both tracks' half-size searches";
  for (const auto& [pyramid, quarter] : { std::pair{ true, false }, std::pair{ false, false } })
    for (const xp::ScheduledStage& stage : xp::MakeSchedule(settings, pyramid, quarter, false).stages)
      EXPECT_EQ(stage.highPassMM, 0.0) << stage.name << ": no travel, no high-pass";
  for (const xp::ScheduledStage& stage : xp::MakeSchedule({}, true, true, false).stages)
    EXPECT_EQ(stage.highPassMM, 0.0) << stage.name << ": off by default";

  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 512, 384);
  for (xp::RegistrationView& item : views)
  {
    // A ramp of a fifth of the levels across the panel: shading the DRR does not have.
    const int columns = item.view.Columns();
    for (size_t i = 0; i < item.xray.size(); ++i)
      item.xray[i] = static_cast<uint16_t>(std::min(65535.0, item.xray[i] * (0.9 + 0.2 * static_cast<double>(i % columns) / columns)));
  }
  const xp::StereoRegistrationResult shaded = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views);
  const xp::StereoRegistrationResult passed =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
  ASSERT_TRUE(passed.ok) << (passed.Reasons().empty() ? "" : passed.Reasons().front());
  EXPECT_LT((passed.misalignment.translation - truth.translation).norm(), 0.5);
  EXPECT_NEAR(passed.misalignment.yaw, truth.yaw, 0.3);
  std::printf("full-size refinement: %d evaluations after high-passed half-size searches, %d after shaded ones\n",
    EvaluationsOf(passed, "fine", 1), EvaluationsOf(shaded, "fine", 1));
  EXPECT_GT(EvaluationsOf(passed, "fine", 1), 0);
  const auto bestOf = [](const xp::StereoRegistrationResult& r, const std::string& name)
  {
    double best = -1.0;
    for (const xp::RegistrationStage& stage : r.stages)
      if (stage.name == name)
        for (int e = stage.firstEvaluation; e < stage.firstEvaluation + stage.evaluations; ++e)
          best = std::max(best, r.objectiveTrace.at(static_cast<size_t>(e)));
    return best;
  };
  for (const std::string name : { "coarse search (quarter resolution)", "coarse search (half resolution)" })
    std::printf("%s: best objective %.3f high-passed after the travel, %.3f shaded\n", name.c_str(), bestOf(passed, name),
      bestOf(shaded, name));
  EXPECT_EQ(bestOf(passed, "coarse search (quarter resolution)"), bestOf(shaded, "coarse search (quarter resolution)"))
    << "the travel is the same";
  EXPECT_LT(bestOf(passed, "coarse search (half resolution)"), 0.5 * bestOf(shaded, "coarse search (half resolution)"));
  int recorded = 0;
  for (const xp::ScheduledStage& stage : passed.schedule.stages)
    recorded += stage.kind == xp::StageKind::Search && stage.highPassMM > 0.0;
  EXPECT_EQ(recorded, 2) << "the result's schedule records the high-pass";
}

TEST(RegistrationSchedule, TheTraceCountsEachStagesEvaluationsAtItsSize)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), SimulateKV(scene, truth, 5, 256, 192));
  ASSERT_FALSE(result.schedule.stages.empty());
  EXPECT_EQ(result.schedule.stages.front().kind, xp::StageKind::PreAlignment);
  int total = 0;
  for (size_t s = 0; s < result.stages.size(); ++s)
  {
    const xp::RegistrationStage& stage = result.stages[s];
    const int next = s + 1 < result.stages.size() ? result.stages[s + 1].firstEvaluation : static_cast<int>(result.objectiveTrace.size());
    EXPECT_EQ(stage.evaluations, next - stage.firstEvaluation) << stage.name;
    const bool halfSize = stage.name.find("coarse search") != std::string::npos || stage.name == "held-out check";
    EXPECT_EQ(stage.imageDivisor, halfSize ? 2 : 1) << stage.name;
    total += stage.evaluations;
  }
  EXPECT_EQ(total, result.evaluations);
  EXPECT_EQ(total, static_cast<int>(result.objectiveTrace.size()));
  // The polish's, the held-out check's and the result's own evaluations are counted too: 13 a
  // polish round. The landscape reads its curvature from the polish's last 12 probes (none of its
  // own), the held-out check measures the result and its six translated neighbours (7), and the
  // refinement's objective at the result is the polish's last evaluation (the result's edges: 1).
  const auto polish = std::find_if(result.stages.begin(), result.stages.end(), [](const xp::RegistrationStage& s) { return s.name == "vertex polish"; });
  ASSERT_NE(polish, result.stages.end());
  EXPECT_GT(polish->evaluations, 0);
  EXPECT_EQ(polish->evaluations % 13, 0);
  const std::map<std::string, int> expected = { { "landscape", 0 }, { "held-out check", 7 }, { "at the result", 1 } };
  for (const auto& [name, evaluations] : expected)
  {
    const auto stage = std::find_if(result.stages.begin(), result.stages.end(), [&](const xp::RegistrationStage& s) { return s.name == name; });
    ASSERT_NE(stage, result.stages.end()) << name;
    EXPECT_EQ(stage->evaluations, evaluations) << name;
  }
  for (double u : result.uncertainty)
    EXPECT_TRUE(u > 0.0 && u < 3.0) << "the phantom's peak is sharp along every axis: " << u;
  EXPECT_GT(result.prealignment.iterations, 0);
}

// At 512x384 and quarterSizeTravel the coarse searches travel on 128x96 images and end at
// 256x192: the travel casts fewer rays per evaluation than the search's end, and the pose is as
// accurate. By default there is no such stage.
TEST(StereoRegistration, CoarseSearchesTravelAtQuarterSizeOnLargeViews)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 512, 384);
  xp::StereoRegistrationSettings quarterFirst;
  quarterFirst.schedule = xp::ScheduleChoice::Standard; // the option on the standard schedule
  quarterFirst.quarterSizeTravel = true;
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, quarterFirst);
  const auto stage = [&](const xp::StereoRegistrationResult& r, const std::string& name) -> const xp::RegistrationStage*
  {
    for (const xp::RegistrationStage& s : r.stages)
      if (s.name == name)
        return &s;
    return nullptr;
  };
  const auto raysPerEvaluation = [&](const xp::StereoRegistrationResult& r, const std::string& name)
  {
    const xp::RegistrationStage* s = stage(r, name);
    return s->cost.drrs > 0 ? static_cast<double>(s->cost.rays) / s->cost.drrs : 0.0;
  };
  for (const char* name : { "coarse search (quarter resolution)", "second coarse search (quarter resolution)" })
  {
    ASSERT_NE(stage(result, name), nullptr) << name;
    EXPECT_GT(stage(result, name)->cost.drrs, 0) << name;
  }
  ASSERT_NE(stage(result, "coarse search (half resolution)"), nullptr);
  EXPECT_LT(raysPerEvaluation(result, "coarse search (quarter resolution)"),
    0.5 * raysPerEvaluation(result, "coarse search (half resolution)"));
  EXPECT_TRUE(result.ok) << (result.Reasons().empty() ? "" : result.Reasons().front());
  EXPECT_LT((result.misalignment.translation - truth.translation).norm(), 0.5);
  EXPECT_NEAR(result.misalignment.yaw, truth.yaw, 0.3);

  xp::StereoRegistrationSettings standard;
  standard.schedule = xp::ScheduleChoice::Standard;
  const xp::StereoRegistrationResult without =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, standard);
  EXPECT_EQ(stage(without, "coarse search (quarter resolution)"), nullptr);
  EXPECT_NE(stage(without, "coarse search (half resolution)"), nullptr);
}

TEST(StereoRegistration, SmoothsEachXRayToTheCTsVoxelAtTheIsocentre)
{
  // The smoothing's sd in pixels is the fraction asked for of the finest voxel (2 mm here) over
  // the pixel's width at the isocentre; a fraction that leaves under 0.3 pixels does nothing.
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-1,1,0.5,0,-0.5", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 128, 96);
  xp::StereoRegistrationSettings settings;
  settings.xraySmoothingPerVoxel = 0.6;
  settings.xrayNoiseLevels = 0.0; // the CT's sd alone
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
  ASSERT_EQ(result.xraySmoothingPixels.size(), 2u);
  for (size_t v = 0; v < views.size(); ++v)
  {
    const double pixel = xp::PixelSpacingAtIsocenter(views[v].view, Eigen::Vector3d::Zero());
    EXPECT_NEAR(pixel, views[v].view.pixelSpacing.maxCoeff() * 1000.0 / 1500.0, 1e-6); // SAD 1000, SID 1500
    EXPECT_NEAR(result.xraySmoothingPixels[v], 0.6 * 2.0 / pixel, 1e-9);
  }
  settings.xraySmoothingPerVoxel = 0.3 * 0.9 * xp::PixelSpacingAtIsocenter(views[0].view, Eigen::Vector3d::Zero()) / 2.0;
  const xp::StereoRegistrationResult unsmoothed =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
  EXPECT_EQ(unsmoothed.xraySmoothingPixels, std::vector<double>(2, 0.0));
}

TEST(StereoRegistration, SmoothsANoisyXRayMoreUpToTwiceTheCTsSD)
{
  // Each view's sd is its ranks' noise over 2 sqrt(pi) times the target, no less than the CT's sd
  // and no more than twice it. Read noise of 200 grey values added to one view raises its noise
  // and its sd and leaves the other view's as they were; a target 100 times tighter takes the
  // noisy view to the cap, and no target leaves both at the CT's sd.
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-1,1,0.5,0,-0.5", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 128, 96);
  std::mt19937 random(9);
  std::normal_distribution<double> gaussian(0.0, 200.0);
  std::vector<xp::RegistrationView> noisy = views;
  for (uint16_t& value : noisy[1].xray)
    value = static_cast<uint16_t>(std::clamp(std::lround(value + gaussian(random)), 0L, 4095L));
  xp::StereoRegistrationSettings settings;
  const double atTheCT = settings.xraySmoothingPerVoxel * 2.0 / xp::PixelSpacingAtIsocenter(views[0].view, Eigen::Vector3d::Zero());
  const auto register_ = [&](const std::vector<xp::RegistrationView>& given)
  {
    const xp::StereoRegistrationResult result =
      xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), given, settings);
    EXPECT_EQ(result.xraySmoothingPixels.size(), 2u);
    EXPECT_EQ(result.xrayRankNoise.size(), 2u);
    for (size_t v = 0; v < result.xrayRankNoise.size() && v < result.xraySmoothingPixels.size(); ++v)
    {
      const double asked = settings.xrayNoiseLevels > 0.0
        ? result.xrayRankNoise[v] / (2.0 * std::sqrt(M_PI) * settings.xrayNoiseLevels)
        : 0.0;
      EXPECT_NEAR(result.xraySmoothingPixels[v], std::clamp(asked, atTheCT, 2.0 * atTheCT), 1e-9) << v;
    }
    return result;
  };
  const xp::StereoRegistrationResult clean = register_(views);
  const xp::StereoRegistrationResult result = register_(noisy);
  ASSERT_EQ(result.xrayRankNoise.size(), 2u);
  ASSERT_EQ(clean.xrayRankNoise.size(), 2u);
  EXPECT_EQ(result.xrayRankNoise[0], clean.xrayRankNoise[0]);
  EXPECT_EQ(result.xraySmoothingPixels[0], clean.xraySmoothingPixels[0]);
  EXPECT_GT(result.xrayRankNoise[1], 2.0 * clean.xrayRankNoise[1]);
  EXPECT_GT(result.xraySmoothingPixels[1], 1.2 * clean.xraySmoothingPixels[1]);
  settings.xrayNoiseLevels /= 100.0;
  EXPECT_NEAR(register_(noisy).xraySmoothingPixels[1], 2.0 * atTheCT, 1e-9);
  settings.xrayNoiseLevels = 0.0;
  EXPECT_EQ(register_(noisy).xraySmoothingPixels, std::vector<double>(2, atTheCT));
}

TEST(StereoRegistrationAcceptance, UpTo10mmAnd3DegreesAllCasesAccurate)
{
  Scene scene;
  EXPECT_EQ(AccurateCases(scene, 4, 10.0, 3.0, 100), 4);
}

TEST(StereoRegistrationAcceptance, UpTo20mmAnd5DegreesNineInTen)
{
  Scene scene;
  EXPECT_GE(AccurateCases(scene, 10, 20.0, 5.0, 200), 9);
}

namespace
{

/** A bar along the CT's x axis (the room's lateral axis, HFS), 1 m long, so that its ends lie
 *  outside both views: an elliptical body with a dense rod off its axis, the same at every x. */
xp::CTVolumeData LateralBar()
{
  xp::CTVolumeData bar;
  bar.dimensions = { 250, 40, 30 };
  bar.spacing = { 4.0, 4.0, 4.0 };
  bar.origin = -0.5 * bar.spacing.cwiseProduct((bar.dimensions - Eigen::Vector3i::Ones()).cast<double>());
  bar.hounsfield.assign(static_cast<size_t>(bar.dimensions.prod()), -1000.0f);
  for (int k = 0; k < bar.dimensions[2]; ++k)
    for (int j = 0; j < bar.dimensions[1]; ++j)
    {
      const double y = bar.origin[1] + 4.0 * j, z = bar.origin[2] + 4.0 * k;
      // Soft edges: a sharp edge sampled on 4 mm voxels aliases with the sampling phase of the
      // rays, which would tell where along its axis the bar is.
      const double body = 1.0 / (1.0 + std::exp((std::hypot(y / 60.0, z / 35.0) - 1.0) * 60.0 / 6.0));
      const double rod = std::exp(-((y - 20.0) * (y - 20.0) + (z - 10.0) * (z - 10.0)) / (2.0 * 8.0 * 8.0));
      const float hu = static_cast<float>(-1000.0 + 1040.0 * body + 1000.0 * rod);
      for (int i = 0; i < bar.dimensions[0]; ++i)
        bar.hounsfield[(static_cast<size_t>(k) * bar.dimensions[1] + j) * bar.dimensions[0] + i] = hu;
    }
  return bar;
}

} // namespace

TEST(StereoRegistrationGate, FailsWhenTheImagesDoNotFixThePose)
{
  // Nothing in either view changes when the bar slides along its axis (x): the similarity is flat
  // along tx, and the two searches, the second started 1.5 mm further along that axis, may end
  // apart and about equally good. Either check must say so; which one catches it depends on how
  // far the second search runs on the flat floor (0.42 mm with the X-rays smoothed to the 4 mm
  // voxels, under the two-search limit, while tx is uncertain by 4 mm).
  // The rays beyond the CT's end slices (air around the bar) are left out as a CT shorter than
  // the anatomy would have them: kept, they change nothing along the bar either, but the second
  // search then happens to pass by the first one's end on the flat floor and stops there, agreeing
  // by accident (Algorithms.md, "limits of the two-search check").
  const Scene scene(LateralBar());
  const xp::Pose truth = xp::Pose::Parse("2,-1,1,0.5,0.5,-0.5", "truth");
  xp::StereoRegistrationSettings settings;
  settings.coverageMinExcess = 0.0;
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), Simulate(scene, truth, 5), settings);
  EXPECT_FALSE(result.ok) << result.misalignment.ToString();
  EXPECT_TRUE(FailedWith(result, xp::GateCode::AmbiguousPose) ||
    (FailedWith(result, xp::GateCode::Uncertain) && result.uncertainty[0] > settings.maxUncertaintyMM))
    << Described(result);
}

/** The head phantom's central 40 % of slices: a planning CT shorter than the X-rays' field. */
xp::CTVolumeData CentralSlices(const xp::CTVolumeData& whole)
{
  xp::CTVolumeData central = whole;
  const int slices = whole.dimensions[2], kept = slices * 2 / 5, first = (slices - kept) / 2;
  const size_t sliceSize = static_cast<size_t>(whole.dimensions[0]) * whole.dimensions[1];
  central.dimensions[2] = kept;
  central.origin += whole.direction.col(2) * (first * whole.spacing[2]);
  central.hounsfield.assign(whole.hounsfield.begin() + first * sliceSize, whole.hounsfield.begin() + (first + kept) * sliceSize);
  return central;
}

TEST(CTCoverage, LeavesOutTheRaysThatCrossTheBodyBeyondTheEndSlices)
{
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const xp::XRayView view = StereoViews(160, 120)[0];
  const std::vector<uint8_t> mask = xp::CTCoverageMask(cropped.volume, cropped.planned, view, 2.0);
  // The panel's columns run along -Y (the CT's slice axis, HFS): the central rows are covered,
  // the rows at the panel's ends (beyond the CT's slices, across the head) are not.
  const auto validInRow = [&](const std::vector<uint8_t>& m, int row)
  {
    int n = 0;
    for (int column = 0; column < 160; ++column)
      n += m[row * 160 + column];
    return n;
  };
  const int centre = validInRow(mask, 60);
  EXPECT_EQ(centre, 160) << "rays through the CT's middle slices";
  int leftOut = 0;
  for (int row = 0; row < 120; ++row)
    leftOut += validInRow(mask, row) < 160;
  EXPECT_GT(leftOut, 20) << "rows across the head beyond the end slices";
  // The whole CT covers what the cropped one does, and more.
  const std::vector<uint8_t> whole = xp::CTCoverageMask(full.volume, full.planned, view, 2.0);
  long long wholeValid = 0, croppedValid = 0;
  for (size_t i = 0; i < mask.size(); ++i)
  {
    wholeValid += whole[i];
    croppedValid += mask[i];
    EXPECT_TRUE(!mask[i] || whole[i]);
  }
  EXPECT_GT(wholeValid, croppedValid);
  // Moving the cropped CT 10 mm along Room -Y (the slice axis; rows run along -Y) moves the
  // covered band about 6 rows down the panel (2.5 mm pixels, magnification 1.5).
  xp::Pose shifted;
  shifted.translation = Eigen::Vector3d(0, -10, 0);
  const std::vector<uint8_t> moved = xp::CTCoverageMask(
    cropped.volume, xp::MisalignedCTToRoom(cropped.planned, shifted, Eigen::Vector3d::Zero()), view, 2.0);
  int firstBefore = -1, firstAfter = -1;
  for (int row = 0; row < 120 && (firstBefore < 0 || firstAfter < 0); ++row)
  {
    if (firstBefore < 0 && validInRow(mask, row) == 160)
      firstBefore = row;
    if (firstAfter < 0 && validInRow(moved, row) == 160)
      firstAfter = row;
  }
  EXPECT_GT(firstAfter, firstBefore + 3) << "the covered band follows the CT";
}

TEST(CTCoverage, AgreesWithDenseSamplingOfEveryRayAtAnObliquePose)
{
  // The mask walks only the stretch of each ray beyond the end slices, one sample per voxel
  // crossed. Reference: every ray sampled at a tenth of a voxel over its whole length.
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const double margin = 2.0;
  const xp::Pose oblique = xp::Pose::Parse("3,-4,2,8,-5,6", "pose");
  const Eigen::Isometry3d ctToRoom = xp::MisalignedCTToRoom(cropped.planned, oblique, Eigen::Vector3d::Zero());
  const xp::XRayView view = StereoViews(160, 120)[1];
  const std::vector<uint8_t> fast = xp::CTCoverage(cropped.volume, margin).Mask(ctToRoom, view);

  const xp::AttenuationVolume& volume = cropped.volume;
  const Eigen::Vector3i d = volume.Dimensions();
  const Eigen::Affine3d indexToCT = volume.IndexToCT();
  const double spacing = indexToCT.linear().col(0).norm(); // isotropic phantom
  const int radius = static_cast<int>(std::ceil(margin / spacing));
  std::vector<uint8_t> body(static_cast<size_t>(d[0]) * d[1], 0);
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i)
        if (volume.At(i, j, k) > 0.0f)
          for (int dj = -radius; dj <= radius; ++dj)
            for (int di = -radius; di <= radius; ++di)
              if (i + di >= 0 && i + di < d[0] && j + dj >= 0 && j + dj < d[1])
                body[static_cast<size_t>(j + dj) * d[0] + i + di] = 1;
  const double kLow = -0.5 + margin / spacing, kHigh = d[2] - 0.5 - margin / spacing;
  const Eigen::Affine3d roomToIndex = (ctToRoom * indexToCT).inverse();
  const Eigen::Vector3d source = roomToIndex * view.source;
  long long uncovered = 0, differ = 0;
  for (int row = 0; row < view.Rows(); ++row)
    for (int column = 0; column < view.Columns(); ++column)
    {
      const Eigen::Vector3d pixel = roomToIndex * view.PixelCenter(column, row);
      const int samples = static_cast<int>(10.0 * (pixel - source).norm());
      bool beyond = false;
      for (int n = 0; n <= samples && !beyond; ++n)
      {
        const Eigen::Vector3d p = source + (pixel - source) * (static_cast<double>(n) / samples);
        const long i = std::lround(p[0]), j = std::lround(p[1]);
        beyond = i >= 0 && i < d[0] && j >= 0 && j < d[1] && body[static_cast<size_t>(j) * d[0] + i] &&
          (p[2] < kLow || p[2] > kHigh);
      }
      uncovered += beyond;
      differ += beyond == (fast[static_cast<size_t>(row) * view.Columns() + column] != 0);
    }
  const long long pixels = static_cast<long long>(view.Columns()) * view.Rows();
  ASSERT_GT(uncovered, pixels / 10) << "the pose must leave many rays uncovered for this to test anything";
  ASSERT_LT(uncovered, pixels * 9 / 10);
  // Rays that graze an outline voxel's corner may go either way with coarser sampling.
  EXPECT_LE(differ, pixels / 200) << differ << " of " << pixels << " pixels differ from the dense reference";
}

TEST(CTCoverage, NamesTheEndFaceEachRayCrossesBeyond)
{
  // HFS: the CT's last slice is the most superior (Room +Y), and the panel's rows run along -Y:
  // rays beyond the last slice meet the panel's top rows, those beyond the first its bottom rows.
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const xp::XRayView view = StereoViews(160, 120)[0];
  const xp::CTCoverage coverage(cropped.volume, 2.0);
  const std::vector<uint8_t> faces = coverage.EndFaces(cropped.planned, view);
  double rowSum[4] = { 0, 0, 0, 0 };
  long long count[4] = { 0, 0, 0, 0 };
  for (size_t i = 0; i < faces.size(); ++i)
  {
    ASSERT_LE(faces[i], xp::BothEndFaces);
    rowSum[faces[i] & 3] += static_cast<double>(i / 160);
    count[faces[i] & 3] += 1;
  }
  ASSERT_GT(count[xp::FirstSliceFace], 500);
  ASSERT_GT(count[xp::LastSliceFace], 500);
  EXPECT_EQ(count[xp::BothEndFaces], 0) << "no ray runs along the whole head";
  EXPECT_GT(rowSum[xp::FirstSliceFace] / count[xp::FirstSliceFace], 80.0) << "first slice: bottom rows";
  EXPECT_LT(rowSum[xp::LastSliceFace] / count[xp::LastSliceFace], 40.0) << "last slice: top rows";
  // A mask of one face leaves the other face's rays in.
  const std::vector<uint8_t> firstOnly = coverage.Mask(cropped.planned, view, xp::FirstSliceFace);
  for (size_t i = 0; i < faces.size(); ++i)
    EXPECT_EQ(firstOnly[i], (faces[i] & xp::FirstSliceFace) == 0);
}

TEST(CTCoverage, LeavesOutOnlyTheEndFacesBeyondWhichTheXRayShowsAnatomy)
{
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const xp::Pose truth = xp::Pose::Parse("2,-1,1,1,-0.5,1", "truth");
  const Eigen::Isometry3d ctToRoom = xp::MisalignedCTToRoom(cropped.planned, truth, Eigen::Vector3d::Zero());
  const xp::CTCoverage coverage(cropped.volume, 2.0);
  const double minExcess = xp::StereoRegistrationSettings{}.coverageMinExcess;
  const std::vector<xp::RegistrationView> drrs = Simulate(cropped, truth, 11);      // the short CT's DRRs
  const std::vector<xp::RegistrationView> longer = Simulate(full, truth, 12);      // X-rays of the whole head
  const std::vector<xp::RegistrationView> asLong = Simulate(cropped, truth, 13);   // X-rays no longer than the CT
  const auto inverted = [](std::vector<uint16_t> image)
  {
    for (uint16_t& v : image)
      v = static_cast<uint16_t>(4095 - v); // log-converted polarity: attenuation bright
    return image;
  };
  for (size_t v = 0; v < drrs.size(); ++v)
  {
    const std::vector<uint8_t> faces = coverage.EndFaces(ctToRoom, drrs[v].view);
    for (const bool invert : { false, true })
    {
      const auto xray = [&](const std::vector<uint16_t>& image) { return invert ? inverted(image) : image; };
      const xp::EndFaceEvidence beyond = xp::MeasureAnatomyBeyondEndFaces(xray(longer[v].xray), drrs[v].xray, {}, faces, minExcess);
      EXPECT_EQ(beyond.facesToLeaveOut, xp::BothEndFaces) << "view " << v << (invert ? " inverted" : "");
      EXPECT_GT(std::min(beyond.excess[0], beyond.excess[1]), 0.2);
      const xp::EndFaceEvidence same = xp::MeasureAnatomyBeyondEndFaces(xray(asLong[v].xray), drrs[v].xray, {}, faces, minExcess);
      EXPECT_EQ(same.facesToLeaveOut, 0) << "view " << v << (invert ? " inverted" : "") << ": excess " << same.excess[0]
                                         << ", " << same.excess[1];
      // 0 (and NaN): always left out.
      for (const double always : { 0.0, std::nan("") })
        EXPECT_EQ(xp::MeasureAnatomyBeyondEndFaces(xray(asLong[v].xray), drrs[v].xray, {}, faces, always).facesToLeaveOut,
          xp::BothEndFaces);
    }
    // An X-ray-only object over a tenth of a face's rays (a frame, a rail) is not anatomy beyond it.
    std::vector<uint16_t> withObject = asLong[v].xray;
    long long marked = 0;
    const long long tenth = std::count_if(faces.begin(), faces.end(), [](uint8_t f) { return f & xp::FirstSliceFace; }) / 10;
    for (size_t i = 0; i < faces.size() && marked < tenth; ++i)
      if (faces[i] & xp::FirstSliceFace)
      {
        withObject[i] = static_cast<uint16_t>(withObject[i] / 4);
        ++marked;
      }
    EXPECT_EQ(xp::MeasureAnatomyBeyondEndFaces(withObject, drrs[v].xray, {}, faces, minExcess).facesToLeaveOut, 0);
    const std::vector<uint8_t> shorter(faces.begin(), faces.end() - 1);
    EXPECT_THROW(xp::MeasureAnatomyBeyondEndFaces(withObject, drrs[v].xray, {}, shorter, minExcess), xp::InputError);
  }
}

TEST(StereoRegistrationGate, ACTShorterThanTheFieldRegistersOnWhatItCovers)
{
  // X-rays of the whole head, a planning CT of its central 40 % of slices (the evaluation's
  // `truncated` case): the coverage mask keeps only the rays the CT explains.
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const xp::Pose truth = xp::Pose::Parse("3,-2,2,1,-1,1.5", "truth");
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(cropped.volume, cropped.planned, Eigen::Vector3d::Zero(), Simulate(full, truth, 6));
  EXPECT_TRUE(result.ok) << Described(result);
  EXPECT_LT((result.misalignment.translation - truth.translation).cwiseAbs().maxCoeff(), 1.2) << result.misalignment.ToString();
  EXPECT_LT(result.validFraction[0], 0.9);
  ASSERT_EQ(result.endFaces.size(), 2u);
  for (const xp::EndFaceEvidence& faces : result.endFaces)
    EXPECT_EQ(faces.facesToLeaveOut, xp::BothEndFaces);
}

TEST(StereoRegistrationGate, FailsWhenTheCTDoesNotCoverTheXRays)
{
  // The same without the coverage mask: the X-rays show anatomy the CT cannot explain at any
  // pose, and the gate's check of uncovered anatomy refuses the result.
  const Scene full;
  const Scene cropped(CentralSlices(full.ct));
  const xp::Pose truth = xp::Pose::Parse("3,-2,2,1,-1,1.5", "truth");
  xp::StereoRegistrationSettings settings;
  settings.coverageMask = false;
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(cropped.volume, cropped.planned, Eigen::Vector3d::Zero(), Simulate(full, truth, 6), settings);
  EXPECT_FALSE(result.ok) << result.misalignment.ToString();
  EXPECT_TRUE(FailedWith(result, xp::GateCode::UncoveredAnatomy)) << Described(result);
}

TEST(StereoRegistrationGate, TheHalvesOfAnAnatomyTenPercentLongerDisagree)
{
  // X-rays of the head 10 % longer along its slice axis (about the same centre), registered with
  // the head as it is: no rigid pose fits both ends, so each view's halves must end apart and the
  // gate fail the result for it. (The phantom's mask leaves few blanks: the halves each on their
  // own catch it too; the texture test above is the one the blanks decide.)
  const Scene planned;
  xp::CTVolumeData longer = planned.ct;
  longer.origin[2] -= 0.05 * longer.spacing[2] * (longer.dimensions[2] - 1);
  longer.spacing[2] *= 1.1;
  const Scene xrays(longer);
  ASSERT_LT((xrays.planned.translation() - planned.planned.translation()).norm(), 1e-9);
  const xp::Pose truth = xp::Pose::Parse("2,-3,1,1,-1,0.5", "truth");
  const xp::StereoRegistrationResult result =
    xp::RegisterStereo(planned.volume, planned.planned, Eigen::Vector3d::Zero(), Simulate(xrays, truth, 7));
  EXPECT_FALSE(result.ok) << result.misalignment.ToString();
  EXPECT_TRUE(FailedWith(result, xp::GateCode::HalvesDisagree)) << Described(result);
}

TEST(StereoRegistrationFormats, RawAndLogXRaysOfAnyDepthGiveTheSameAnswer)
{
  // The same X-rays as 12-bit raw transmission, 16-bit raw and 16-bit log (bright = attenuation):
  // ranks make them one image, so the three registrations agree, and the log one is read as such.
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  std::vector<xp::RegistrationView> raw12 = SimulateKV(scene, truth, 7, 256, 192);
  std::vector<xp::RegistrationView> raw16 = raw12, log16 = raw12;
  for (size_t v = 0; v < raw12.size(); ++v)
    for (size_t i = 0; i < raw12[v].xray.size(); ++i)
    {
      const double transmission = std::max(raw12[v].xray[i], uint16_t(1)) / 4095.0;
      raw16[v].xray[i] = static_cast<uint16_t>(std::lround(65535.0 * transmission));
      log16[v].xray[i] = static_cast<uint16_t>(std::lround(65535.0 * -std::log(transmission) / 9.0));
    }
  std::vector<xp::Pose> found;
  for (const std::vector<xp::RegistrationView>* views : { &raw12, &raw16, &log16 })
  {
    const xp::StereoRegistrationResult result = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), *views);
    EXPECT_TRUE(result.ok) << Described(result);
    ASSERT_EQ(result.xrayInverted.size(), 2u);
    for (bool inverted : result.xrayInverted)
      EXPECT_EQ(inverted, views == &log16) << "bright means attenuation in the log images only";
    EXPECT_LT((result.misalignment.translation - truth.translation).cwiseAbs().maxCoeff(), 0.5);
    found.push_back(result.misalignment);
  }
  for (size_t k = 1; k < found.size(); ++k)
    EXPECT_LT((found[k].translation - found[0].translation).norm(), 0.1) << "format " << k << " moved the answer";
}

TEST(StereoRegistrationFormats, DeadAndHotPixelsDoNotMoveTheAnswer)
{
  // One pixel in 10 stuck at black or white, as a worn panel or a log of too few quanta makes
  // them: the 3x3 median removes them before the ranks, the masks and the pose see the X-ray,
  // and keeps the edges where they are.
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("-3,4,-2,-1,1.5,1", "truth");
  const std::vector<xp::RegistrationView> clean = SimulateKV(scene, truth, 21, 256, 192);
  std::vector<xp::RegistrationView> stuck = clean;
  std::mt19937 random(5);
  std::uniform_int_distribution<int> draw(0, 19);
  for (xp::RegistrationView& item : stuck)
    for (uint16_t& value : item.xray)
    {
      const int d = draw(random);
      value = d == 0 ? 0 : (d == 1 ? 4095 : value);
    }
  const xp::StereoRegistrationResult reference = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), clean);
  const xp::StereoRegistrationResult result = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), stuck);
  ASSERT_TRUE(reference.ok) << Described(reference);
  EXPECT_TRUE(result.ok) << Described(result);
  EXPECT_LT((result.misalignment.translation - truth.translation).cwiseAbs().maxCoeff(), 0.5) << Described(result);
  EXPECT_LT((result.misalignment.translation - reference.misalignment.translation).norm(), 0.2) << Described(result);
  for (size_t v = 0; v < result.validFraction.size(); ++v)
    EXPECT_GT(result.validFraction[v], 0.8 * reference.validFraction[v]) << "view " << v << ": the outliers decided the mask";
}

TEST(StereoRegistrationInput, AnXRayOfAnotherSizeThanItsPanelIsRefusedNamingTheView)
{
  Scene scene;
  std::vector<xp::RegistrationView> views = Simulate(scene, xp::Pose(), 3);
  views[1].xray.pop_back();
  try
  {
    xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views);
    FAIL() << "a short X-ray was registered";
  }
  catch (const xp::InputError& error)
  {
    EXPECT_NE(std::string(error.what()).find("view " + views[1].view.name), std::string::npos) << error.what();
  }
}

TEST(StereoRegistrationGate, WhatNoRayOfTheCTMeetsDoesNotJudgeTheHeldOutPeak)
{
  // Rails across the open field, 10 px and more from the CT's shadow: a couch or a positioning
  // aid that the CT does not hold. No pose of this CT explains them, so the held-out check, which
  // keeps the shadow and a margin, must read the same leads with them as without.
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-3,1,1,-0.5,1", "truth");
  const std::vector<xp::RegistrationView> clean = SimulateKV(scene, truth, 9, 256, 192);
  std::vector<xp::RegistrationView> railed = clean;
  long long railPixels = 0;
  for (xp::RegistrationView& item : railed)
  {
    const int columns = item.view.Columns(), rows = item.view.Rows();
    std::vector<float> integral(item.xray.size());
    xp::RenderLineIntegrals(scene.volume, xp::MisalignedCTToRoom(scene.planned, truth, Eigen::Vector3d::Zero()),
      item.view.source, xp::DetectorGrid::TopRowFirst(item.view), nullptr, integral.data());
    std::vector<uint8_t> shadow(integral.size());
    for (size_t i = 0; i < integral.size(); ++i)
      shadow[i] = integral[i] > 0.0f;
    const std::vector<uint8_t> near = xp::DilateMask(shadow, columns, rows, 10);
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < columns; ++c)
      {
        const size_t i = static_cast<size_t>(r) * columns + c;
        if (!near[i] && (c / 6) % 2 == 0)
        {
          item.xray[i] = static_cast<uint16_t>(item.xray[i] / 2);
          ++railPixels;
        }
      }
  }
  ASSERT_GT(railPixels, 2000) << "the scene has no open field to put rails in";
  const xp::StereoRegistrationResult reference = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), clean);
  const xp::StereoRegistrationResult result = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), railed);
  ASSERT_TRUE(reference.ok) << Described(reference);
  EXPECT_LT((result.misalignment.translation - reference.misalignment.translation).norm(), 0.2) << Described(result);
  for (size_t k = 0; k < 6; ++k) // the translated neighbours' (the turned ones are not measured)
    EXPECT_NEAR(result.peakLeads[k], reference.peakLeads[k], 0.02) << "axis " << k / 2 << (k % 2 ? " +" : " -");
}

// The held-out peak check judges the translated neighbours; the turned ones are measured only
// when asked for (heldOutTurns), and then recorded beside them. On this rounded scene the turned
// neighbours lead least, so a margin taken over all twelve would be theirs. Not measuring them
// saves their six evaluations and changes nothing else.
TEST(StereoRegistrationGate, TheHeldOutMarginIsTheTranslatedNeighboursLeastLead)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-3,1,1,-0.5,1", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 9, 256, 192);
  xp::StereoRegistrationSettings turns;
  turns.heldOutTurns = true;
  EXPECT_FALSE(xp::StereoRegistrationSettings{}.heldOutTurns) << "the default";
  const xp::StereoRegistrationResult result = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, turns);
  const auto leads = result.peakLeads;
  const double translated = *std::min_element(leads.begin(), leads.begin() + 6);
  const double turned = *std::min_element(leads.begin() + 6, leads.end());
  ASSERT_LT(turned, translated) << "the scene's turned neighbours must lead least for this test to tell the two apart";
  EXPECT_DOUBLE_EQ(result.peakMargin, translated) << Described(result);
  EXPECT_TRUE(result.ok) << Described(result);

  const xp::StereoRegistrationResult plain = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views);
  EXPECT_EQ(plain.evaluations, result.evaluations - 6) << "the six turned neighbours not evaluated";
  EXPECT_EQ(plain.misalignment.Parameters(), result.misalignment.Parameters()) << "the same registration";
  EXPECT_EQ(plain.ok, result.ok);
  EXPECT_DOUBLE_EQ(plain.peakMargin, result.peakMargin);
  for (size_t k = 0; k < 12; ++k)
  {
    if (k < 6)
      EXPECT_DOUBLE_EQ(plain.peakLeads[k], leads[k]) << k;
    else
      EXPECT_TRUE(std::isnan(plain.peakLeads[k])) << k << ": " << plain.peakLeads[k];
  }
}

#include "xpCudaRayCaster.h"

namespace
{

// On a GPU the objective is measured there from the second evaluation on (rays, histograms and
// MI): it gives the CPU's MI at every pose, and the DRRs fetched afterwards are the last pose's.
TEST(StereoSimilarityOnGPU, MeasuresTheCPUsObjective)
{
  std::string reason;
  if (!xp::cuda::Available(&reason))
    GTEST_SKIP() << "no GPU here: " << reason;
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-1,1,1,-0.5,1", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 3, 256, 192);
  xp::StereoSimilarity cpu(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32);
  xp::StereoSimilarity gpu(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, 32);
  gpu.SetDevice(xp::ComputeDevice::CUDA);
  for (const char* text : { "0,0,0,0,0,0", "2,-1,1,1,-0.5,1", "3,0,-1,0,1,-1", "-4,2,2,2,0,0" })
  {
    const xp::Pose pose = xp::Pose::Parse(text, "pose");
    const double expected = cpu.Evaluate(pose), measured = gpu.Evaluate(pose);
    EXPECT_NEAR(measured, expected, 0.005 * expected) << text;
    for (size_t v = 0; v < views.size(); ++v)
    {
      EXPECT_NEAR(gpu.LastMutualInformation()[v], cpu.LastMutualInformation()[v], 0.005 * cpu.LastMutualInformation()[v]);
      const std::vector<uint16_t>& a = cpu.LastDRRLevels(v);
      const std::vector<uint16_t>& b = gpu.LastDRRLevels(v);
      long long apart = 0;
      for (size_t i = 0; i < a.size(); ++i)
        apart += std::abs(int(a[i]) - int(b[i])) > 2;
      EXPECT_LE(apart, static_cast<long long>(a.size() / 1000)) << "view " << v << " at " << text;
    }
  }
}

// The same registration on both devices: the same pose within 0.05 mm and 0.05 degree, the same
// verdict; also with the refinement's objective measured on the GPU (no high-pass, every ray),
// whose DRRs the views' checks then fetch from threads of their own.
TEST(StereoRegistrationOnGPU, FindsTheCPUsPose)
{
  std::string reason;
  if (!xp::cuda::Available(&reason))
    GTEST_SKIP() << "no GPU here: " << reason;
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::vector<xp::RegistrationView> views = SimulateKV(scene, truth, 5, 256, 192);
  for (bool refinementOnGPU : { false, true })
  {
    xp::StereoRegistrationSettings settings;
    settings.finePlaneStep = 1; // the GPU samples every voxel plane: the CPU the same ones
    if (refinementOnGPU)
    {
      settings.fineHighPassMM = 0.0;
      settings.fineRenderStride = 1;
    }
    const xp::StereoRegistrationResult cpu = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
    settings.device = xp::ComputeDevice::CUDA;
    const xp::StereoRegistrationResult gpu = xp::RegisterStereo(scene.volume, scene.planned, Eigen::Vector3d::Zero(), views, settings);
    const std::string against = Described(gpu) + " against " + Described(cpu) + (refinementOnGPU ? ", refinement on the GPU" : "");
    EXPECT_EQ(cpu.device, "cpu");
    EXPECT_EQ(gpu.device.rfind("cuda (", 0), 0u) << gpu.device;
    EXPECT_EQ(gpu.ok, cpu.ok) << against;
    EXPECT_LE((gpu.misalignment.translation - cpu.misalignment.translation).norm(), 0.05) << against;
    EXPECT_LE(std::abs(gpu.misalignment.pitch - cpu.misalignment.pitch), 0.05) << against;
    EXPECT_LE(std::abs(gpu.misalignment.roll - cpu.misalignment.roll), 0.05) << against;
    EXPECT_LE(std::abs(gpu.misalignment.yaw - cpu.misalignment.yaw), 0.05) << against;
    for (size_t v = 0; v < cpu.drrs.size(); ++v)
      EXPECT_EQ(gpu.drrs[v].size(), cpu.drrs[v].size());
    EXPECT_NEAR(gpu.explained[0], cpu.explained[0], 0.01) << against;
  }
}

} // namespace


// StereoRegistrationInStages: another CT compared after the pre-alignment leaves the registration
// as RegisterStereo makes it (the same pose, evaluations and DRRs: its renderings count to none
// of its stages); this CT itself at its pre-aligned pose gives PreAlignedCT's objective (the
// pose's frame), two more rounds of the pre-alignment stay near it, and from 4 mm off come back.
TEST(StereoRegistrationInStages, ComparingAnotherCTLeavesTheRegistrationAsItWas)
{
  const Scene scene;
  const xp::Pose truth = xp::Pose::Parse("2,-1.5,1,0.5,-0.5,1", "truth");
  const std::vector<xp::RegistrationView> views = Simulate(scene, truth, 11);
  const Eigen::Vector3d isocenter(5.0, -3.0, 2.0); // off the volume's centre: a frame mixed up moves the pose
  const xp::StereoRegistrationResult whole = xp::RegisterStereo(scene.volume, scene.planned, isocenter, views);
  xp::StereoRegistrationInStages stages(scene.volume, scene.planned, isocenter, views);
  const xp::PreAlignedCT aligned = stages.PreAlign();
  EXPECT_DOUBLE_EQ(stages.HighPassedObjectiveOf(scene.volume, aligned.prealignment.pose, 0), aligned.highPassedObjective);
  EXPECT_NEAR(stages.HighPassedObjectiveOf(scene.volume, aligned.prealignment.pose, 2), aligned.highPassedObjective,
    0.05 * aligned.highPassedObjective) << "two more rounds from the pre-alignment stay near it";
  xp::Pose away = aligned.prealignment.pose;
  away.translation.z() += 4.0;
  const double awayValue = stages.HighPassedObjectiveOf(scene.volume, away, 0);
  EXPECT_LT(awayValue, aligned.highPassedObjective) << "4 mm off the pre-alignment";
  const double cameBack = stages.HighPassedObjectiveOf(scene.volume, away, 2);
  std::printf("high-passed objective: %.4f at the pre-alignment, %.4f 4 mm off it, %.4f after two rounds from there\n",
    aligned.highPassedObjective, awayValue, cameBack);
  EXPECT_GT(cameBack, awayValue) << "two rounds of the pre-alignment come back";
  const xp::StereoRegistrationResult finished = stages.Finish();
  EXPECT_EQ(finished.misalignment.ToString(), whole.misalignment.ToString());
  EXPECT_EQ(finished.evaluations, whole.evaluations);
  EXPECT_EQ(finished.drrCount, whole.drrCount);
  EXPECT_EQ(finished.ok, whole.ok);
}

// The phantom's CT holds a head rest and a couch top; X-rays that show them (a renderer of that
// CT) or not (a room): with chooseTable the registration renders the CT the X-rays show, and
// says why. Fails if the choice ignores the X-rays, or if the table found or the objectives go
// unreported.
TEST(vtkXPStereoRegistrationFilter, ChoosesTheCTWithOrWithoutItsTableByTheXRays)
{
  const xp::CTVolumeData withTable = xp::MakeHeadPhantom(2.0);
  xp::CTVolumeData body = withTable;
  const std::vector<uint8_t> inBody = xp::SegmentBody(body.hounsfield.data(), body.dimensions);
  long long tableVoxels = 0;
  for (size_t i = 0; i < inBody.size(); ++i)
    tableVoxels += !inBody[i] && body.hounsfield[i] > xp::BodyMaskSettings{}.tableHU;
  xp::ClearOutsideBody(body.hounsfield.data(), inBody);
  ASSERT_GT(tableVoxels, 10000) << "the phantom's head rest and couch top";
  const vtkSmartPointer<vtkImageData> ct = CTImage(withTable);
  const xp::Pose truth = xp::Pose::Parse("3,-2,2,1,-1,1.5", "truth");
  for (const bool shown : { true, false })
  {
    const Scene scene(shown ? withTable : body);
    vtkNew<vtkXPStereoRegistrationFilter> registration;
    registration->SetCTData(ct);
    xp::StereoGeometry geometry;
    for (const xp::RegistrationView& item : Simulate(scene, truth, 7))
    {
      geometry.views.push_back(item.view);
      registration->AddXRayData(XRayImage(item));
    }
    registration->SetGeometry(geometry);
    xp::StereoRegistrationSettings settings;
    settings.chooseTable = true;
    registration->SetSettings(settings);
    registration->Update();
    const xp::StereoRegistrationResult& result = registration->GetResult();
    ASSERT_TRUE(result.table.has_value()) << "chooseTable reports its choice";
    EXPECT_DOUBLE_EQ(result.table->tableCM3, tableVoxels * 8.0 / 1000.0) << "2 mm voxels";
    EXPECT_EQ(result.table->keptTable, shown) << (shown ? "X-rays that show the table" : "X-rays without it")
                                              << ": with " << result.table->withTable << ", body alone " << result.table->bodyOnly;
    EXPECT_EQ(result.table->withTable > result.table->bodyOnly, shown);
    EXPECT_TRUE(result.ok) << Described(result);
    EXPECT_LT((result.misalignment.translation - truth.translation).norm(), 0.5) << (shown ? "shown" : "not shown");
  }
}

namespace
{

/** The refinement's objective (ranks, high-passed at 5 mm) on kV X-rays of the scene at `truth`,
 *  and a refinement's steps and stops on the scene's 2 mm voxels. */
std::unique_ptr<xp::StereoSimilarity> RefinementObjective(const Scene& scene, const xp::Pose& truth, unsigned seed)
{
  return std::make_unique<xp::StereoSimilarity>(scene.volume, scene.planned, Eigen::Vector3d::Zero(),
    SimulateKV(scene, truth, seed, 256, 192), 32, xp::SimilarityLevels{ true, 5.0, 0.0 });
}

xp::PoseOptimizerSettings RefinementSteps()
{
  xp::PoseOptimizerSettings settings;
  settings.initialStepMM = 0.5;
  settings.initialStepDegrees = 0.3;
  settings.toleranceMM = 0.05;
  settings.toleranceDegrees = 0.03;
  return settings;
}

} // namespace

// The linearized refinement (xpLinearizedRefinement.h) on the refinement's own objective (ranks,
// high-passed) from 0.6 mm and 0.4 degree off on every axis: it ends where a simplex that
// renders every evaluation ends, within its stops, on a sixth of the renderings or fewer, every
// measured pose counted once. A slope with the wrong sign (or on the wrong axis) climbs the model
// away from the peak: the round's end measures lower and the refinement stays at its start.
TEST(LinearizedRefinement, EndsWhereTheRenderingSimplexEnds)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::unique_ptr<xp::StereoSimilarity> objective = RefinementObjective(scene, truth, 3);
  xp::StereoSimilarity& similarity = *objective;
  xp::PoseOptimizerSettings settings = RefinementSteps();
  settings.maxEvaluations = 400;
  settings.maxRestarts = 0;
  const xp::Pose start = xp::Pose::Parse("4.6,-3.6,2.6,1.9,-1.4,2.4", "start");
  int measured = 0;
  const auto evaluate = [&](const xp::Pose& p)
  {
    ++measured;
    return similarity.Evaluate(p);
  };
  const xp::LinearizedRefinementResult linearized = xp::MaximizeOnLinearizedDRRs(similarity, evaluate, start, settings);
  int rendering = 0;
  const xp::PoseOptimizerResult simplex = xp::MaximizePose(
    [&](const xp::Pose& p)
    {
      ++rendering;
      return similarity.Evaluate(p);
    },
    start, settings);
  std::printf("linearized: %s, %d rounds, %d evaluations, %d of the model (%s); simplex: %s, %d evaluations\n",
    linearized.pose.ToString().c_str(), linearized.rounds, linearized.evaluations, linearized.modelEvaluations,
    linearized.stopReason.c_str(), simplex.pose.ToString().c_str(), simplex.evaluations);
  EXPECT_TRUE(linearized.converged) << linearized.stopReason;
  EXPECT_FALSE(linearized.reachedTarget);
  EXPECT_EQ(linearized.evaluations, measured);
  EXPECT_EQ(linearized.evaluations, 1 + 13 * linearized.rounds);
  EXPECT_GT(linearized.modelEvaluations, linearized.evaluations);
  EXPECT_DOUBLE_EQ(linearized.value, similarity.Evaluate(linearized.pose));
  EXPECT_GE(linearized.value, 0.98 * simplex.value);
  EXPECT_LT((linearized.pose.translation - simplex.pose.translation).norm(), 0.2);
  EXPECT_LT((linearized.pose.translation - truth.translation).norm(), 0.3);
  for (const auto& [found, expected] : { std::make_pair(linearized.pose.pitch, truth.pitch),
         std::make_pair(linearized.pose.roll, truth.roll), std::make_pair(linearized.pose.yaw, truth.yaw) })
    EXPECT_NEAR(found, expected, 0.15);
  EXPECT_LT(linearized.evaluations, rendering);
}

// The target (PoseOptimizerSettings::stopWhen) is asked at every measured pose, slopes included,
// and the first pose that reaches it is the result; the trust region bounds each round's climb;
// settings the climb cannot run with are refused.
TEST(LinearizedRefinement, StopsAtTheTargetAndStaysWithinItsTrustRegion)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("4,-3,2,1.5,-1,2", "truth");
  const std::unique_ptr<xp::StereoSimilarity> objective = RefinementObjective(scene, truth, 4);
  xp::StereoSimilarity& similarity = *objective;
  xp::PoseOptimizerSettings settings = RefinementSteps();
  const xp::Pose start = xp::Pose::Parse("6,-3,2,1.5,-1,2", "start");
  std::vector<xp::Pose> poses;
  const auto evaluate = [&](const xp::Pose& p)
  {
    poses.push_back(p);
    return similarity.Evaluate(p);
  };
  xp::LinearizedClimb oneRound;
  oneRound.maxRounds = 1;
  oneRound.trustSteps = 1.0;
  const xp::LinearizedRefinementResult first = xp::MaximizeOnLinearizedDRRs(similarity, evaluate, start, settings, oneRound);
  EXPECT_FALSE(first.converged) << "one round from 2 mm off, within 0.5 mm: still climbing";
  EXPECT_EQ(first.stopReason, "rounds");
  EXPECT_EQ(first.evaluations, 14);
  for (const xp::Pose& p : poses)
    EXPECT_LE((p.translation - start.translation).cwiseAbs().maxCoeff(), 0.5 + 1e-9);
  EXPECT_LT(first.pose.translation[0], start.translation[0] - 0.1) << "the round climbs toward the peak at 4 mm";

  poses.clear();
  settings.stopWhen = [&](const xp::Pose& p, double) { return poses.size() == 5; };
  const xp::LinearizedRefinementResult early = xp::MaximizeOnLinearizedDRRs(similarity, evaluate, start, settings);
  EXPECT_TRUE(early.reachedTarget);
  EXPECT_EQ(early.evaluations, 5);
  EXPECT_EQ(early.stopReason, "target");
  EXPECT_EQ(early.pose.ToString(), poses.back().ToString());

  settings.stopWhen = nullptr;
  xp::PoseOptimizerSettings still = settings;
  still.initialStepDegrees = 0.0;
  EXPECT_THROW(xp::MaximizeOnLinearizedDRRs(similarity, evaluate, start, still), xp::Error);
  xp::LinearizedClimb none;
  none.maxRounds = 0;
  EXPECT_THROW(xp::MaximizeOnLinearizedDRRs(similarity, evaluate, start, settings, none), xp::Error);
}

// The model's objective is the similarity's own measure of given line integrals: those of the
// last rendering give the objective Evaluate gave, and the next evaluation is unaffected.
TEST(StereoSimilarity, MeasuresGivenLineIntegralsAsItsOwnRendering)
{
  Scene scene;
  const xp::Pose truth = xp::Pose::Parse("1,-1,0.5,0.5,0,0", "truth");
  xp::StereoSimilarity similarity(scene.volume, scene.planned, Eigen::Vector3d::Zero(), SimulateKV(scene, truth, 5, 128, 96),
    32, xp::SimilarityLevels{ true, 5.0, 0.0 });
  const double atTruth = similarity.Evaluate(truth);
  std::vector<std::vector<float>> integrals;
  for (size_t v = 0; v < similarity.Views().size(); ++v)
    integrals.push_back(similarity.LastIntegrals(v));
  const double elsewhere = similarity.Evaluate(xp::Pose{});
  EXPECT_LT(elsewhere, atTruth);
  EXPECT_DOUBLE_EQ(similarity.ObjectiveOf(integrals), atTruth);
  EXPECT_DOUBLE_EQ(similarity.Evaluate(xp::Pose{}), elsewhere);
  integrals.pop_back();
  EXPECT_THROW(similarity.ObjectiveOf(integrals), xp::Error);
}
