// The ray caster against analytic line integrals (RTK's approach): a box and a sphere of
// constant mu, chord lengths known in closed form.
#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpRayCaster.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdio>
#include <functional>
#include <set>
#include <vector>

namespace
{

constexpr double MuWater = 0.02;

/** A cubic volume of n^3 voxels of `spacing` mm centred on the origin, HU from a function of position. */
xp::AttenuationVolume MakeVolume(
  int n, const std::function<double(const Eigen::Vector3d&)>& fractionInside, double spacing = 1.0)
{
  std::vector<float> hu(static_cast<size_t>(n) * n * n);
  const double c = 0.5 * (n - 1);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        hu[(static_cast<size_t>(k) * n + j) * n + i] =
          static_cast<float>(-1000.0 + 1000.0 * fractionInside(spacing * Eigen::Vector3d(i - c, j - c, k - c)));
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() *= spacing;
  indexToCT.translation() = Eigen::Vector3d::Constant(-c * spacing);
  return xp::AttenuationVolume(hu.data(), Eigen::Vector3i(n, n, n), indexToCT, MuWater);
}

/** Fraction of a voxel of `size` mm at `p` inside a sphere (partial volume, 8^3 samples at the surface). */
double SphereFraction(const Eigen::Vector3d& p, double radius, double size)
{
  const double distance = p.norm();
  if (std::abs(distance - radius) > 0.9 * size)
    return distance < radius ? 1.0 : 0.0;
  int inside = 0;
  for (int a = 0; a < 8; ++a)
    for (int b = 0; b < 8; ++b)
      for (int c = 0; c < 8; ++c)
        inside += (p + size * Eigen::Vector3d(a - 3.5, b - 3.5, c - 3.5) / 8.0).norm() <= radius;
  return inside / 512.0;
}

/** A 64x64-pixel panel at z = +400 looking up from a source at z = -600 (CT frame = room). */
xp::DetectorGrid Panel(double pitch)
{
  xp::DetectorGrid grid;
  grid.columns = grid.rows = 64;
  grid.origin = Eigen::Vector3d(-31.5 * pitch, -31.5 * pitch, 400.0);
  grid.columnStep = Eigen::Vector3d(pitch, 0, 0);
  grid.rowStep = Eigen::Vector3d(0, pitch, 0);
  return grid;
}

const Eigen::Vector3d Source(7.0, -5.0, -600.0); // off-axis so that rays are oblique

/**
 * Chord of a ray through the box [-h, h]^3. `clean` is false when the ray crosses a face within
 * the band where trilinear interpolation ramps the edge (half a voxel either side) and that band
 * reaches another face along the ray: there the interpolated box has rounded edges, not the
 * box's sharp ones, and the analytic chord is not the right reference.
 */
double BoxChord(const Eigen::Vector3d& from, const Eigen::Vector3d& to, double h, bool& clean)
{
  const Eigen::Vector3d d = (to - from).normalized();
  double t0 = -1e9, t1 = 1e9;
  for (int a = 0; a < 3; ++a)
  {
    double ta = (-h - from[a]) / d[a], tb = (h - from[a]) / d[a];
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  clean = t1 > t0;
  if (!clean)
    return 0;
  for (double t : { t0, t1 })
  {
    const Eigen::Vector3d p = from + t * d;
    int face = 0;
    (Eigen::Vector3d::Constant(h) - p.cwiseAbs()).minCoeff(&face);
    const double band = 0.6 / std::abs(d[face]);
    for (double dt : { -band, band })
    {
      const Eigen::Vector3d q = from + (t + dt) * d;
      for (int b = 0; b < 3; ++b)
        clean = clean && (b == face || std::abs(q[b]) < h - 0.6);
    }
  }
  return t1 - t0;
}

void CheckBox(xp::RayCastMethod method, double stepSize, double tolerance)
{
  // Voxels 16..47 of 64 are inside: the box spans [-16, 16] mm exactly.
  const xp::AttenuationVolume volume =
    MakeVolume(64, [](const Eigen::Vector3d& p) { return p.cwiseAbs().maxCoeff() < 16.0 ? 1.0 : 0.0; });
  const xp::DetectorGrid grid = Panel(1.2);
  std::vector<float> integrals(grid.columns * grid.rows);
  xp::RayCastSettings settings;
  settings.method = method;
  settings.stepSize = stepSize;
  xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, nullptr, integrals.data(), settings);
  int checked = 0;
  double worst = 0;
  for (int r = 0; r < grid.rows; ++r)
  {
    for (int c = 0; c < grid.columns; ++c)
    {
      bool clean;
      const double chord = BoxChord(Source, grid.origin + c * grid.columnStep + r * grid.rowStep, 16.0, clean);
      const double value = integrals[r * grid.columns + c];
      if (chord == 0.0)
      {
        EXPECT_NEAR(value, 0.0, MuWater * 1.5) << "pixel " << c << "," << r;
        continue;
      }
      if (!clean)
      {
        continue;
      }
      ++checked;
      worst = std::max(worst, std::abs(value / (MuWater * chord) - 1.0));
    }
  }
  EXPECT_GT(checked, 400);
  EXPECT_LT(worst, tolerance) << "worst relative error over " << checked << " rays";
}

} // namespace

