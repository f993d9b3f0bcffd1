#include "xpRayCaster.h"

#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpXRayView.h"

#include <vtkSMPTools.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace xp
{

DetectorGrid DetectorGrid::TopRowFirst(const XRayView& view)
{
  DetectorGrid grid;
  grid.origin = view.PixelCenter(0, 0);
  grid.columnStep = view.pixelSpacing[0] * view.rowDirection;
  grid.rowStep = view.pixelSpacing[1] * view.columnDirection;
  grid.columns = view.Columns();
  grid.rows = view.Rows();
  return grid;
}

DetectorGrid DetectorGrid::BottomRowFirst(const XRayView& view)
{
  DetectorGrid grid = TopRowFirst(view);
  grid.origin = view.PixelCenter(0, view.Rows() - 1);
  grid.rowStep = -grid.rowStep;
  return grid;
}

namespace
{

constexpr double Infinity = std::numeric_limits<double>::infinity();

/** A ray in padded voxel-index space: p(t) = start + t * direction, t in mm along the room ray. */
struct IndexRay
{
  Eigen::Vector3d start;
  Eigen::Vector3d direction;
  double length; // source to pixel, mm
};

/** Clips t in [0, length] to the box [lo, hi] per axis; false when the ray misses it. */
bool ClipToBox(const IndexRay& ray, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double& t0, double& t1)
{
  t0 = 0.0;
  t1 = ray.length;
  for (int a = 0; a < 3; ++a)
  {
    const double d = ray.direction[a], p = ray.start[a];
    if (d == 0.0)
    {
      if (p < lo[a] || p > hi[a])
      {
        return false;
      }
      continue;
    }
    double ta = (lo[a] - p) / d, tb = (hi[a] - p) / d;
    if (ta > tb)
    {
      std::swap(ta, tb);
    }
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t0 < t1;
}

/**
 * Sum of trilinear samples k0 <= k < k1 at start + (k + 0.5) * step * direction. Built twice
 * (AVX2 and baseline) and picked at load time: the hot loop of every DRR.
 */
__attribute__((target_clones("avx2", "default"), noinline)) float SampleRun(const float* voxels, long nx, long nxy,
  const float start[3], const float step[3], long k0, long k1, const float upper[3])
{
  float sum = 0.0f;
  for (long k = k0; k < k1; ++k)
  {
    const float s = static_cast<float>(k) + 0.5f;
    const float x = std::min(std::max(start[0] + s * step[0], 0.0f), upper[0]);
    const float y = std::min(std::max(start[1] + s * step[1], 0.0f), upper[1]);
    const float z = std::min(std::max(start[2] + s * step[2], 0.0f), upper[2]);
    const long ix = static_cast<long>(x), iy = static_cast<long>(y), iz = static_cast<long>(z);
    const float fx = x - ix, fy = y - iy, fz = z - iz;
    const float* c = voxels + ix + iy * nx + iz * nxy;
    const float c00 = c[0] + fx * (c[1] - c[0]);
    const float c10 = c[nx] + fx * (c[nx + 1] - c[nx]);
    const float c01 = c[nxy] + fx * (c[nxy + 1] - c[nxy]);
    const float c11 = c[nxy + nx] + fx * (c[nxy + nx + 1] - c[nxy + nx]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    sum += c0 + fz * (c1 - c0);
  }
  return sum;
}

/** Trilinear line integral, marching only through occupied blocks. */
double TraceTrilinear(const AttenuationVolume& volume, const IndexRay& ray, double step)
{
  const Eigen::Vector3i& padded = volume.PaddedDimensions();
  // Samples read voxel floor(p) + 1, so positions stay below padded - 1.
  const Eigen::Vector3d upperD = (padded.cast<double>() - Eigen::Vector3d::Constant(1.0 + 1e-4));
  double tEnter, tExit;
  if (!ClipToBox(ray, Eigen::Vector3d::Zero(), upperD, tEnter, tExit))
  {
    return 0.0;
  }
  const float upper[3] = { static_cast<float>(upperD[0]), static_cast<float>(upperD[1]), static_cast<float>(upperD[2]) };
  const long nx = padded[0], nxy = static_cast<long>(padded[0]) * padded[1];
  const float* voxels = volume.Voxels();

  // 3D DDA over occupancy blocks (Amanatides & Woo); at most bx + by + bz steps.
  const double blockSize = 1 << AttenuationVolume::BlockShift;
  const Eigen::Vector3i& blocks = volume.BlockDimensions();
  const Eigen::Vector3d entry = ray.start + tEnter * ray.direction;
  Eigen::Vector3i cell, stepCell;
  Eigen::Vector3d tNext, tDelta;
  for (int a = 0; a < 3; ++a)
  {
    cell[a] = std::clamp(static_cast<int>(entry[a] / blockSize), 0, blocks[a] - 1);
    const double d = ray.direction[a];
    stepCell[a] = d > 0 ? 1 : -1;
    if (d == 0.0)
    {
      tNext[a] = Infinity;
      tDelta[a] = Infinity;
    }
    else
    {
      const double boundary = (cell[a] + (d > 0 ? 1 : 0)) * blockSize;
      tNext[a] = (boundary - ray.start[a]) / d;
      tDelta[a] = blockSize / std::abs(d);
    }
  }

  double sum = 0.0;
  double t = tEnter, runStart = -1.0;
  const auto flush = [&](double runEnd)
  {
    // Samples of the ray's own lattice tEnter + (k + 0.5) step that fall in [runStart, runEnd).
    const long k0 = static_cast<long>(std::ceil((runStart - tEnter) / step - 0.5));
    const long k1 = static_cast<long>(std::ceil((runEnd - tEnter) / step - 0.5));
    if (k1 > k0)
    {
      const Eigen::Vector3d s = ray.start + tEnter * ray.direction, d = step * ray.direction;
      const float start[3] = { float(s[0]), float(s[1]), float(s[2]) }, dir[3] = { float(d[0]), float(d[1]), float(d[2]) };
      sum += SampleRun(voxels, nx, nxy, start, dir, k0, k1, upper);
    }
    runStart = -1.0;
  };
  while (t < tExit)
  {
    int axis = 0;
    if (tNext[1] < tNext[axis])
      axis = 1;
    if (tNext[2] < tNext[axis])
      axis = 2;
    const double tEnd = std::min(tNext[axis], tExit);
    if (volume.BlockOccupied(cell[0], cell[1], cell[2]))
    {
      if (runStart < 0.0)
      {
        runStart = t;
      }
    }
    else if (runStart >= 0.0)
    {
      flush(t);
    }
    t = tEnd;
    cell[axis] += stepCell[axis];
    tNext[axis] += tDelta[axis];
    if (cell[axis] < 0 || cell[axis] >= blocks[axis])
    {
      break;
    }
  }
  if (runStart >= 0.0)
  {
    flush(std::min(t, tExit));
  }
  return sum * step;
}

/** Exact integral through nearest-neighbour voxels (Siddon / Amanatides & Woo voxel walk). */
double TraceSiddon(const AttenuationVolume& volume, const IndexRay& ray)
{
  const Eigen::Vector3i& dims = volume.Dimensions();
  // Original voxel i (padded i + 1) spans padded coordinates [i + 0.5, i + 1.5].
  const Eigen::Vector3d lo = Eigen::Vector3d::Constant(0.5), hi = dims.cast<double>() + lo;
  double tEnter, tExit;
  if (!ClipToBox(ray, lo, hi, tEnter, tExit))
  {
    return 0.0;
  }
  const Eigen::Vector3d mid = ray.start + 0.5 * (tEnter + tExit) * ray.direction;
  const Eigen::Vector3d entry = ray.start + tEnter * ray.direction;
  Eigen::Vector3i voxel, stepVoxel;
  Eigen::Vector3d tNext, tDelta;
  for (int a = 0; a < 3; ++a)
  {
    const double d = ray.direction[a];
    // Enter on a face: take the voxel the ray moves into, not the one it leaves.
    double p = entry[a];
    if (d == 0.0)
    {
      p = mid[a];
    }
    voxel[a] = std::clamp(static_cast<int>(std::floor(p - 0.5 + (d > 0 ? 1e-9 : -1e-9))), 0, dims[a] - 1);
    stepVoxel[a] = d > 0 ? 1 : -1;
    if (d == 0.0)
    {
      tNext[a] = Infinity;
      tDelta[a] = Infinity;
    }
    else
    {
      const double boundary = voxel[a] + 0.5 + (d > 0 ? 1.0 : 0.0);
      tNext[a] = (boundary - ray.start[a]) / d;
      tDelta[a] = 1.0 / std::abs(d);
    }
  }
  double sum = 0.0, t = tEnter;
  while (t < tExit)
  {
    int axis = 0;
    if (tNext[1] < tNext[axis])
      axis = 1;
    if (tNext[2] < tNext[axis])
      axis = 2;
    const double tEnd = std::min(tNext[axis], tExit);
    sum += (tEnd - t) * volume.At(voxel[0], voxel[1], voxel[2]);
    t = tEnd;
    voxel[axis] += stepVoxel[axis];
    tNext[axis] += tDelta[axis];
    if (voxel[axis] < 0 || voxel[axis] >= dims[axis])
    {
      break;
    }
  }
  return sum;
}

} // namespace

long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const uint8_t* mask, float* lineIntegrals,
  const RayCastSettings& settings)
{
  if (volume.Dimensions().minCoeff() < 1)
  {
    throw Error("ray caster: no volume");
  }
  const double step = settings.stepSize > 0.0 ? settings.stepSize : volume.MinimumSpacing();
  const Eigen::Affine3d roomToIndex = (ctToRoom * volume.PaddedIndexToCT()).inverse();
  const Eigen::Vector3d source = roomToIndex * sourceInRoom;
  const long long count = static_cast<long long>(grid.columns) * grid.rows;

  // The pixels to trace: all, or the valid ones, so that work is spread evenly over threads.
  std::vector<int> valid;
  if (mask)
  {
    valid.reserve(static_cast<size_t>(count));
    for (long long i = 0; i < count; ++i)
    {
      if (mask[i])
      {
        valid.push_back(static_cast<int>(i));
      }
      else
      {
        lineIntegrals[i] = 0.0f;
      }
    }
  }
  const long long traced = mask ? static_cast<long long>(valid.size()) : count;

  vtkSMPTools::For(0LL, traced, 256LL,
    [&](long long begin, long long end)
    {
      for (long long n = begin; n < end; ++n)
      {
        const long long pixel = mask ? valid[n] : n;
        const int column = static_cast<int>(pixel % grid.columns), row = static_cast<int>(pixel / grid.columns);
        const Eigen::Vector3d target = grid.origin + column * grid.columnStep + row * grid.rowStep;
        const Eigen::Vector3d toPixel = target - sourceInRoom;
        IndexRay ray;
        ray.length = toPixel.norm();
        ray.start = source;
        ray.direction = roomToIndex.linear() * (toPixel / ray.length);
        const double integral = settings.method == RayCastMethod::Siddon ? TraceSiddon(volume, ray)
                                                                         : TraceTrilinear(volume, ray, step);
        lineIntegrals[pixel] = static_cast<float>(integral);
      }
    });
  return traced;
}

void LineIntegralsTo12Bit(const float* lineIntegrals, const uint8_t* mask, long long count, uint16_t* transmission)
{
  for (long long i = 0; i < count; ++i)
  {
    transmission[i] = (mask && !mask[i]) ? 0 : static_cast<uint16_t>(std::lround(4095.0 * std::exp(-double(lineIntegrals[i]))));
  }
}

} // namespace xp
