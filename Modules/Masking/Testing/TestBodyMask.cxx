// The body segmentation that takes the CT's table out of simulations and DRRs.
#include "xpBodyMask.h"

#include <gtest/gtest.h>
#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <tuple>

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


/** SegmentBody as first written, voxel by voxel: a naive square dilation, components labelled by
 *  a voxel walk, cavities filled per slice. The fast version must give the same voxels. */
std::vector<uint8_t> ReferenceBody(const std::vector<float>& hu, const Eigen::Vector3i& d, const xp::BodyMaskSettings& settings)
{
  const long long nx = d[0], ny = d[1], nz = d[2], slice = nx * ny, count = slice * nz;
  const auto dilate = [&](std::vector<uint8_t>& v, int radius)
  {
    std::vector<uint8_t> out(v.size());
    for (long long z = 0; z < nz; ++z) // rows first, then columns, as the separable original
      for (long long y = 0; y < ny; ++y)
        for (long long x = 0; x < nx; ++x)
        {
          uint8_t any = 0;
          for (long long j = std::max(0LL, x - radius); j <= std::min(nx - 1, x + radius); ++j)
            any |= v[z * slice + y * nx + j] != 0;
          out[z * slice + y * nx + x] = any;
        }
    for (long long z = 0; z < nz; ++z)
      for (long long y = 0; y < ny; ++y)
        for (long long x = 0; x < nx; ++x)
        {
          uint8_t any = 0;
          for (long long j = std::max(0LL, y - radius); j <= std::min(ny - 1, y + radius); ++j)
            any |= out[z * slice + j * nx + x];
          v[z * slice + y * nx + x] = any;
        }
  };
  std::vector<uint8_t> tissue(count), core(count);
  for (long long i = 0; i < count; ++i)
    tissue[i] = hu[i] > settings.thresholdHU, core[i] = !tissue[i];
  dilate(core, settings.openingRadius);
  for (uint8_t& v : core)
    v = !v;
  std::vector<int> label(count, 0);
  std::vector<long long> sizes;
  for (long long start = 0; start < count; ++start)
  {
    if (!core[start] || label[start])
      continue;
    std::vector<long long> stack{ start };
    label[start] = static_cast<int>(sizes.size()) + 1;
    long long size = 0;
    while (!stack.empty())
    {
      const long long v = stack.back();
      stack.pop_back();
      ++size;
      const long long x = v % nx, y = (v / nx) % ny, z = v / slice;
      for (const long long n : { x > 0 ? v - 1 : -1, x + 1 < nx ? v + 1 : -1, y > 0 ? v - nx : -1, y + 1 < ny ? v + nx : -1,
             z > 0 ? v - slice : -1, z + 1 < nz ? v + slice : -1 })
        if (n >= 0 && core[n] && !label[n])
          label[n] = label[start], stack.push_back(n);
    }
    sizes.push_back(size);
  }
  if (sizes.empty())
    throw std::runtime_error("no core");
  const long long largest = *std::max_element(sizes.begin(), sizes.end());
  std::vector<uint8_t> body(count);
  for (long long i = 0; i < count; ++i)
    body[i] = label[i] > 0 && sizes[label[i] - 1] >= settings.minComponentFraction * largest;
  dilate(body, settings.openingRadius + 1);
  for (long long i = 0; i < count; ++i)
    body[i] = body[i] && tissue[i];
  for (long long z = 0; z < nz; ++z) // what the slice border's air cannot reach is body
  {
    std::vector<uint8_t> outside(slice, 0);
    std::vector<long long> stack;
    for (long long p = 0; p < slice; ++p)
      if (p % nx == 0 || p % nx == nx - 1 || p / nx == 0 || p / nx == ny - 1)
        stack.push_back(p);
    while (!stack.empty())
    {
      const long long p = stack.back();
      stack.pop_back();
      if (body[z * slice + p] || outside[p])
        continue;
      outside[p] = 1;
      const long long x = p % nx, y = p / nx;
      if (x > 0) stack.push_back(p - 1);
      if (x + 1 < nx) stack.push_back(p + 1);
      if (y > 0) stack.push_back(p - nx);
      if (y + 1 < ny) stack.push_back(p + nx);
    }
    for (long long p = 0; p < slice; ++p)
      body[z * slice + p] = !outside[p];
  }
  if (settings.dilation > 0)
    dilate(body, settings.dilation);
  return body;
}

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