TEST(RayCasterAnalytic, BoxTrilinearDefaultStep)
{
  CheckBox(xp::RayCastMethod::Trilinear, 0.0, 1e-3);
}

TEST(RayCasterAnalytic, BoxTrilinearFineStep)
{
  CheckBox(xp::RayCastMethod::Trilinear, 0.25, 1e-3);
}

TEST(RayCasterAnalytic, BoxSiddonIsExact)
{
  CheckBox(xp::RayCastMethod::Siddon, 0.0, 1e-5);
}

TEST(RayCasterAnalytic, SphereChordLength)
{
  const double radius = 30.0;
  // 0.5 mm voxels: at 1 mm the voxelised sphere itself differs from the sphere by 0.13 %.
  const xp::AttenuationVolume volume =
    MakeVolume(136, [&](const Eigen::Vector3d& p) { return SphereFraction(p, radius, 0.5); }, 0.5);
  const xp::DetectorGrid grid = Panel(1.5);
  struct Case
  {
    const char* name;
    xp::RayCastMethod method;
    double step;
    double tolerance;
  };
  // Siddon integrates nearest-neighbour voxels exactly, so the partial-volume voxels at the
  // surface bias it; trilinear interpolation follows the smooth surface.
  for (const Case& test : { Case{ "trilinear 0.25 mm", xp::RayCastMethod::Trilinear, 0.25, 1e-3 },
         Case{ "trilinear per plane", xp::RayCastMethod::Trilinear, 0.0, 1e-3 },
         Case{ "siddon", xp::RayCastMethod::Siddon, 0.0, 1e-2 } })
  {
    std::vector<float> integrals(grid.columns * grid.rows);
    xp::RayCastSettings settings;
    settings.method = test.method;
    settings.stepSize = test.step;
    xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, nullptr, integrals.data(), settings);
    double worst = 0;
    int checked = 0;
    for (int r = 0; r < grid.rows; ++r)
    {
      for (int c = 0; c < grid.columns; ++c)
      {
        const Eigen::Vector3d d = (grid.origin + c * grid.columnStep + r * grid.rowStep - Source).normalized();
        const double distance = (-Source - (-Source).dot(d) * d).norm(); // centre to ray
        if (distance > 0.5 * radius)
          continue;
        const double chord = 2.0 * std::sqrt(radius * radius - distance * distance);
        worst = std::max(worst, std::abs(integrals[r * grid.columns + c] / (MuWater * chord) - 1.0));
        ++checked;
      }
    }
    EXPECT_GT(checked, 100);
    EXPECT_LT(worst, test.tolerance) << test.name;
    std::printf("sphere, %s: worst relative error %.4f %% over %d rays\n", test.name, 100 * worst, checked);
  }
}

TEST(RayCasterAnalytic, GrazingAndMissingRaysEndQuicklyWithZero)
{
  // All water, spanning [-16, 16] mm. Rays nearly parallel to the slices (z = const) that miss
  // the volume, run along its boundary face, or cross it: the case that hangs a peer's tracer.
  const xp::AttenuationVolume volume = MakeVolume(32, [](const Eigen::Vector3d&) { return 1.0; });
  const auto trace = [&](double y, double z0, double z1, xp::RayCastMethod method)
  {
    xp::DetectorGrid grid;
    grid.columns = grid.rows = 1;
    grid.origin = Eigen::Vector3d(2000.0, y, z1);
    xp::RayCastSettings settings;
    settings.method = method;
    float integral = -1.0f;
    xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Eigen::Vector3d(-2000.0, y, z0), grid, nullptr,
      &integral, settings);
    return integral;
  };
  const auto start = std::chrono::steady_clock::now();
  for (xp::RayCastMethod method : { xp::RayCastMethod::Trilinear, xp::RayCastMethod::Siddon })
  {
    EXPECT_EQ(trace(40.0, 1e-9, 0.0, method), 0.0f) << "misses beside the volume";
    EXPECT_EQ(trace(0.0, 16.5 + 1e-12, 16.5, method), 0.0f) << "misses just above the top slice";
    EXPECT_NEAR(trace(-9.0, 1e-9, -1e-9, method), MuWater * 32.0, MuWater * 0.01) << "crosses 32 mm of water";
    const float face = trace(16.0, 0.0, 1e-12, method);
    EXPECT_TRUE(std::isfinite(face) && face >= 0.0f && face <= MuWater * 32.01) << "runs along the boundary face";
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
}

