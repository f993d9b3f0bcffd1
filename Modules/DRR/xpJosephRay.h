/**
 * @file xpJosephRay.h
 * @brief One ray of Joseph's scheme as plain arithmetic that compiles for the CPU and for CUDA:
 *        the GPU ray caster's per-ray work, checked on the CPU against xpRayCaster's own.
 *
 * The same scheme as the CPU ray caster's (xpRayCaster.cxx, SetUpPlaneRay and PlaneSample): the
 * ray is clipped to where trilinear samples may be taken, one sample is taken on every voxel plane
 * of its dominant axis, bilinear on that plane, and the sum is scaled by the planes' spacing along
 * the ray. The set-up is in double and the samples in float, as there. Empty space is not skipped:
 * its samples are zeros, so the sum is the same.
 *
 * No VTK, no Eigen, no CUDA header: the GPU kernels (xpCudaRayCaster.cu) and the harness of
 * Utilities/GPU include it as it is.
 */
#ifndef xpJosephRay_h
#define xpJosephRay_h

#include <cmath>
#include <cstdint>

#if defined(__CUDACC__)
#define XP_HOST_DEVICE __host__ __device__ __forceinline__
#else
#define XP_HOST_DEVICE inline
#endif

namespace xp
{
namespace joseph
{

/**
 * One DRR's rays. Pixel (c, r) of the traced grid (pixel index r * columns + c) lies at
 * origin + c column + r row in padded voxel-index space and at roomOrigin + c roomColumn +
 * r roomRow from the source in Room mm (the ray's length, which sets the integral's mm).
 */
struct Job
{
  double source[3];
  double origin[3], column[3], row[3];
  double roomOrigin[3], roomColumn[3], roomRow[3];
  int columns;
};

/** The padded volume: voxel (x, y, z) at x + y nx + z nx ny, in steps of `quantum` (1/mm). */
struct Grid
{
  int dims[3];
  double quantum;
};

/** Where a ray's samples lie: sample j on plane m0 + sa j of axis `axis`, its two other
 *  coordinates b0 + j db (axis b) and c0 + j dc (axis c), j in [0, count). */
struct Planes
{
  int axis, b, c, m0, sa, count;
  float b0, db, c0, dc, upperB, upperC;
  double dt; ///< mm between planes along the ray
};

/** Sets up the ray of `pixel`; false when it misses the volume (its integral is 0). */
XP_HOST_DEVICE bool SetUp(const Job& job, const Grid& grid, int pixel, Planes& out)
{
  const int c = pixel % job.columns, r = pixel / job.columns;
  double room[3], direction[3], start[3], upper[3];
  double length2 = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    room[a] = job.roomOrigin[a] + c * job.roomColumn[a] + r * job.roomRow[a];
    length2 += room[a] * room[a];
  }
  const double length = sqrt(length2);
  for (int a = 0; a < 3; ++a)
  {
    start[a] = job.source[a];
    direction[a] = (job.origin[a] + c * job.column[a] + r * job.row[a] - job.source[a]) / length;
    upper[a] = grid.dims[a] - (1.0 + 1e-4);
  }
  // Clip t in [0, length] to the box [0, upper].
  double t0 = 0.0, t1 = length;
  for (int a = 0; a < 3; ++a)
  {
    const double d = direction[a], p = start[a];
    if (d == 0.0)
    {
      if (p < 0.0 || p > upper[a])
        return false;
      continue;
    }
    double ta = (0.0 - p) / d, tb = (upper[a] - p) / d;
    if (ta > tb)
    {
      const double swap = ta;
      ta = tb;
      tb = swap;
    }
    t0 = ta > t0 ? ta : t0;
    t1 = tb < t1 ? tb : t1;
  }
  if (!(t0 < t1))
    return false;
  // The dominant axis (the first of equals, as Eigen's maxCoeff).
  int a = 0;
  for (int k = 1; k < 3; ++k)
    if (fabs(direction[k]) > fabs(direction[a]))
      a = k;
  const int b = a == 0 ? 1 : 0, cc = 3 - a - b;
  const double da = direction[a];
  const double entryA = start[a] + t0 * da;
  const int m0 = static_cast<int>(da > 0 ? ceil(entryA) : floor(entryA));
  const double tFirst = (m0 - start[a]) / da;
  const double dt = 1.0 / fabs(da);
  out.axis = a;
  out.b = b;
  out.c = cc;
  out.m0 = m0;
  out.sa = da > 0 ? 1 : -1;
  out.dt = dt;
  out.count = static_cast<int>(ceil((t1 - tFirst) / dt));
  out.b0 = static_cast<float>(start[b] + tFirst * direction[b]);
  out.db = static_cast<float>(dt * direction[b]);
  out.c0 = static_cast<float>(start[cc] + tFirst * direction[cc]);
  out.dc = static_cast<float>(dt * direction[cc]);
  out.upperB = static_cast<float>(upper[b]);
  out.upperC = static_cast<float>(upper[cc]);
  return out.count > 0;
}

/** Sample j of a ray: bilinear on its plane, in volume steps. `voxel(x, y, z)` reads a padded voxel. */
template <typename Voxel>
XP_HOST_DEVICE float Sample(const Planes& p, int j, const Voxel& voxel)
{
  const float fj = static_cast<float>(j);
  float bf = p.b0 + fj * p.db, cf = p.c0 + fj * p.dc;
  bf = fminf(fmaxf(bf, 0.0f), p.upperB);
  cf = fminf(fmaxf(cf, 0.0f), p.upperC);
  const int ib = static_cast<int>(bf), ic = static_cast<int>(cf);
  const float fb = bf - static_cast<float>(ib), fc = cf - static_cast<float>(ic);
  int at[3];
  at[p.axis] = p.m0 + p.sa * j;
  at[p.b] = ib;
  at[p.c] = ic;
  const float v00 = voxel(at[0], at[1], at[2]);
  at[p.b] = ib + 1;
  const float v10 = voxel(at[0], at[1], at[2]);
  at[p.c] = ic + 1;
  const float v11 = voxel(at[0], at[1], at[2]);
  at[p.b] = ib;
  const float v01 = voxel(at[0], at[1], at[2]);
  const float low = v00 + fb * (v10 - v00);
  const float high = v01 + fb * (v11 - v01);
  return low + fc * (high - low);
}

/** The line integral of mu (dimensionless) for `pixel` of `job`. */
template <typename Voxel>
XP_HOST_DEVICE float LineIntegral(const Job& job, const Grid& grid, int pixel, const Voxel& voxel)
{
  Planes planes;
  if (!SetUp(job, grid, pixel, planes))
    return 0.0f;
  float sum = 0.0f;
  for (int j = 0; j < planes.count; ++j)
    sum += Sample(planes, j, voxel);
  return static_cast<float>(sum * planes.dt * grid.quantum);
}

} // namespace joseph
} // namespace xp

#endif
