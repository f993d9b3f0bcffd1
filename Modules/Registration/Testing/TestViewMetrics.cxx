// Each image metric of a view on its own, without a projector: an X-ray made from known line
// integrals, measured against the same integrals, against them shifted, and inside a mask.
#include "xpImageLevels.h"
#include "xpRayCaster.h"
#include "xpStereoSimilarity.h"
#include "xpViewMetrics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{

constexpr int Columns = 64, Rows = 48;

/** Line integrals of a few overlapping blobs (more matter: a larger integral), moved by `shift`
 *  columns. */
std::vector<float> Integrals(double shift)
{
  std::vector<float> integrals(Columns * Rows);
  for (int r = 0; r < Rows; ++r)
    for (int c = 0; c < Columns; ++c)
    {
      const double x = c - shift;
      const double blobs = 2.0 * std::exp(-((x - 20) * (x - 20) + (r - 20) * (r - 20)) / 60.0) +
        1.2 * std::exp(-((x - 42) * (x - 42) + (r - 30) * (r - 30)) / 30.0) + 0.4 * std::sin(0.3 * x) * std::cos(0.25 * r);
      integrals[static_cast<size_t>(r) * Columns + c] = static_cast<float>(1.0 + blobs);
    }
  return integrals;
}

/** The X-ray a detector reads from those integrals: transmission, 12 bits, every pixel. */
xp::RegistrationView XRayOf(const std::vector<float>& integrals, std::vector<uint8_t> mask = {})
{
  xp::RegistrationView item;
  item.view.size = Eigen::Vector2i(Columns, Rows);
  item.view.pixelSpacing = Eigen::Vector2d(1.0, 1.0);
  item.xray.resize(integrals.size());
  xp::LineIntegralsTo12Bit(integrals.data(), nullptr, static_cast<long long>(integrals.size()), item.xray.data());
  item.mask = std::move(mask);
  return item;
}

TEST(MutualInformationMetric, PeaksWhereTheDRRIsTheXRaysOwnAndIgnoresMaskedPixels)
{
  const std::vector<float> truth = Integrals(0.0);
  std::vector<uint8_t> mask(truth.size(), 1);
  for (int r = 0; r < Rows; ++r)
    for (int c = 50; c < Columns; ++c)
      mask[static_cast<size_t>(r) * Columns + c] = 0; // the right strip left out
  const xp::RegistrationView item = XRayOf(truth, mask);
  for (bool equalize : { true, false })
  {
    const xp::PreparedXRay prepared = xp::PrepareXRay(item, { equalize, 0.0, 0.0 });
    xp::MutualInformationMetric metric(
      item.mask.data(), Columns, Rows, equalize ? prepared.levels : item.xray, 32, equalize, 0.0);
    const double atTruth = metric.Measure(truth);
    EXPECT_GT(atTruth, metric.Measure(Integrals(2.0)) + 0.05) << "equalize " << equalize;
    EXPECT_GT(metric.Measure(Integrals(2.0)), metric.Measure(Integrals(6.0))) << "farther is worse";
    // What lies under the mask's zeros changes nothing.
    std::vector<float> outside = truth;
    for (size_t i = 0; i < outside.size(); ++i)
      if (!mask[i])
        outside[i] = 100.0f;
    EXPECT_DOUBLE_EQ(metric.Measure(outside), atTruth) << "equalize " << equalize;
    // Without equalisation the DRR's levels are its 12-bit transmission, 0 where masked.
    if (!equalize)
    {
      std::vector<uint16_t> transmission(truth.size());
      xp::LineIntegralsTo12Bit(truth.data(), mask.data(), static_cast<long long>(truth.size()), transmission.data());
      metric.Measure(truth);
      EXPECT_EQ(metric.DRRLevels(), transmission);
    }
  }
}

TEST(MutualInformationMetric, FixesItsLevelsAtTheFirstMeasure)
{
  const std::vector<float> truth = Integrals(0.0);
  const xp::RegistrationView item = XRayOf(truth);
  const xp::PreparedXRay prepared = xp::PrepareXRay(item, { true, 0.0, 0.0 });
  xp::MutualInformationMetric metric(nullptr, Columns, Rows, prepared.levels, 32, true, 0.0);
  EXPECT_TRUE(metric.IntegralLevels().Empty());
  metric.Measure(truth);
  const std::vector<uint16_t> first = metric.DRRLevels();
  // Twice the matter everywhere: the levels of the first measure map it higher, not to the same ranks.
  std::vector<float> doubled = truth;
  for (float& value : doubled)
    value *= 2.0f;
  metric.Measure(doubled);
  EXPECT_NE(metric.DRRLevels(), first);
  metric.SetDRRLevels(truth);
  EXPECT_EQ(metric.DRRLevels(), first) << "SetDRRLevels ranks as the first measure did (no high-pass)";
}

TEST(CorrelationMetric, FollowsTheStructureWithMoreMatterDark)
{
  const std::vector<float> truth = Integrals(0.0);
  const xp::RegistrationView item = XRayOf(truth);
  const xp::PreparedXRay prepared = xp::PrepareXRay(item, { true, 0.0, 8.0 });
  ASSERT_EQ(prepared.structure.size(), truth.size());
  xp::CorrelationMetric metric(nullptr, Columns, Rows, prepared.structure, 8.0);
  const double atTruth = metric.Measure(truth);
  EXPECT_GT(atTruth, 0.7) << "the X-ray's ranks (a monotone map of the integrals, not a linear one) against the DRR's negated integrals";
  EXPECT_GT(atTruth, metric.Measure(Integrals(3.0)) + 0.1);
  std::vector<float> inverted = truth;
  for (float& value : inverted)
    value = 4.0f - value; // less matter where there was more: the sign flips
  EXPECT_LT(metric.Measure(inverted), -0.7);
}

} // namespace