TEST(RayCasterAnalytic, MaskedPixelsAreNotTracedAndValidOnesUnchanged)
{
  const xp::AttenuationVolume volume =
    MakeVolume(48, [](const Eigen::Vector3d& p) { return p.norm() < 20 ? 1.0 : 0.0; });
  const xp::DetectorGrid grid = Panel(1.0);
  const size_t n = grid.columns * grid.rows;
  std::vector<float> full(n), masked(n, -1.0f);
  std::vector<uint8_t> mask(n);
  for (size_t i = 0; i < n; ++i)
    mask[i] = (i % 7 == 0 || (i / 64) % 3 == 1) ? 1 : 0;
  const long long all = xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, nullptr, full.data());
  const long long some =
    xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, mask.data(), masked.data());
  EXPECT_EQ(all, static_cast<long long>(n));
  EXPECT_EQ(some, std::count(mask.begin(), mask.end(), 1));
  for (size_t i = 0; i < n; ++i)
  {
    EXPECT_EQ(masked[i], mask[i] ? full[i] : 0.0f) << i;
  }
  // The same pixels through a reusable list: traced ones equal, the others left as they were.
  std::vector<float> reused(n, -1.0f);
  const xp::TracedPixels pixels(grid.columns, grid.rows, mask.data());
  EXPECT_EQ(xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, pixels, reused.data()), some);
  for (size_t i = 0; i < n; ++i)
  {
    EXPECT_EQ(reused[i], mask[i] ? full[i] : -1.0f) << i;
  }
  const xp::TracedPixels otherPanel(grid.columns + 1, grid.rows, nullptr);
  EXPECT_THROW(
    xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, grid, otherPanel, reused.data()), xp::Error);
  std::vector<uint16_t> twelveBit(n);
  xp::LineIntegralsTo12Bit(masked.data(), mask.data(), static_cast<long long>(n), twelveBit.data());
  const size_t corner = 64 * 1; // row 1 is valid, column 0: a ray that misses -> transmission 1
  ASSERT_TRUE(mask[corner]);
  EXPECT_EQ(twelveBit[corner], 4095);
  EXPECT_EQ(twelveBit[2], 0) << "masked pixel";
}

// The vectorised caster's packets: every listed pixel once, in the list's order, at most sixteen
// to a packet, never two tiles and never more than two of a tile's rows, a row never split.
TEST(TracedPixels, PacketsStayWithinATileAndTwoOfItsRows)
{
  constexpr int Columns = 40, Rows = 21; // tiles of 16 x 8 cut at the panel's edges
  constexpr int TileColumns = xp::TracedPixels::TileColumns, TileRows = xp::TracedPixels::TileRows;
  std::vector<uint8_t> mask(Columns * Rows);
  for (int row = 0; row < Rows; ++row)
    for (int column = 0; column < Columns; ++column)
      // Tiles of the first tile row whole; below, rows of 3, 3, 3, 16, ... of a tile's columns.
      mask[row * Columns + column] = row < TileRows || column % TileColumns < (row % 4 == 3 ? 16 : 3);
  const xp::TracedPixels pixels(Columns, Rows, mask.data());
  const std::vector<int>& order = pixels.Order();
  const std::vector<int>& starts = pixels.PacketStarts();
  ASSERT_GE(starts.size(), 2u);
  EXPECT_EQ(starts.front(), 0);
  EXPECT_EQ(starts.back(), static_cast<int>(order.size()));
  EXPECT_EQ(order.size(), static_cast<size_t>(std::count(mask.begin(), mask.end(), 1)));
  const auto tileOf = [&](int pixel)
  { return std::make_pair(pixel / Columns / TileRows, pixel % Columns / TileColumns); };
  int twoRowPackets = 0;
  for (size_t p = 0; p + 1 < starts.size(); ++p)
  {
    ASSERT_LT(starts[p], starts[p + 1]) << "packet " << p << " is empty";
    ASSERT_LE(starts[p + 1] - starts[p], xp::TracedPixels::PacketSize);
    std::set<int> rows;
    for (int n = starts[p]; n < starts[p + 1]; ++n)
    {
      EXPECT_EQ(tileOf(order[n]), tileOf(order[starts[p]])) << "packet " << p << " spans two tiles";
      rows.insert(order[n] / Columns);
    }
    EXPECT_LE(rows.size(), 2u) << "packet " << p;
    twoRowPackets += rows.size() == 2;
    // A row is never split: the entry before a packet lies in another row or tile.
    if (starts[p] > 0)
    {
      const int before = order[starts[p] - 1], first = order[starts[p]];
      EXPECT_TRUE(before / Columns != first / Columns || tileOf(before) != tileOf(first))
        << "packet " << p << " begins inside a row";
    }
  }
  EXPECT_GT(twoRowPackets, 0);
  // Rows 0-7, whole: a packet each in the two 16-column tiles, two to a packet in the 8-column
  // one: 8 + 8 + 4. Rows 8-15 hold 3, 3, 3, 16, 3, 3, 3, 16 of a 16-column tile: {3 3} {3} {16}
  // {3 3} {3} {16}, 6 packets; of the 8-column tile 3, 3, 3, 8, ...: {3 3} {3 8} {3 3} {3 8}, 4.
  // Rows 16-20, 3, 3, 3, 16, 3: {3 3} {3} {16} {3}, 4; 3, 3, 3, 8, 3: {3 3} {3 8} {3}, 3.
  EXPECT_EQ(starts.size() - 1, static_cast<size_t>(8 + 8 + 4 + 6 + 6 + 4 + 4 + 4 + 3));
  // Unmasked: a packet per row of a 16-column tile, per two rows of an 8-column one (whose tiles
  // hold 8, 8 and 5 rows).
  const xp::TracedPixels all(Columns, Rows, nullptr);
  EXPECT_EQ(all.PacketStarts().size() - 1, static_cast<size_t>(2 * Rows + 4 + 4 + 3));
}