// Random blobs and shells (seeded): components that meet only through a slice or around a bend,
// cavities, pieces near the fraction. The fast segmentation (runs joined by union-find, sliding
// dilations, slices on all threads) gives the reference's voxels, bit for bit, for several
// radii and fractions.
TEST(BodyMask, MatchesTheVoxelByVoxelReference)
{
  const Eigen::Vector3i dims(47, 39, 13);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int scene = 0; scene < 4; ++scene)
  {
    std::vector<float> hu(static_cast<size_t>(dims.prod()), -1000.0f);
    for (int blob = 0; blob < 14; ++blob)
    {
      const Eigen::Vector3d centre(unit(random) * dims[0], unit(random) * dims[1], unit(random) * dims[2]);
      const double radius = 1.5 + 7.0 * unit(random), shell = unit(random) < 0.3 ? 1.5 : radius;
      const float value = unit(random) < 0.2 ? -600.0f : 40.0f;
      for (int k = 0; k < dims[2]; ++k)
        for (int j = 0; j < dims[1]; ++j)
          for (int i = 0; i < dims[0]; ++i)
          {
            const double r = (Eigen::Vector3d(i, j, k) - centre).norm();
            if (r < radius && r > radius - shell)
              hu[(static_cast<size_t>(k) * dims[1] + j) * dims[0] + i] = value;
          }
    }
    for (const auto& [opening, fraction, dilation] : { std::tuple{ 3, 0.02, 1 }, std::tuple{ 1, 0.3, 0 }, std::tuple{ 2, 0.1, 2 } })
    {
      xp::BodyMaskSettings settings;
      settings.openingRadius = opening;
      settings.minComponentFraction = fraction;
      settings.dilation = dilation;
      std::vector<uint8_t> expected;
      try
      {
        expected = ReferenceBody(hu, dims, settings);
      }
      catch (const std::runtime_error&) // no core left
      {
        EXPECT_THROW(xp::SegmentBody(hu.data(), dims, settings), std::exception);
        continue;
      }
      const std::vector<uint8_t> body = xp::SegmentBody(hu.data(), dims, settings);
      ASSERT_EQ(body.size(), expected.size());
      EXPECT_TRUE(body == expected) << "scene " << scene << ", opening " << opening << ", fraction " << fraction << ": "
                                    << std::count(body.begin(), body.end(), 1) << " voxels against "
                                    << std::count(expected.begin(), expected.end(), 1);
      EXPECT_GT(std::count(body.begin(), body.end(), 1), 0);
    }
  }
}

// A CT read as 16-bit HU is segmented on its own values: BodyOf gives the voxels and the table's
// count that the float copy gives, and BodyOnly the same cleared copy from either type.
TEST(BodyMask, A16BitCTIsSegmentedAsItsFloatCopy)
{
  Scene scene; // its table shell (-100 HU) is denser than tableHU
  const auto image = [&](int type)
  {
    auto ct = vtkSmartPointer<vtkImageData>::New();
    ct->SetDimensions(scene.dims[0], scene.dims[1], scene.dims[2]);
    ct->AllocateScalars(type, 1);
    for (vtkIdType i = 0; i < ct->GetNumberOfPoints(); ++i)
      ct->GetPointData()->GetScalars()->SetTuple1(i, scene.hu[static_cast<size_t>(i)]);
    return ct;
  };
  const vtkSmartPointer<vtkImageData> shortCT = image(VTK_SHORT), floatCT = image(VTK_FLOAT);
  const xp::BodyVoxels fromShort = xp::BodyOf(shortCT), fromFloat = xp::BodyOf(floatCT);
  EXPECT_TRUE(fromShort.inBody == xp::SegmentBody(scene.hu.data(), scene.dims));
  EXPECT_TRUE(fromShort.inBody == fromFloat.inBody);
  EXPECT_EQ(fromShort.tableVoxels, 80 * 4 * 10);
  EXPECT_EQ(fromFloat.tableVoxels, fromShort.tableVoxels);
  long long removed = 0, table = 0;
  const vtkSmartPointer<vtkImageData> body = xp::BodyOnly(shortCT, {}, &removed, &table);
  EXPECT_EQ(table, fromShort.tableVoxels);
  EXPECT_EQ(removed, 80 * 4 * 10);
  std::vector<float> cleared = scene.hu;
  xp::ClearOutsideBody(cleared.data(), fromShort.inBody);
  const float* values = static_cast<const float*>(body->GetScalarPointer());
  EXPECT_TRUE(std::equal(cleared.begin(), cleared.end(), values));
}

TEST(BodyMask, RefusesACTWithoutTissue)
{
  std::vector<float> air(1000, -1000.0f);
  EXPECT_THROW(xp::SegmentBody(air.data(), Eigen::Vector3i(10, 10, 10)), std::exception);
}

} // namespace
