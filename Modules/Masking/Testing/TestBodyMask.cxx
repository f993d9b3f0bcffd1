// The body segmentation that takes the CT's table out of simulations and DRRs.
#include "xpBodyMask.h"

#include <gtest/gtest.h>

#include <cmath>

namespace
{

/** 80 x 80 x 10 voxels: a body (radius 25, 20 HU) with a gas cavity, a thin table shell (4 voxels
 *  thick, -100 HU) under it across the whole width after an air gap, and an arm (radius 8) beside it. */
struct Scene
{
  Eigen::Vector3i dims{ 80, 80, 10 };
  std::vector<float> hu;

  Scene()
    : hu(static_cast<size_t>(80) * 80 * 10, -1000.0f)
  {
    for (int k = 0; k < dims[2]; ++k)
      for (int j = 0; j < dims[1]; ++j)
        for (int i = 0; i < dims[0]; ++i)
        {
          float& v = hu[Index(i, j, k)];
          const double r = std::hypot(i - 35.0, j - 35.0);
          if (r < 25)
            v = r < 6 ? -1000.0f : 20.0f; // the cavity: gas inside the body
          if (j >= 64 && j < 68)
            v = -100.0f;                  // table shell, 4 voxels below the body's lowest row (59)
          if (std::hypot(i - 70.0, j - 35.0) < 8)
            v = 40.0f;                    // an arm, apart from the body
        }
  }
  size_t Index(int i, int j, int k) const { return (static_cast<size_t>(k) * dims[1] + j) * dims[0] + i; }
};

TEST(BodyMask, RemovesTheTableKeepsCavitiesAndLimbs)
{
  Scene scene;
  xp::BodyMaskSettings settings;
  settings.minComponentFraction = 0.02;
  const std::vector<uint8_t> body = xp::SegmentBody(scene.hu.data(), scene.dims, settings);
  EXPECT_TRUE(body[scene.Index(35, 35, 5)]) << "the cavity inside the body is body";
  EXPECT_TRUE(body[scene.Index(35, 15, 5)]) << "tissue";
  EXPECT_TRUE(body[scene.Index(35, 59, 5)]) << "the body's lowest row";
  EXPECT_TRUE(body[scene.Index(70, 35, 5)]) << "a limb of a tenth of the body's volume stays";
  for (int i = 0; i < 80; i += 7)
    EXPECT_FALSE(body[scene.Index(i, 66, 5)]) << "the table shell at column " << i;
  EXPECT_FALSE(body[scene.Index(2, 2, 5)]) << "air outside";

  std::vector<float> cleared = scene.hu;
  EXPECT_EQ(xp::ClearOutsideBody(cleared.data(), body), 80 * 4 * 10);
  EXPECT_EQ(cleared[scene.Index(30, 66, 3)], -1000.0f);
  EXPECT_EQ(cleared[scene.Index(35, 35, 3)], -1000.0f) << "the cavity keeps its own value";
  EXPECT_EQ(cleared[scene.Index(35, 20, 3)], 20.0f);
}

TEST(BodyMask, ComponentsBelowTheFractionGo)
{
  Scene scene;
  xp::BodyMaskSettings settings;
  settings.minComponentFraction = 0.2;
  const std::vector<uint8_t> body = xp::SegmentBody(scene.hu.data(), scene.dims, settings);
  EXPECT_FALSE(body[scene.Index(70, 35, 5)]);
  EXPECT_TRUE(body[scene.Index(35, 15, 5)]);
}

TEST(BodyMask, RefusesACTWithoutTissue)
{
  std::vector<float> air(1000, -1000.0f);
  EXPECT_THROW(xp::SegmentBody(air.data(), Eigen::Vector3i(10, 10, 10)), std::exception);
}

} // namespace