TEST(RayCasterAnalytic, VectorPacketsMatchOneRayAtATime)
{
  if (!xp::HasVectorRayCaster())
  {
    GTEST_SKIP() << "this CPU has no AVX2: the vectorised ray caster is not used here";
  }
  // A textured sphere and box 90 mm apart with empty 32^3 blocks between them: a packet samples
  // the gap (zeros), one ray at a time skips it. 61 x 37 pixels: packets straddle rows and the
  // last one is partial.
  const xp::AttenuationVolume volume = MakeVolume(128,
    [](const Eigen::Vector3d& p)
    {
      const double texture = 1.0 + 0.5 * std::sin(0.7 * p[0]) * std::cos(0.3 * p[1] + 0.2 * p[2]);
      const bool sphere = (p - Eigen::Vector3d(-45, 0, 0)).norm() < 12.0;
      const bool box = (p - Eigen::Vector3d(45, 5, 0)).cwiseAbs().maxCoeff() < 10.0;
      return sphere || box ? texture : 0.0;
    });
  struct View
  {
    const char* name;
    Eigen::Vector3d source, panelCentre, columnStep, rowStep;
  };
  // Along +x, -y and +z, and 45 degrees in x-y on a wide panel: there the dominant axis changes
  // from column to column, inside packets.
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1, -1, 0).normalized();
  for (const View& view : { View{ "+x", { -600, 3, 2 }, { 400, 0, 0 }, { 0, 1.1, 0 }, { 0, 0.3, 1.1 } },
         View{ "-y", { 40, 600, -3 }, { 50, -400, 0 }, { 1.1, 0, 0 }, { 0, 0, 1.1 } },
         View{ "+z", { -40, -2, -600 }, { -50, 0, 400 }, { 1.1, 0, 0 }, { 0, 1.1, 0 } },
         View{ "x-y diagonal", { -500, -500, 0 }, { 350, 350, 0 }, 7.0 * diagonal, { 0, 0, 1.3 } } })
  {
    xp::DetectorGrid grid;
    grid.columns = 61;
    grid.rows = 37;
    grid.columnStep = view.columnStep;
    grid.rowStep = view.rowStep;
    grid.origin = view.panelCentre - 30.0 * view.columnStep - 18.0 * view.rowStep;
    const size_t n = static_cast<size_t>(grid.columns) * grid.rows;
    std::vector<uint8_t> mask(n);
    for (size_t i = 0; i < n; ++i)
      mask[i] = i % 3 != 1;
    for (const uint8_t* pixels : { static_cast<const uint8_t*>(nullptr), static_cast<const uint8_t*>(mask.data()) })
    {
      std::vector<float> packets(n, -1.0f), single(n, -1.0f);
      xp::RayCastSettings settings;
      xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), view.source, grid, pixels, packets.data(), settings);
      settings.vectorized = false;
      xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), view.source, grid, pixels, single.data(), settings);
      int nonZero = 0;
      for (size_t i = 0; i < n; ++i)
      {
        EXPECT_NEAR(packets[i], single[i], 2e-5 * single[i] + 1e-7) << view.name << ", pixel " << i;
        nonZero += single[i] > MuWater;
      }
      EXPECT_GT(nonZero, static_cast<int>(n / 20)) << view.name << ": the rays must cross the objects";
    }
  }
}

TEST(RayCasterAnalytic, VoxelReadsResolveToLoadsOrGathers)
{
  EXPECT_EQ(xp::WideVoxelReadsOf(xp::VoxelReads::Loads), xp::VoxelReads::Loads);
  EXPECT_EQ(xp::WideVoxelReadsOf(xp::VoxelReads::Gathers), xp::VoxelReads::Gathers);
  const xp::VoxelReads chosen = xp::WideVoxelReadsOf(xp::VoxelReads::Auto);
  EXPECT_TRUE(chosen == xp::VoxelReads::Loads || chosen == xp::VoxelReads::Gathers) << xp::ToString(chosen);
  EXPECT_STREQ(xp::ToString(xp::VoxelReads::Auto), "auto");
}

TEST(RayCasterAnalytic, SixteenLanesGiveEightLanesIntegralsToTheBit)
{
  if (!xp::HasWideVectorRayCaster())
  {
    GTEST_SKIP() << "this CPU has no AVX-512: the ray caster's sixteen lanes are not used here";
  }
  // Two objects with empty blocks between them, lit from an oblique source so that the dominant
  // axis changes across the panel; masked pixels so that packets straddle rows; every plane and
  // every second one.
  const xp::AttenuationVolume volume = MakeVolume(128,
    [](const Eigen::Vector3d& p)
    {
      const double texture = 1.0 + 0.5 * std::sin(0.9 * p[0] + 0.4 * p[2]) * std::cos(0.3 * p[1]);
      const bool sphere = (p - Eigen::Vector3d(-40, 10, 0)).norm() < 14.0;
      const bool box = (p - Eigen::Vector3d(35, -5, 8)).cwiseAbs().maxCoeff() < 11.0;
      return sphere || box ? texture : 0.0;
    });
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1, -1, 0.2).normalized();
  xp::DetectorGrid grid;
  grid.columns = 71;
  grid.rows = 43;
  grid.columnStep = 6.0 * diagonal;
  grid.rowStep = Eigen::Vector3d(0.1, 0, 1.2);
  grid.origin = Eigen::Vector3d(350, 350, 0) - 35.0 * grid.columnStep - 21.0 * grid.rowStep;
  const Eigen::Vector3d source(-500, -500, 10);
  const size_t n = static_cast<size_t>(grid.columns) * grid.rows;
  std::vector<uint8_t> mask(n);
  for (size_t i = 0; i < n; ++i)
    mask[i] = (i * 7) % 5 != 2;
  for (const int step : { 1, 2 })
  {
    for (const uint8_t* pixels : { static_cast<const uint8_t*>(nullptr), static_cast<const uint8_t*>(mask.data()) })
    {
      std::vector<float> narrow(n, -2.0f);
      xp::RayCastSettings settings;
      settings.planeSteps = { step, step, step };
      settings.wideVectors = false;
      xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), source, grid, pixels, narrow.data(), settings);
      settings.wideVectors = true;
      // Both ways of reading the voxels: row loads where the lanes allow them, gathers always.
      for (const xp::VoxelReads reads : { xp::VoxelReads::Loads, xp::VoxelReads::Gathers })
      {
        std::vector<float> wide(n, -1.0f);
        settings.voxelReads = reads;
        xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), source, grid, pixels, wide.data(), settings);
        int nonZero = 0, differ = 0;
        for (size_t i = 0; i < n; ++i)
        {
          differ += wide[i] != narrow[i];
          nonZero += wide[i] > 0.0f;
        }
        EXPECT_EQ(differ, 0) << "plane step " << step << (pixels ? ", masked" : "") << ", " << xp::ToString(reads);
        EXPECT_GT(nonZero, static_cast<int>(n / 10)) << "the rays must cross the objects";
      }
    }
  }
}

// Sixteen lanes set their rays up eight at a time (AVX-512), eight lanes four at a time (AVX2).
TEST(RayCasterAnalytic, ThePacketsRaysSetUpSeveralAtATimeGiveTheIntegralsToTheBit)
{
  if (!xp::HasVectorRayCaster())
  {
    GTEST_SKIP() << "this CPU has no AVX2: the ray caster's packets are not used here";
  }
  // Two objects with empty blocks between and around them (the walks skip blocks at both ends and
  // meet empty ones between), under panels whose rays run obliquely (the dominant axis changing
  // across the panel), exactly along an index axis (direction components of 0, some rays outside
  // the volume's slab) and past the volume altogether; every plane and every second one, masked
  // pixels so that packets hold fewer than sixteen rays.
  const xp::AttenuationVolume volume = MakeVolume(100,
    [](const Eigen::Vector3d& p)
    {
      const bool sphere = (p - Eigen::Vector3d(-30, 12, -5)).norm() < 12.0;
      const bool box = (p - Eigen::Vector3d(28, -6, 9)).cwiseAbs().maxCoeff() < 9.0;
      return sphere || box ? 1.0 + 0.3 * std::sin(0.7 * p[0] + 0.2 * p[1]) : 0.0;
    });
  struct Panel
  {
    Eigen::Vector3d source, centre, columnStep, rowStep;
  };
  const Eigen::Vector3d diagonal = Eigen::Vector3d(1, -1, 0.2).normalized();
  const std::vector<Panel> panels = {
    { { -500, -500, 10 }, { 350, 350, 0 }, 5.0 * diagonal, { 0.1, 0, 1.1 } },
    { { -600, 0, 0 }, { 400, 0, 0 }, { 0, 2.0, 0 }, { 0, 0, 2.0 } },   // along x: the central row's rays have dz = 0
    { { 0, 0, -700 }, { 0, 0, 400 }, { 2.5, 0, 0 }, { 0, 2.5, 0 } },   // along z, rays beyond the slab's sides
    { { -500, 400, 0 }, { 500, 400, 0 }, { 0, 1.5, 0 }, { 0, 0, 1.5 } }, // past the volume: every ray misses
  };
  const int columns = 61, rows = 37;
  const size_t n = static_cast<size_t>(columns) * rows;
  std::vector<uint8_t> mask(n);
  for (size_t i = 0; i < n; ++i)
    mask[i] = (i * 7) % 5 != 2;
  int crossing = 0;
  for (size_t p = 0; p < panels.size(); ++p)
  {
    xp::DetectorGrid grid;
    grid.columns = columns;
    grid.rows = rows;
    grid.columnStep = panels[p].columnStep;
    grid.rowStep = panels[p].rowStep;
    grid.origin = panels[p].centre - 30.0 * grid.columnStep - 18.0 * grid.rowStep;
    for (const bool wideVectors : { false, true })
      for (const int step : { 1, 2 })
        for (const uint8_t* pixels : { static_cast<const uint8_t*>(nullptr), static_cast<const uint8_t*>(mask.data()) })
          for (const xp::VoxelReads reads : { xp::VoxelReads::Loads, xp::VoxelReads::Gathers })
          {
            if (wideVectors && !xp::HasWideVectorRayCaster())
              continue; // no AVX-512: sixteen lanes are not used here
            xp::RayCastSettings settings;
            settings.wideVectors = wideVectors;
            settings.planeSteps = { step, step, step };
            settings.voxelReads = reads;
            std::vector<float> one(n, -2.0f), several(n, -1.0f);
            settings.wideSetUp = false;
            xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), panels[p].source, grid, pixels, one.data(), settings);
            settings.wideSetUp = true;
            xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), panels[p].source, grid, pixels, several.data(), settings);
            int differ = 0;
            for (size_t i = 0; i < n; ++i)
            {
              differ += std::memcmp(&one[i], &several[i], sizeof(float)) != 0;
              crossing += one[i] > 0.0f;
            }
            EXPECT_EQ(differ, 0) << (wideVectors ? "sixteen" : "eight") << " lanes, panel " << p << ", plane step " << step
                                 << (pixels ? ", masked" : "") << ", " << xp::ToString(reads);
          }
  }
  EXPECT_GT(crossing, static_cast<int>(n)) << "the rays must cross the objects";
}

TEST(RayCasterAnalytic, PlaneStepsSampleEveryNthPlaneWeighingItsLength)
{
  // Slabs one voxel thick across each axis in turn, every second plane dense: with step 2 a ray
  // along that axis samples either only dense planes (twice the every-plane integral) or only
  // air between them (0), and the complementary slabs the other way round. A voxel at two
  // opposite corners keeps the stored box, and so the planes' parity, the same for both.
  const int n = 48;
  for (int direction = 0; direction < 6; ++direction)
  {
    // Rays up and down each axis: they enter the volume at either end, on planes of either parity.
    const int axis = direction / 2;
    const double sense = direction % 2 == 0 ? 1.0 : -1.0;
    double stepTwo[2][2] = {}; // [phase][vectorized]
    double everyPlane[2] = {};
    for (int phase = 0; phase < 2; ++phase)
    {
      const xp::AttenuationVolume volume = MakeVolume(n,
        [axis, phase](const Eigen::Vector3d& p)
        {
          const Eigen::Vector3d index = p + Eigen::Vector3d::Constant(0.5 * (n - 1));
          if ((index.array() < 0.5).all() || (index.array() > n - 1.5).all())
            return 1.0;
          const bool inside = (p.cwiseAbs().array() < 15.0).all();
          return inside && static_cast<int>(std::lround(index[axis])) % 2 == phase ? 2.0 : 0.0;
        });
      // Rays along +axis, 10 % oblique across it: the dominant axis stays `axis`.
      const int b = (axis + 1) % 3, c = (axis + 2) % 3;
      Eigen::Vector3d source = Eigen::Vector3d::Zero(), centre = Eigen::Vector3d::Zero();
      source[axis] = -600.0 * sense;
      source[b] = 3.0;
      centre[axis] = 400.0 * sense;
      xp::DetectorGrid grid;
      grid.columns = grid.rows = 16;
      grid.columnStep = 1.2 * Eigen::Vector3d::Unit(b);
      grid.rowStep = 1.2 * Eigen::Vector3d::Unit(c);
      grid.origin = centre - 7.5 * grid.columnStep - 7.5 * grid.rowStep;
      const size_t pixels = static_cast<size_t>(grid.columns) * grid.rows;
      for (const bool vectorized : { false, true })
      {
        if (vectorized && !xp::HasVectorRayCaster())
          continue;
        xp::RayCastSettings settings;
        settings.vectorized = vectorized;
        std::vector<float> every(pixels), second(pixels);
        xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), source, grid, nullptr, every.data(), settings);
        settings.planeSteps[axis] = 2;
        xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), source, grid, nullptr, second.data(), settings);
        // Another axis's step leaves these rays alone.
        settings.planeSteps[axis] = 1;
        settings.planeSteps[b] = 2;
        std::vector<float> other(pixels);
        xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), source, grid, nullptr, other.data(), settings);
        for (size_t i = 0; i < pixels; ++i)
          EXPECT_NEAR(other[i], every[i], 1e-5 * every[i] + 1e-7) << "axis " << axis << ", sense " << sense << ", pixel " << i;
        everyPlane[phase] = 0.0;
        for (size_t i = 0; i < pixels; ++i)
        {
          everyPlane[phase] += every[i];
          stepTwo[phase][vectorized] += second[i];
        }
      }
    }
    ASSERT_GT(everyPlane[0], 0.0);
    ASSERT_NEAR(everyPlane[1], everyPlane[0], 0.1 * everyPlane[0]) << "axis " << axis << ", sense " << sense << ": the phases' slabs are alike";
    for (const int vectorized : { 0, 1 })
    {
      if (vectorized && !xp::HasVectorRayCaster())
        continue;
      // One phase's step-2 integral is twice its every-plane one, the other's none.
      const int dense = stepTwo[0][vectorized] > stepTwo[1][vectorized] ? 0 : 1;
      EXPECT_NEAR(stepTwo[dense][vectorized], 2.0 * everyPlane[dense], 0.01 * everyPlane[dense])
        << "axis " << axis << ", sense " << sense << (vectorized ? ", packets" : ", one ray at a time");
      EXPECT_LT(stepTwo[1 - dense][vectorized], 0.01 * everyPlane[1 - dense])
        << "axis " << axis << ", sense " << sense << (vectorized ? ", packets" : ", one ray at a time");
    }
    if (xp::HasVectorRayCaster())
      EXPECT_EQ(stepTwo[0][0] > stepTwo[1][0], stepTwo[0][1] > stepTwo[1][1]) << "both paths keep the same planes";
  }
  xp::RayCastSettings refused;
  refused.planeSteps[1] = 0;
  std::vector<float> out(64 * 64);
  const xp::AttenuationVolume volume = MakeVolume(8, [](const Eigen::Vector3d&) { return 1.0; });
  EXPECT_THROW(
    xp::RenderLineIntegrals(volume, Eigen::Isometry3d::Identity(), Source, Panel(1.0), nullptr, out.data(), refused), xp::Error);
}

TEST(AttenuationVolume, StoresTheBoxOfNonAirVoxelsAndKeepsTheCTGrid)
{
  // A 20 x 16 x 12 CT, air (and noise below the air threshold) but for a block of water at
  // voxels x 5..9, y 3..12, z 2..2 and one bone voxel at (14, 4, 7).
  const Eigen::Vector3i dims(20, 16, 12);
  std::vector<int16_t> hu(static_cast<size_t>(dims.prod()), -1000);
  const auto at = [&](int i, int j, int k) -> int16_t& { return hu[(static_cast<size_t>(k) * dims[1] + j) * dims[0] + i]; };
  for (int j = 3; j <= 12; ++j)
    for (int i = 5; i <= 9; ++i)
      at(i, j, 2) = 0;
  at(14, 4, 7) = 1000;
  at(18, 15, 11) = -960; // noise in the air
  Eigen::Affine3d indexToCT = Eigen::Affine3d::Identity();
  indexToCT.linear() = Eigen::Vector3d(0.5, 0.75, 2.0).asDiagonal();
  indexToCT.translation() = Eigen::Vector3d(-5.0, 3.0, 100.0);
  const xp::AttenuationVolume volume(hu.data(), dims, indexToCT, MuWater);
  EXPECT_EQ(volume.Dimensions(), dims);
  EXPECT_TRUE(volume.IndexToCT().isApprox(indexToCT));
  EXPECT_EQ(volume.StoredOrigin(), Eigen::Vector3i(5, 3, 2));
  EXPECT_EQ(volume.StoredDimensions(), Eigen::Vector3i(10, 10, 6));
  // The padded grid starts one voxel before the box.
  EXPECT_TRUE((volume.PaddedIndexToCT() * Eigen::Vector3d(1, 1, 1)).isApprox(indexToCT * Eigen::Vector3d(5, 3, 2)));
  EXPECT_NEAR(volume.At(7, 8, 2), MuWater, 1e-6);
  EXPECT_NEAR(volume.At(14, 4, 7), 2.0 * MuWater, 1e-6);
  EXPECT_EQ(volume.At(18, 15, 11), 0.0f);
  EXPECT_EQ(volume.At(0, 0, 0), 0.0f);
  EXPECT_EQ(volume.At(-1, 20, 40), 0.0f) << "outside the CT";
  EXPECT_NEAR(volume.StoredAt(9, 1, 5), 2.0 * MuWater, 1e-6);
  // Half resolution: the CT's grid halved, the box's voxels averaged 2 x 2 x 2.
  const xp::AttenuationVolume half = volume.Halved();
  EXPECT_EQ(half.Dimensions(), Eigen::Vector3i(10, 8, 6));
  EXPECT_TRUE((half.IndexToCT() * Eigen::Vector3d(0, 0, 0)).isApprox(indexToCT * Eigen::Vector3d(0.5, 0.5, 0.5)));
  EXPECT_NEAR(half.At(7, 2, 3), 2.0 * MuWater / 8.0, 1e-6);  // the bone voxel, one of eight
  EXPECT_NEAR(half.At(3, 3, 1), MuWater / 2.0, 1e-6);        // water in one of two slices
  EXPECT_EQ(half.At(9, 7, 5), 0.0f);
  // Halved along x and y only (a CT of thick slices): 2 x 2 x 1 averaged, the slices kept.
  const xp::AttenuationVolume pixelsOnly = volume.Halved(Eigen::Vector3i(2, 2, 1));
  EXPECT_EQ(pixelsOnly.Dimensions(), Eigen::Vector3i(10, 8, 12));
  EXPECT_TRUE((pixelsOnly.IndexToCT() * Eigen::Vector3d(1, 1, 1)).isApprox(indexToCT * Eigen::Vector3d(2.5, 2.5, 1.0)));
  EXPECT_NEAR(pixelsOnly.At(7, 2, 7), 2.0 * MuWater / 4.0, 1e-6); // the bone voxel, one of four
  EXPECT_NEAR(pixelsOnly.At(3, 3, 2), MuWater, 1e-6);              // inside the water slice
  EXPECT_NEAR(pixelsOnly.At(2, 1, 2), MuWater / 4.0, 1e-6);        // its corner, one of four
  EXPECT_EQ(pixelsOnly.At(3, 3, 3), 0.0f) << "the slice above the water stays air";
  EXPECT_THROW(volume.Halved(Eigen::Vector3i(2, 3, 1)), xp::Error);
  // All air: one stored voxel, and every ray integrates to zero.
  std::vector<float> air(static_cast<size_t>(dims.prod()), -1000.0f);
  const xp::AttenuationVolume empty(air.data(), dims, indexToCT, MuWater);
  EXPECT_EQ(empty.StoredDimensions(), Eigen::Vector3i(1, 1, 1));
  EXPECT_EQ(empty.OccupiedFraction(), 0.0);
}
