#include "xpRayCaster.h"

#include "xpAttenuationVolume.h"
#include "xpCudaRayCaster.h"
#include "xpError.h"
#include "xpExactVectors.h"
#include "xpParallel.h"
#include "xpXRayView.h"

#include <immintrin.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <mutex>
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

// Clang refuses noinline beside target_clones; GCC builds keep it as they always had it.
#if defined(__clang__)
#define XP_AVX2_AND_BASELINE __attribute__((target_clones("avx2", "default")))
#else
#define XP_AVX2_AND_BASELINE __attribute__((target_clones("avx2", "default"), noinline))
#endif

/**
 * Sum of trilinear samples k0 <= k < k1 at start + (k + 0.5) * step * direction, in volume steps
 * (AttenuationVolume::Quantum). Built twice (AVX2 and baseline) and picked at load time.
 */
XP_AVX2_AND_BASELINE float SampleRun(const uint16_t* voxels, long nx,
  long nxy, const float start[3], const float step[3], long k0, long k1, const float upper[3])
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
    const uint16_t* c = voxels + ix + iy * nx + iz * nxy;
    const float c00 = c[0] + fx * (float(c[1]) - c[0]);
    const float c10 = c[nx] + fx * (float(c[nx + 1]) - c[nx]);
    const float c01 = c[nxy] + fx * (float(c[nxy + 1]) - c[nxy]);
    const float c11 = c[nxy + nx] + fx * (float(c[nxy + nx + 1]) - c[nxy + nx]);
    const float c0 = c00 + fy * (c10 - c00);
    const float c1 = c01 + fy * (c11 - c01);
    sum += c0 + fz * (c1 - c0);
  }
  return sum;
}

/**
 * Samples j0 <= j < j1 on the voxel planes of axis a: plane index m0 + sa*j along a, the two other
 * coordinates (b, c) linear in j. On a voxel plane trilinear interpolation is bilinear in the
 * other two axes: 4 voxels a sample. Axis b is the fastest of the layout read (stride 1), so a
 * sample's two b-neighbours are adjacent. Offsets are 32-bit (volumes hold < 2^31 voxels).
 */
struct PlaneRun
{
  const uint16_t* voxels;
  int strideA, strideC, m0, sa;
  float b0, db, c0, dc, upperB, upperC;
};

inline float PlaneSample(const PlaneRun& r, int j)
{
  const float b = std::min(std::max(r.b0 + static_cast<float>(j) * r.db, 0.0f), r.upperB);
  const float c = std::min(std::max(r.c0 + static_cast<float>(j) * r.dc, 0.0f), r.upperC);
  const int ib = static_cast<int>(b), ic = static_cast<int>(c);
  const float fb = b - static_cast<float>(ib), fc = c - static_cast<float>(ic);
  const uint16_t* v = r.voxels + (r.m0 + r.sa * j) * r.strideA + ib + ic * r.strideC;
  const float low = v[0] + fb * (float(v[1]) - v[0]);
  const float high = v[r.strideC] + fb * (float(v[r.strideC + 1]) - v[r.strideC]);
  return low + fc * (high - low);
}

/** The first multiple of `step` at or after q. */
inline int FirstMultipleFrom(int q, int step)
{
  const int past = ((q % step) + step) % step;
  return past == 0 ? q : q + step - past;
}

/** The samples j0 <= j < j1 whose plane m0 + sa j is a multiple of `step` (every one with 1). */
float SamplePlanesScalar(const PlaneRun& r, int j0, int j1, int step)
{
  // With q = sa m: sample j = q - sa m0 lies on a kept plane where q is a multiple of step.
  const int planeOfFirst = r.sa * r.m0;
  float sum = 0.0f;
  for (int j = FirstMultipleFrom(planeOfFirst + j0, step) - planeOfFirst; j < j1; j += step)
  {
    sum += PlaneSample(r, j);
  }
  return sum;
}

/**
 * Walks the 32^3 blocks that the ray crosses from tEnter to tExit (a 3D DDA, Amanatides & Woo, at
 * most bx + by + bz steps) and calls visit(occupied, t) with each block's flag and the t (mm) at
 * which the ray enters it, while visit returns true. Returns the t at which the walk ended.
 */
template <typename Visit>
double WalkBlocks(const AttenuationVolume& volume, const IndexRay& ray, double tEnter, double tExit, Visit visit)
{
  const double blockSize = 1 << AttenuationVolume::BlockShift;
  const Eigen::Vector3i& blocks = volume.BlockDimensions();
  const Eigen::Vector3d entry = ray.start + tEnter * ray.direction;
  // Per axis: the next boundary crossing (t), its spacing, the step in the flat block index, and
  // how many more steps stay inside the grid. Scalars, not arrays, so they live in registers, and
  // the step is branch-free: the loop's axis choice would mispredict on most rays.
  double tNext[3], tDelta[3];
  long stride[3], left[3];
  long index = 0;
  const long blockStrides[3] = { 1, blocks[0], static_cast<long>(blocks[0]) * blocks[1] };
  for (int a = 0; a < 3; ++a)
  {
    const int cell = std::clamp(static_cast<int>(entry[a] / blockSize), 0, blocks[a] - 1);
    const double d = ray.direction[a];
    index += cell * blockStrides[a];
    stride[a] = d > 0 ? blockStrides[a] : -blockStrides[a];
    left[a] = d > 0 ? blocks[a] - 1 - cell : cell;
    tNext[a] = d == 0.0 ? Infinity : ((cell + (d > 0 ? 1 : 0)) * blockSize - ray.start[a]) / d;
    tDelta[a] = d == 0.0 ? Infinity : blockSize / std::abs(d);
  }
  double tx = tNext[0], ty = tNext[1], tz = tNext[2];
  long lx = left[0], ly = left[1], lz = left[2];
  const uint8_t* occupied = volume.OccupancyGrid();
  double t = tEnter;
  while (t < tExit)
  {
    if (!visit(occupied[index] != 0, t))
    {
      return t;
    }
    // Step every axis whose boundary comes first (two at once through an edge).
    const double tStep = std::min(tx, std::min(ty, tz));
    const long sx = tx == tStep, sy = ty == tStep, sz = tz == tStep;
    t = std::min(tStep, tExit);
    index += sx * stride[0] + sy * stride[1] + sz * stride[2];
    tx += sx ? tDelta[0] : 0.0;
    ty += sy ? tDelta[1] : 0.0;
    tz += sz ? tDelta[2] : 0.0;
    lx -= sx;
    ly -= sy;
    lz -= sz;
    if ((lx | ly | lz) < 0)
    {
      break;
    }
  }
  return std::min(t, tExit);
}

/** Calls run(start, end) for each stretch of the ray, in t (mm), that crosses occupied blocks. */
template <typename RunFunction>
void ForEachOccupiedRun(const AttenuationVolume& volume, const IndexRay& ray, double tEnter, double tExit, RunFunction run)
{
  double runStart = -1.0;
  const double tEnd = WalkBlocks(volume, ray, tEnter, tExit,
    [&](bool occupied, double t)
    {
      if (occupied)
      {
        runStart = runStart < 0.0 ? t : runStart;
      }
      else if (runStart >= 0.0)
      {
        run(runStart, t);
        runStart = -1.0;
      }
      return true;
    });
  if (runStart >= 0.0)
  {
    run(runStart, tEnd);
  }
}

/** The t at which the ray enters its first occupied block after tEnter, Infinity if none. */
double FirstOccupied(const AttenuationVolume& volume, const IndexRay& ray, double tEnter, double tExit)
{
  double first = Infinity;
  WalkBlocks(volume, ray, tEnter, tExit,
    [&](bool occupied, double t)
    {
      first = occupied ? t : first;
      return !occupied;
    });
  return first;
}

/**
 * From where the ray enters its first occupied block to where it leaves its last one, walking in
 * from both ends: only the empty blocks outside the patient are visited. False if none.
 */
bool OccupiedSpan(const AttenuationVolume& volume, const IndexRay& ray, double tEnter, double tExit, double& tFirst,
  double& tLast)
{
  tFirst = FirstOccupied(volume, ray, tEnter, tExit);
  if (tFirst == Infinity)
  {
    return false;
  }
  // The same walk on the reversed ray, whose u runs back from tExit: t = tEnter + tExit - u.
  const double mirror = tEnter + tExit;
  const IndexRay reversed{ ray.start + mirror * ray.direction, -ray.direction, ray.length };
  const double uLast = FirstOccupied(volume, reversed, tEnter, mirror - tFirst);
  tLast = uLast == Infinity ? tExit : mirror - uLast;
  return true;
}

/** Clips a ray to where trilinear samples may be taken: padded coordinates in [0, padded - 1). */
bool ClipForInterpolation(const AttenuationVolume& volume, const IndexRay& ray, double& tEnter, double& tExit,
  Eigen::Vector3d& upper)
{
  upper = volume.PaddedDimensions().cast<double>() - Eigen::Vector3d::Constant(1.0 + 1e-4);
  return ClipToBox(ray, Eigen::Vector3d::Zero(), upper, tEnter, tExit);
}

/** Trilinear line integral at a fixed step (mm), sampling only occupied blocks. */
double TraceTrilinear(const AttenuationVolume& volume, const IndexRay& ray, double step)
{
  double tEnter, tExit;
  Eigen::Vector3d upperD;
  if (!ClipForInterpolation(volume, ray, tEnter, tExit, upperD))
  {
    return 0.0;
  }
  const float upper[3] = { float(upperD[0]), float(upperD[1]), float(upperD[2]) };
  const long nx = volume.PaddedDimensions()[0], nxy = nx * volume.PaddedDimensions()[1];
  const Eigen::Vector3d s = ray.start + tEnter * ray.direction, d = step * ray.direction;
  const float start[3] = { float(s[0]), float(s[1]), float(s[2]) }, dir[3] = { float(d[0]), float(d[1]), float(d[2]) };
  double sum = 0.0;
  ForEachOccupiedRun(volume, ray, tEnter, tExit,
    [&](double runStart, double runEnd)
    {
      // Samples of the ray's own lattice tEnter + (k + 0.5) step that fall in [runStart, runEnd).
      const long k0 = static_cast<long>(std::ceil((runStart - tEnter) / step - 0.5));
      const long k1 = static_cast<long>(std::ceil((runEnd - tEnter) / step - 0.5));
      if (k1 > k0)
      {
        sum += SampleRun(volume.Voxels(), nx, nxy, start, dir, k0, k1, upper);
      }
    });
  return sum * step * volume.Quantum();
}

/**
 * A ray set up for Joseph's scheme: one sample on every voxel plane of its dominant axis a (the
 * step is spacing / |cos| along the ray), each sample bilinear on its plane.
 */
struct PlaneRay
{
  PlaneRun planes{};
  int axis = -1; ///< a; -1 when the ray misses the volume
  double tEnter = 0.0, tExit = 0.0;
  double t0 = 0.0; ///< t of sample j = 0, the first plane at or after the entry
  double dt = 0.0; ///< mm between planes along the ray

  /** One past the ray's last sample (the samples of [tEnter, tExit)). */
  int EndSample() const { return static_cast<int>(std::ceil((this->tExit - this->t0) / this->dt)); }

  /** The samples j0 <= j < j1 that lie in [runStart, runEnd). */
  void SamplesIn(double runStart, double runEnd, int& j0, int& j1) const
  {
    j0 = std::max(0, static_cast<int>(std::ceil((runStart - this->t0) / this->dt)));
    j1 = static_cast<int>(std::ceil((std::min(runEnd, this->tExit) - this->t0) / this->dt));
  }
};

PlaneRay SetUpPlaneRay(const AttenuationVolume& volume, const IndexRay& ray)
{
  PlaneRay out;
  Eigen::Vector3d upper;
  if (!ClipForInterpolation(volume, ray, out.tEnter, out.tExit, upper))
  {
    return out;
  }
  int a = 0;
  ray.direction.cwiseAbs().maxCoeff(&a);
  // Interpolate along b = x, or along b = y in the y-fastest copy when the ray steps along x: then
  // the two b-neighbours of a sample are adjacent in memory.
  const int b = a == 0 ? 1 : 0, c = 3 - a - b;
  const double da = ray.direction[a];
  const int nx = volume.PaddedDimensions()[0], ny = volume.PaddedDimensions()[1], nxy = nx * ny;
  const bool yFastest = a == 0;
  const int strides[3] = { yFastest ? ny : 1, yFastest ? 1 : nx, nxy }; // strides[b] == 1
  const double entryA = ray.start[a] + out.tEnter * da;
  const int m0 = static_cast<int>(da > 0 ? std::ceil(entryA) : std::floor(entryA));
  out.axis = a;
  out.t0 = (m0 - ray.start[a]) / da;
  out.dt = 1.0 / std::abs(da);
  const Eigen::Vector3d first = ray.start + out.t0 * ray.direction, perPlane = out.dt * ray.direction;
  out.planes = PlaneRun{ yFastest ? volume.VoxelsYFastest() : volume.Voxels(), strides[a], strides[c], m0,
    da > 0 ? 1 : -1, float(first[b]), float(perPlane[b]), float(first[c]), float(perPlane[c]), float(upper[b]),
    float(upper[c]) };
  return out;
}

/** Trilinear line integral on the voxel planes (every planeSteps[a]-th along the ray's dominant
 *  axis a), one ray at a time, only in occupied blocks. */
double TracePlanes(const AttenuationVolume& volume, const IndexRay& ray, const std::array<int, 3>& planeSteps)
{
  const PlaneRay planeRay = SetUpPlaneRay(volume, ray);
  if (planeRay.axis < 0)
  {
    return 0.0;
  }
  const int step = planeSteps[planeRay.axis];
  double sum = 0.0;
  ForEachOccupiedRun(volume, ray, planeRay.tEnter, planeRay.tExit,
    [&](double runStart, double runEnd)
    {
      int j0, j1;
      planeRay.SamplesIn(runStart, runEnd, j0, j1);
      if (j1 > j0)
      {
        sum += SamplePlanesScalar(planeRay.planes, j0, j1, step);
      }
    });
  return sum * step * planeRay.dt * volume.Quantum();
}

/** Sixteen rays sampled together, lane r for ray r (neighbours in a tile's row); lanes with first
 *  >= last take no samples. AVX-512 samples all sixteen at once, AVX2 eight at a time. */
struct RayPacket
{
  static constexpr int Size = TracedPixels::PacketSize;
  PlaneRay rays[Size];
  int first[Size] = {}; ///< first sample j in an occupied block
  int last[Size] = {};  ///< one past the last
};

/**
 * The planes ahead whose lines are fetched while one is sampled: a plane's lines are far from the
 * last one's (a slice or a row apart), and without the fetch every plane waits for memory. Three
 * planes ahead measured fastest, twelve and more slower again (Performance.md, "The packets'
 * gathers").
 */
constexpr int PrefetchPlanes = 3;

/**
 * The constants of `Lanes` lanes of a packet from lane0 on, for sampling its rays on `axis` in
 * direction `sa`: sample j of ray r lies on plane m = m0_r + sa j, so with q = sa m every lane's
 * j = q - sa m0_r, and a lane samples while beforeFirst < j < last. Lanes of other rays take none.
 */
template <int Lanes>
struct PacketLanes
{
  alignas(64) int planeOfFirst[Lanes], beforeFirst[Lanes], last[Lanes];
  alignas(64) float b0[Lanes], db[Lanes], c0[Lanes], dc[Lanes];
  int qBegin = std::numeric_limits<int>::max(), qEnd = std::numeric_limits<int>::min();
  const PlaneRun* common = nullptr; ///< a sampling lane's planes (strides, bounds); null when none samples

  PacketLanes(const RayPacket& packet, int lane0, int axis, int sa)
  {
    for (int r = 0; r < Lanes; ++r)
    {
      const int n = lane0 + r;
      const PlaneRun& planes = packet.rays[n].planes;
      const bool mine = packet.rays[n].axis == axis && planes.sa == sa && packet.first[n] < packet.last[n];
      this->planeOfFirst[r] = mine ? sa * planes.m0 : 0;
      this->beforeFirst[r] = mine ? packet.first[n] - 1 : 0;
      this->last[r] = mine ? packet.last[n] : 0;
      this->b0[r] = planes.b0, this->db[r] = planes.db, this->c0[r] = planes.c0, this->dc[r] = planes.dc;
      if (mine)
      {
        this->common = &planes;
        this->qBegin = std::min(this->qBegin, this->planeOfFirst[r] + packet.first[n]);
        this->qEnd = std::max(this->qEnd, this->planeOfFirst[r] + packet.last[n]);
      }
    }
  }
};

/**
 * The line integrals (in volume steps) of eight of a packet's rays from lane0 on, on `axis`
 * stepping in direction `sa`, with AVX2 gathers; lanes of other rays get 0. One iteration samples
 * the same voxel plane for all eight rays: neighbours on the detector, they read a few cache lines
 * that they share, where one ray at a time would stream each of its lines through the cache once
 * per ray. The samples are PlaneSample's (same planes, voxels and weights, up to FMA rounding); in
 * empty blocks between occupied ones they are 0.
 */
__attribute__((target("avx2,fma"))) void SamplePacketAVX2(
  const RayPacket& packet, int lane0, int axis, int sa, int step, float* sums)
{
  const PacketLanes<8> lanes(packet, lane0, axis, sa);
  const PlaneRun* common = lanes.common;
  if (!common)
  {
    std::fill(sums, sums + 8, 0.0f);
    return;
  }
  const __m256i vPlaneOfFirst = _mm256_load_si256(reinterpret_cast<const __m256i*>(lanes.planeOfFirst));
  const __m256i vBeforeFirst = _mm256_load_si256(reinterpret_cast<const __m256i*>(lanes.beforeFirst));
  const __m256i vLast = _mm256_load_si256(reinterpret_cast<const __m256i*>(lanes.last));
  const __m256 vb0 = _mm256_load_ps(lanes.b0), vdb = _mm256_load_ps(lanes.db), vc0 = _mm256_load_ps(lanes.c0),
               vdc = _mm256_load_ps(lanes.dc);
  const __m256i low16 = _mm256_set1_epi32(0xFFFF), none = _mm256_setzero_si256();
  const __m256 zero = _mm256_setzero_ps(), upperB = _mm256_set1_ps(common->upperB),
               upperC = _mm256_set1_ps(common->upperC);
  const __m256i strideC = _mm256_set1_epi32(common->strideC);
  const int* words = reinterpret_cast<const int*>(common->voxels); // scale 2: indices count voxels
  const intptr_t origin = reinterpret_cast<intptr_t>(common->voxels);
  const int planeStride = sa * common->strideA; // m strideA = q planeStride
  __m256 sum = _mm256_setzero_ps();
  // Only the planes that are multiples of step (q = sa m is one where m is).
  for (int q = FirstMultipleFrom(lanes.qBegin, step); q < lanes.qEnd; q += step)
  {
    const __m256i j = _mm256_sub_epi32(_mm256_set1_epi32(q), vPlaneOfFirst);
    // Lanes outside their ray's samples gather nothing (their plane may lie outside the volume).
    const __m256i active = _mm256_and_si256(_mm256_cmpgt_epi32(j, vBeforeFirst), _mm256_cmpgt_epi32(vLast, j));
    const __m256 jf = _mm256_cvtepi32_ps(j);
    const __m256 b = _mm256_min_ps(_mm256_max_ps(_mm256_fmadd_ps(jf, vdb, vb0), zero), upperB);
    const __m256 c = _mm256_min_ps(_mm256_max_ps(_mm256_fmadd_ps(jf, vdc, vc0), zero), upperC);
    const __m256i ib = _mm256_cvttps_epi32(b), ic = _mm256_cvttps_epi32(c);
    const __m256 fb = _mm256_sub_ps(b, _mm256_cvtepi32_ps(ib)), fc = _mm256_sub_ps(c, _mm256_cvtepi32_ps(ic));
    const __m256i base =
      _mm256_add_epi32(_mm256_add_epi32(_mm256_set1_epi32(q * planeStride), ib), _mm256_mullo_epi32(ic, strideC));
    // The lines of the first and last ray PrefetchPlanes ahead. Addresses in integers: past the
    // volume's end they are hints, which never fault.
    const intptr_t aheadFirst = _mm256_cvtsi256_si32(base) + PrefetchPlanes * planeStride;
    const intptr_t aheadLast = _mm256_extract_epi32(base, 7) + PrefetchPlanes * planeStride;
    for (const intptr_t voxel : { aheadFirst, aheadFirst + common->strideC, aheadLast, aheadLast + common->strideC })
    {
      _mm_prefetch(reinterpret_cast<const char*>(origin + voxel * intptr_t(sizeof(uint16_t))), _MM_HINT_T0);
    }
    // One 32-bit element holds a voxel and its b-neighbour: two gathers fetch the four voxels.
    const __m256i w0 = _mm256_mask_i32gather_epi32(none, words, base, active, 2);
    const __m256i w1 = _mm256_mask_i32gather_epi32(none, words, _mm256_add_epi32(base, strideC), active, 2);
    const __m256 v00 = _mm256_cvtepi32_ps(_mm256_and_si256(w0, low16)), v10 = _mm256_cvtepi32_ps(_mm256_srli_epi32(w0, 16));
    const __m256 v01 = _mm256_cvtepi32_ps(_mm256_and_si256(w1, low16)), v11 = _mm256_cvtepi32_ps(_mm256_srli_epi32(w1, 16));
    const __m256 low = _mm256_fmadd_ps(fb, _mm256_sub_ps(v10, v00), v00);
    const __m256 high = _mm256_fmadd_ps(fb, _mm256_sub_ps(v11, v01), v01);
    sum = _mm256_add_ps(sum, _mm256_fmadd_ps(fc, _mm256_sub_ps(high, low), low));
  }
  _mm256_storeu_ps(sums, sum);
}

/**
 * SamplePacketAVX2 for all sixteen rays at once with AVX-512: the same samples, weights and order
 * of sums per lane, so the same integrals to the bit (lanes outside their samples add +0). Where
 * the active lanes' voxels on a plane lie in one or two neighbouring c rows, within 31 voxels
 * along b of the first one's (the common case: a packet is a run of neighbouring pixels of one
 * detector row), each of those rows and the one above is read with two 64-byte loads and a word
 * permutation, instead of two sixteen-element gathers, which cost about as much as the rest of
 * the sample together (Performance.md, "The packets' gathers"). Elsewhere (a masked packet's lanes
 * in rows of the panel far apart, a volume's first or last voxels), the gathers.
 * `voxelCount` is the length of the voxel array (AttenuationVolume::VoxelCount). Without
 * `RowLoads` (VoxelReads::Gathers), the gathers everywhere.
 */
template <bool RowLoads>
__attribute__((target("avx512f,avx512bw"))) void SamplePacketAVX512(
  const RayPacket& packet, int axis, int sa, int step, long long voxelCount, float* sums)
{
  const PacketLanes<16> lanes(packet, 0, axis, sa);
  const PlaneRun* common = lanes.common;
  if (!common)
  {
    std::fill(sums, sums + 16, 0.0f);
    return;
  }
  const __m512i vPlaneOfFirst = _mm512_load_si512(lanes.planeOfFirst);
  const __m512i vBeforeFirst = _mm512_load_si512(lanes.beforeFirst);
  const __m512i vLast = _mm512_load_si512(lanes.last);
  const __m512 vb0 = _mm512_load_ps(lanes.b0), vdb = _mm512_load_ps(lanes.db), vc0 = _mm512_load_ps(lanes.c0),
               vdc = _mm512_load_ps(lanes.dc);
  const __m512i low16 = _mm512_set1_epi32(0xFFFF), none = _mm512_setzero_si512();
  const __m512 zero = _mm512_setzero_ps(), upperB = _mm512_set1_ps(common->upperB),
               upperC = _mm512_set1_ps(common->upperC);
  const __m512i strideC = _mm512_set1_epi32(common->strideC);
  const int* words = reinterpret_cast<const int*>(common->voxels);
  const uint16_t* voxels = common->voxels;
  const intptr_t origin = reinterpret_cast<intptr_t>(common->voxels);
  const int planeStride = sa * common->strideA;
  // A lane's word offset d from the reference voxel r must satisfy -31 <= d <= 30: its pair of
  // words (d + 31, d + 32) then lies in the 64 words from r - 31. The three rows' loads stay in
  // the array where r - 31 >= 0 and r + 2 strideC + 33 <= voxelCount.
  const __m512i reach = _mm512_set1_epi32(31), span = _mm512_set1_epi32(61);
  const long long lastReference = voxelCount - 33 - 2LL * common->strideC;
  __m512 sum = _mm512_setzero_ps();
  for (int q = FirstMultipleFrom(lanes.qBegin, step); q < lanes.qEnd; q += step)
  {
    const __m512i j = _mm512_sub_epi32(_mm512_set1_epi32(q), vPlaneOfFirst);
    const __mmask16 active = _mm512_cmpgt_epi32_mask(j, vBeforeFirst) & _mm512_cmpgt_epi32_mask(vLast, j);
    const __m512 jf = _mm512_cvtepi32_ps(j);
    const __m512 b = _mm512_min_ps(_mm512_max_ps(_mm512_fmadd_ps(jf, vdb, vb0), zero), upperB);
    const __m512 c = _mm512_min_ps(_mm512_max_ps(_mm512_fmadd_ps(jf, vdc, vc0), zero), upperC);
    const __m512i ib = _mm512_cvttps_epi32(b), ic = _mm512_cvttps_epi32(c);
    const __m512 fb = _mm512_sub_ps(b, _mm512_cvtepi32_ps(ib)), fc = _mm512_sub_ps(c, _mm512_cvtepi32_ps(ic));
    const __m512i base =
      _mm512_add_epi32(_mm512_add_epi32(_mm512_set1_epi32(q * planeStride), ib), _mm512_mullo_epi32(ic, strideC));
    const intptr_t aheadFirst = _mm_cvtsi128_si32(_mm512_castsi512_si128(base)) + PrefetchPlanes * planeStride;
    const intptr_t aheadLast =
      _mm_extract_epi32(_mm512_extracti32x4_epi32(base, 3), 3) + PrefetchPlanes * planeStride;
    for (const intptr_t voxel : { aheadFirst, aheadFirst + common->strideC, aheadLast, aheadLast + common->strideC })
    {
      _mm_prefetch(reinterpret_cast<const char*>(origin + voxel * intptr_t(sizeof(uint16_t))), _MM_HINT_T0);
    }
    __m512i w0 = none, w1 = none;
    if (active)
    {
      // Rows: the lowest active lane's c row (the first active lane's, or the one below it) and
      // the next; offsets within the lowest row, from the first active lane's voxel there (the
      // reference r).
      const __m512i first = _mm512_set1_epi32(__builtin_ctz(active));
      const __m512i icFirst = _mm512_permutexvar_epi32(first, ic);
      const __mmask16 below = _mm512_mask_cmplt_epi32_mask(active, ic, icFirst);
      const __m512i rowOffset =
        _mm512_sub_epi32(ic, below ? _mm512_sub_epi32(icFirst, _mm512_set1_epi32(1)) : icFirst);
      const __mmask16 second = _mm512_mask_cmpeq_epi32_mask(active, rowOffset, _mm512_set1_epi32(1));
      const __mmask16 twoRows = _mm512_mask_cmple_epu32_mask(active, rowOffset, _mm512_set1_epi32(1));
      const __m512i inLowest = _mm512_mask_sub_epi32(base, second, base, strideC);
      const __m512i reference = _mm512_permutexvar_epi32(first, inLowest);
      const __m512i d = _mm512_sub_epi32(inLowest, reference);
      const long long r = _mm_cvtsi128_si32(_mm512_castsi512_si128(reference));
      const __mmask16 near = _mm512_mask_cmple_epu32_mask(active, _mm512_add_epi32(d, reach), span);
      if (RowLoads && (near & twoRows) == active && r >= 31 && r <= lastReference)
      {
        // Word i of a lane's element: the voxel d + 31 + i words after r - 31 in its row, as the
        // gather's. Row k (0 to 2): the 64 words from r - 31 + k strideC.
        const __m512i pair = _mm512_or_si512(
          _mm512_add_epi32(d, reach), _mm512_slli_epi32(_mm512_add_epi32(d, _mm512_set1_epi32(32)), 16));
        const uint16_t* row0 = voxels + r - 31;
        const uint16_t* row1 = row0 + common->strideC;
        const __m512i p0 = _mm512_permutex2var_epi16(_mm512_loadu_si512(row0), pair, _mm512_loadu_si512(row0 + 32));
        const __m512i p1 = _mm512_permutex2var_epi16(_mm512_loadu_si512(row1), pair, _mm512_loadu_si512(row1 + 32));
        if (!second)
        {
          w0 = _mm512_maskz_mov_epi32(active, p0);
          w1 = _mm512_maskz_mov_epi32(active, p1);
        }
        else
        {
          const uint16_t* row2 = row1 + common->strideC;
          const __m512i p2 = _mm512_permutex2var_epi16(_mm512_loadu_si512(row2), pair, _mm512_loadu_si512(row2 + 32));
          w0 = _mm512_maskz_mov_epi32(active, _mm512_mask_blend_epi32(second, p0, p1));
          w1 = _mm512_maskz_mov_epi32(active, _mm512_mask_blend_epi32(second, p1, p2));
        }
      }
      else
      {
        w0 = _mm512_mask_i32gather_epi32(none, active, base, words, 2);
        w1 = _mm512_mask_i32gather_epi32(none, active, _mm512_add_epi32(base, strideC), words, 2);
      }
    }
    const __m512 v00 = _mm512_cvtepi32_ps(_mm512_and_si512(w0, low16)), v10 = _mm512_cvtepi32_ps(_mm512_srli_epi32(w0, 16));
    const __m512 v01 = _mm512_cvtepi32_ps(_mm512_and_si512(w1, low16)), v11 = _mm512_cvtepi32_ps(_mm512_srli_epi32(w1, 16));
    const __m512 low = _mm512_fmadd_ps(fb, _mm512_sub_ps(v10, v00), v00);
    const __m512 high = _mm512_fmadd_ps(fb, _mm512_sub_ps(v11, v01), v01);
    sum = _mm512_add_ps(sum, _mm512_fmadd_ps(fc, _mm512_sub_ps(high, low), low));
  }
  _mm512_storeu_ps(sums, sum);
}

// Initialised before main: the CPU's features read explicitly first (__builtin_cpu_init), as
// a constructor's use of them must not rely on libgcc's own running before it.
const bool HaveAVX2 = (__builtin_cpu_init(), __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"));
const bool HaveAVX512 = HaveAVX2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw");
const bool IsAMD = __builtin_cpu_is("amd");
const bool HaveAVX512VL = HaveAVX512 && __builtin_cpu_supports("avx512vl");

/** Eight doubles, the given lanes of b where `pick`, of a elsewhere. */
#define XP_PICK(pick, a, b) _mm512_mask_mov_pd((a), (pick), (b))

/**
 * FirstOccupied for eight rays at once: each lane walks the blocks as WalkBlocks does (the same
 * operations in the same order; std::min's and std::max's choices on ties), until its ray enters
 * an occupied block, leaves the grid or reaches tExit. Lanes not in `lanes` take no step; their
 * result is Infinity.
 */
XP_EXACT_AVX512 __m512d FirstOccupiedAVX512(const AttenuationVolume& volume, const __m512d start[3], const __m512d direction[3],
  __m512d tEnter, __m512d tExit, __mmask8 lanes)
{
  const __m512d blockSize = _mm512_set1_pd(static_cast<double>(1 << AttenuationVolume::BlockShift));
  const __m512d zero = _mm512_setzero_pd(), infinity = _mm512_set1_pd(Infinity);
  const Eigen::Vector3i& blocks = volume.BlockDimensions();
  const int blockStrides[3] = { 1, blocks[0], blocks[0] * blocks[1] };
  __m512d tNext[3], tDelta[3];
  __m256i stride[3], left[3];
  __m256i index = _mm256_setzero_si256();
  for (int a = 0; a < 3; ++a)
  {
    const __m512d entry = _mm512_add_pd(start[a], _mm512_mul_pd(tEnter, direction[a]));
    __m256i cell = _mm512_cvttpd_epi32(_mm512_div_pd(entry, blockSize));
    cell = _mm256_min_epi32(_mm256_max_epi32(cell, _mm256_setzero_si256()), _mm256_set1_epi32(blocks[a] - 1));
    const __m512d d = direction[a];
    const __mmask8 positive = _mm512_cmp_pd_mask(d, zero, _CMP_GT_OQ), flat = _mm512_cmp_pd_mask(d, zero, _CMP_EQ_OQ);
    index = _mm256_add_epi32(index, _mm256_mullo_epi32(cell, _mm256_set1_epi32(blockStrides[a])));
    stride[a] = _mm256_mask_mov_epi32(_mm256_set1_epi32(-blockStrides[a]), positive, _mm256_set1_epi32(blockStrides[a]));
    left[a] = _mm256_mask_mov_epi32(cell, positive, _mm256_sub_epi32(_mm256_set1_epi32(blocks[a] - 1), cell));
    const __m256i boundary = _mm256_mask_add_epi32(cell, positive, cell, _mm256_set1_epi32(1));
    const __m512d next = _mm512_div_pd(_mm512_sub_pd(_mm512_mul_pd(_mm512_cvtepi32_pd(boundary), blockSize), start[a]), d);
    tNext[a] = XP_PICK(flat, next, infinity);
    tDelta[a] = XP_PICK(flat, _mm512_div_pd(blockSize, _mm512_abs_pd(d)), infinity);
  }
  const uint8_t* occupied = volume.OccupancyGrid();
  __m512d t = tEnter, first = infinity;
  __mmask8 active = lanes;
  while (true)
  {
    active &= _mm512_cmp_pd_mask(t, tExit, _CMP_LT_OQ);
    if (!active)
      break;
    alignas(32) int at[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(at), index);
    __mmask8 found = 0;
    for (int l = 0; l < 8; ++l)
      if (((active >> l) & 1) && occupied[at[l]] != 0)
        found |= static_cast<__mmask8>(1u << l);
    first = _mm512_mask_mov_pd(first, found, t);
    active &= static_cast<__mmask8>(~found);
    if (!active)
      break;
    // std::min(tx, std::min(ty, tz)): (b < a) ? b : a at each step.
    const __m512d yz = XP_PICK(_mm512_cmp_pd_mask(tNext[2], tNext[1], _CMP_LT_OQ), tNext[1], tNext[2]);
    const __m512d tStep = XP_PICK(_mm512_cmp_pd_mask(yz, tNext[0], _CMP_LT_OQ), tNext[0], yz);
    t = _mm512_mask_mov_pd(t, active, XP_PICK(_mm512_cmp_pd_mask(tExit, tStep, _CMP_LT_OQ), tStep, tExit));
    __mmask8 exhausted = 0;
    for (int a = 0; a < 3; ++a)
    {
      const __mmask8 steps = active & _mm512_cmp_pd_mask(tNext[a], tStep, _CMP_EQ_OQ);
      index = _mm256_mask_add_epi32(index, steps, index, stride[a]);
      // tNext + (steps ? tDelta : 0.0), as the scalar walk adds.
      tNext[a] = _mm512_mask_add_pd(tNext[a], active, tNext[a], _mm512_maskz_mov_pd(steps, tDelta[a]));
      left[a] = _mm256_mask_sub_epi32(left[a], steps, left[a], _mm256_set1_epi32(1));
      exhausted |= _mm256_cmp_epi32_mask(left[a], _mm256_setzero_si256(), _MM_CMPINT_LT);
    }
    active &= static_cast<__mmask8>(~exhausted);
  }
  return first;
}

/** Per lane, v[0] where `x`, v[1] where `y`, else v[2]. (Functions, not lambdas: Clang does not
 *  give a lambda its enclosing function's target.) */
XP_EXACT_AVX512 inline __m512d AlongAxis(const __m512d v[3], __mmask8 x, __mmask8 y)
{
  return XP_PICK(y, XP_PICK(x, v[2], v[0]), v[1]);
}

/** static_cast<int>(std::ceil(x)) per lane. */
XP_EXACT_AVX512 inline __m256i CeilToInt(__m512d x)
{
  return _mm512_cvttpd_epi32(_mm512_roundscale_pd(x, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
}

/** What a vector set-up found for its `Lanes` rays, per lane; the masks hold bit l for lane l. */
template <int Lanes>
struct LaneSetUps
{
  alignas(64) double tEnter[Lanes], tExit[Lanes], t0[Lanes], dt[Lanes];
  alignas(32) int m0[Lanes], first[Lanes], last[Lanes];
  alignas(32) float b0[Lanes], db[Lanes], c0[Lanes], dc[Lanes], upperB[Lanes], upperC[Lanes];
  unsigned hit = 0, spanned = 0, isX = 0, isY = 0, forward = 0;
};

/** The packet's rays [lane0, lane0 + count) as SetUpPlaneRay and the packet's sample range make
 *  them, from a vector set-up's lanes. */
template <int Lanes>
void StoreSetUps(const AttenuationVolume& volume, const LaneSetUps<Lanes>& in, int count, RayPacket& packet, int lane0)
{
  const int nx = volume.PaddedDimensions()[0], ny = volume.PaddedDimensions()[1], nxy = nx * ny;
  for (int l = 0; l < count; ++l)
  {
    PlaneRay& out = packet.rays[lane0 + l];
    if (!((in.hit >> l) & 1))
      continue; // missed: axis -1, as SetUpPlaneRay leaves it
    const int a = ((in.isX >> l) & 1) ? 0 : ((in.isY >> l) & 1) ? 1 : 2;
    const bool yFastest = a == 0;
    out.axis = a;
    out.tEnter = in.tEnter[l], out.tExit = in.tExit[l], out.t0 = in.t0[l], out.dt = in.dt[l];
    out.planes = PlaneRun{ yFastest ? volume.VoxelsYFastest() : volume.Voxels(), a == 0 ? ny : a == 1 ? nx : nxy,
      a == 2 ? nx : nxy, in.m0[l], ((in.forward >> l) & 1) ? 1 : -1, in.b0[l], in.db[l], in.c0[l], in.dc[l], in.upperB[l],
      in.upperC[l] };
    if ((in.spanned >> l) & 1)
    {
      packet.first[lane0 + l] = in.first[l];
      packet.last[lane0 + l] = in.last[l];
    }
  }
}

/**
 * SetUpPlaneRay, OccupiedSpan and the packet's sample range for rays [lane0, lane0 + count) of a
 * packet (count <= 8), eight at a time: per lane the scalar functions' operations in their order,
 * none fused, so every PlaneRay and sample range is theirs to the bit
 * (RayCasterAnalytic.ThePacketsRaysSetUpSeveralAtATimeGiveTheIntegralsToTheBit).
 */
XP_EXACT_AVX512 void SetUpRaysAVX512(const AttenuationVolume& volume, const IndexRay* rays, int count, RayPacket& packet, int lane0)
{
  alignas(64) double in[7][8] = {};
  for (int l = 0; l < 8; ++l)
  {
    const IndexRay& ray = rays[std::min(l, count - 1)];
    for (int a = 0; a < 3; ++a)
      in[a][l] = ray.start[a], in[3 + a][l] = ray.direction[a];
    in[6][l] = ray.length;
  }
  const __mmask8 lanes = static_cast<__mmask8>((1u << count) - 1u);
  const __m512d zero = _mm512_setzero_pd(), one = _mm512_set1_pd(1.0);
  __m512d start[3], direction[3];
  for (int a = 0; a < 3; ++a)
    start[a] = _mm512_load_pd(in[a]), direction[a] = _mm512_load_pd(in[3 + a]);
  // ClipForInterpolation: ClipToBox against [0, padded - 1 - 1e-4].
  const Eigen::Vector3d upperD = volume.PaddedDimensions().cast<double>() - Eigen::Vector3d::Constant(1.0 + 1e-4);
  __m512d tEnter = zero, tExit = _mm512_load_pd(in[6]);
  __mmask8 hit = lanes;
  for (int a = 0; a < 3; ++a)
  {
    const __m512d d = direction[a], p = start[a], hi = _mm512_set1_pd(upperD[a]);
    const __mmask8 flat = _mm512_cmp_pd_mask(d, zero, _CMP_EQ_OQ);
    hit &= static_cast<__mmask8>(~(flat & (_mm512_cmp_pd_mask(p, zero, _CMP_LT_OQ) | _mm512_cmp_pd_mask(p, hi, _CMP_GT_OQ))));
    __m512d ta = _mm512_div_pd(_mm512_sub_pd(zero, p), d), tb = _mm512_div_pd(_mm512_sub_pd(hi, p), d);
    const __mmask8 swap = _mm512_cmp_pd_mask(ta, tb, _CMP_GT_OQ);
    const __m512d low = XP_PICK(swap, ta, tb), high = XP_PICK(swap, tb, ta);
    const __mmask8 sloped = static_cast<__mmask8>(~flat);
    // std::max(t0, ta), std::min(t1, tb)
    tEnter = _mm512_mask_mov_pd(tEnter, sloped & _mm512_cmp_pd_mask(tEnter, low, _CMP_LT_OQ), low);
    tExit = _mm512_mask_mov_pd(tExit, sloped & _mm512_cmp_pd_mask(high, tExit, _CMP_LT_OQ), high);
  }
  hit &= _mm512_cmp_pd_mask(tEnter, tExit, _CMP_LT_OQ);
  // The dominant axis (Eigen's maxCoeff: the first of equal ones), and b, c as SetUpPlaneRay takes them.
  const __m512d ax = _mm512_abs_pd(direction[0]), ay = _mm512_abs_pd(direction[1]), az = _mm512_abs_pd(direction[2]);
  const __mmask8 overX = _mm512_cmp_pd_mask(ay, ax, _CMP_GT_OQ);
  const __m512d largest = XP_PICK(overX, ax, ay);
  const __mmask8 isZ = _mm512_cmp_pd_mask(az, largest, _CMP_GT_OQ), isY = overX & static_cast<__mmask8>(~isZ),
                 isX = static_cast<__mmask8>(~(isY | isZ));
  // a: X, Y or Z; b: Y where a is X, else X; c: Z unless a is, then Y.
  const __m512d da = AlongAxis(direction, isX, isY), startA = AlongAxis(start, isX, isY);
  const __m512d db = XP_PICK(isX, direction[0], direction[1]), startB = XP_PICK(isX, start[0], start[1]);
  const __m512d dc = XP_PICK(isZ, direction[2], direction[1]), startC = XP_PICK(isZ, start[2], start[1]);
  const __m512d upperB = XP_PICK(isX, _mm512_set1_pd(upperD[0]), _mm512_set1_pd(upperD[1]));
  const __m512d upperC = XP_PICK(isZ, _mm512_set1_pd(upperD[2]), _mm512_set1_pd(upperD[1]));
  const __mmask8 forward = _mm512_cmp_pd_mask(da, zero, _CMP_GT_OQ);
  const __m512d entryA = _mm512_add_pd(startA, _mm512_mul_pd(tEnter, da));
  const __m512d roundedA = XP_PICK(forward, _mm512_roundscale_pd(entryA, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC),
    _mm512_roundscale_pd(entryA, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
  const __m256i m0 = _mm512_cvttpd_epi32(roundedA);
  const __m512d t0 = _mm512_div_pd(_mm512_sub_pd(_mm512_cvtepi32_pd(m0), startA), da);
  const __m512d dt = _mm512_div_pd(one, _mm512_abs_pd(da));
  const __m512d perPlaneB = _mm512_mul_pd(dt, db), perPlaneC = _mm512_mul_pd(dt, dc);
  const __m512d firstB = _mm512_add_pd(startB, _mm512_mul_pd(t0, db)), firstC = _mm512_add_pd(startC, _mm512_mul_pd(t0, dc));
  // OccupiedSpan: the first occupied block from the entry, then from the exit on the reversed ray.
  const __m512d infinity = _mm512_set1_pd(Infinity);
  const __m512d tFirst = FirstOccupiedAVX512(volume, start, direction, tEnter, tExit, hit);
  const __mmask8 spanned = hit & _mm512_cmp_pd_mask(tFirst, infinity, _CMP_NEQ_OQ);
  const __m512d mirror = _mm512_add_pd(tEnter, tExit);
  __m512d reversedStart[3], reversedDirection[3];
  for (int a = 0; a < 3; ++a)
  {
    reversedStart[a] = _mm512_add_pd(start[a], _mm512_mul_pd(mirror, direction[a]));
    // -d (the sign flipped, as Eigen's negation), not 0 - d, which differs at 0.
    reversedDirection[a] = _mm512_castsi512_pd(_mm512_xor_si512(_mm512_castpd_si512(direction[a]), _mm512_set1_epi64(INT64_MIN)));
  }
  const __m512d uLast = FirstOccupiedAVX512(volume, reversedStart, reversedDirection, tEnter, _mm512_sub_pd(mirror, tFirst), spanned);
  const __m512d tLast = XP_PICK(_mm512_cmp_pd_mask(uLast, infinity, _CMP_EQ_OQ), _mm512_sub_pd(mirror, uLast), tExit);
  // EndSample, SamplesIn(tFirst, tLast), and the packet's margin of one sample either side.
  const __m256i endSample = CeilToInt(_mm512_div_pd(_mm512_sub_pd(tExit, t0), dt));
  const __m256i j0 = _mm256_max_epi32(_mm256_setzero_si256(), CeilToInt(_mm512_div_pd(_mm512_sub_pd(tFirst, t0), dt)));
  const __m512d runEnd = XP_PICK(_mm512_cmp_pd_mask(tExit, tLast, _CMP_LT_OQ), tLast, tExit);
  const __m256i j1 = CeilToInt(_mm512_div_pd(_mm512_sub_pd(runEnd, t0), dt));
  const __m256i firstSample = _mm256_max_epi32(_mm256_setzero_si256(), _mm256_sub_epi32(j0, _mm256_set1_epi32(1)));
  const __m256i lastSample = _mm256_min_epi32(endSample, _mm256_add_epi32(j1, _mm256_set1_epi32(1)));

  LaneSetUps<8> out;
  _mm512_store_pd(out.tEnter, tEnter), _mm512_store_pd(out.tExit, tExit), _mm512_store_pd(out.t0, t0), _mm512_store_pd(out.dt, dt);
  _mm256_store_si256(reinterpret_cast<__m256i*>(out.m0), m0);
  _mm256_store_si256(reinterpret_cast<__m256i*>(out.first), firstSample);
  _mm256_store_si256(reinterpret_cast<__m256i*>(out.last), lastSample);
  _mm256_store_ps(out.b0, _mm512_cvtpd_ps(firstB)), _mm256_store_ps(out.db, _mm512_cvtpd_ps(perPlaneB));
  _mm256_store_ps(out.c0, _mm512_cvtpd_ps(firstC)), _mm256_store_ps(out.dc, _mm512_cvtpd_ps(perPlaneC));
  _mm256_store_ps(out.upperB, _mm512_cvtpd_ps(upperB)), _mm256_store_ps(out.upperC, _mm512_cvtpd_ps(upperC));
  out.hit = hit, out.spanned = spanned, out.isX = isX, out.isY = isY, out.forward = forward;
  StoreSetUps(volume, out, count, packet, lane0);
}
#undef XP_PICK

/** Four doubles, b's lanes where `pick` (all bits set), a's elsewhere. */
#define XP_PICK4(pick, a, b) _mm256_blendv_pd((a), (b), (pick))

/** Per lane, v[0] where `x`, v[1] where `y`, else v[2]. */
XP_EXACT_AVX2 inline __m256d AlongAxis4(const __m256d v[3], __m256d x, __m256d y)
{
  return XP_PICK4(y, XP_PICK4(x, v[2], v[0]), v[1]);
}

/** static_cast<int>(std::ceil(x)) per lane. */
XP_EXACT_AVX2 inline __m128i CeilToInt4(__m256d x)
{
  return _mm256_cvttpd_epi32(_mm256_round_pd(x, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
}

/** The four 64-bit lanes' masks as four 32-bit ones. */
XP_EXACT_AVX2 inline __m128i NarrowMask4(__m256d mask)
{
  return _mm256_castsi256_si128(
    _mm256_permutevar8x32_epi32(_mm256_castpd_si256(mask), _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7)));
}

/**
 * FirstOccupiedAVX512 on four rays with AVX2: each lane walks the blocks as WalkBlocks does (the
 * same operations in the same order; std::min's and std::max's choices on ties). Lanes not in
 * `lanes` (all bits set where in) take no step; their result is Infinity.
 */
XP_EXACT_AVX2 __m256d FirstOccupiedAVX2(const AttenuationVolume& volume, const __m256d start[3], const __m256d direction[3],
  __m256d tEnter, __m256d tExit, __m256d lanes)
{
  const __m256d blockSize = _mm256_set1_pd(static_cast<double>(1 << AttenuationVolume::BlockShift));
  const __m256d zero = _mm256_setzero_pd(), infinity = _mm256_set1_pd(Infinity);
  const Eigen::Vector3i& blocks = volume.BlockDimensions();
  const long long blockStrides[3] = { 1, blocks[0], static_cast<long long>(blocks[0]) * blocks[1] };
  __m256d tNext[3], tDelta[3];
  __m256i stride[3], left[3]; // 64-bit lanes, as WalkBlocks' longs
  __m256i index = _mm256_setzero_si256();
  for (int a = 0; a < 3; ++a)
  {
    const __m256d entry = _mm256_add_pd(start[a], _mm256_mul_pd(tEnter, direction[a]));
    __m128i cell = _mm256_cvttpd_epi32(_mm256_div_pd(entry, blockSize));
    cell = _mm_min_epi32(_mm_max_epi32(cell, _mm_setzero_si128()), _mm_set1_epi32(blocks[a] - 1));
    const __m256d d = direction[a];
    const __m256d positive = _mm256_cmp_pd(d, zero, _CMP_GT_OQ), flat = _mm256_cmp_pd(d, zero, _CMP_EQ_OQ);
    const __m256i cell64 = _mm256_cvtepi32_epi64(cell), positive64 = _mm256_castpd_si256(positive);
    index = _mm256_add_epi64(index, _mm256_mul_epi32(cell64, _mm256_set1_epi64x(blockStrides[a])));
    stride[a] = _mm256_blendv_epi8(_mm256_set1_epi64x(-blockStrides[a]), _mm256_set1_epi64x(blockStrides[a]), positive64);
    left[a] = _mm256_blendv_epi8(cell64, _mm256_sub_epi64(_mm256_set1_epi64x(blocks[a] - 1), cell64), positive64);
    const __m128i boundary = _mm_add_epi32(cell, _mm_and_si128(NarrowMask4(positive), _mm_set1_epi32(1)));
    const __m256d next = _mm256_div_pd(_mm256_sub_pd(_mm256_mul_pd(_mm256_cvtepi32_pd(boundary), blockSize), start[a]), d);
    const __m256d magnitude = _mm256_andnot_pd(_mm256_set1_pd(-0.0), d);
    tNext[a] = XP_PICK4(flat, next, infinity);
    tDelta[a] = XP_PICK4(flat, _mm256_div_pd(blockSize, magnitude), infinity);
  }
  const uint8_t* occupied = volume.OccupancyGrid();
  __m256d t = tEnter, first = infinity;
  __m256d active = lanes;
  while (true)
  {
    active = _mm256_and_pd(active, _mm256_cmp_pd(t, tExit, _CMP_LT_OQ));
    const int activeLanes = _mm256_movemask_pd(active);
    if (!activeLanes)
      break;
    alignas(32) long long at[4];
    _mm256_store_si256(reinterpret_cast<__m256i*>(at), index);
    alignas(32) long long foundBits[4];
    for (int l = 0; l < 4; ++l)
      foundBits[l] = ((activeLanes >> l) & 1) && occupied[at[l]] != 0 ? -1 : 0;
    const __m256d found = _mm256_castsi256_pd(_mm256_load_si256(reinterpret_cast<const __m256i*>(foundBits)));
    first = XP_PICK4(found, first, t);
    active = _mm256_andnot_pd(found, active);
    if (!_mm256_movemask_pd(active))
      break;
    // std::min(tx, std::min(ty, tz)): (b < a) ? b : a at each step.
    const __m256d yz = XP_PICK4(_mm256_cmp_pd(tNext[2], tNext[1], _CMP_LT_OQ), tNext[1], tNext[2]);
    const __m256d tStep = XP_PICK4(_mm256_cmp_pd(yz, tNext[0], _CMP_LT_OQ), tNext[0], yz);
    t = XP_PICK4(active, t, XP_PICK4(_mm256_cmp_pd(tExit, tStep, _CMP_LT_OQ), tStep, tExit));
    __m256i exhausted = _mm256_setzero_si256();
    for (int a = 0; a < 3; ++a)
    {
      const __m256d steps = _mm256_and_pd(active, _mm256_cmp_pd(tNext[a], tStep, _CMP_EQ_OQ));
      const __m256i steps64 = _mm256_castpd_si256(steps);
      index = _mm256_add_epi64(index, _mm256_and_si256(steps64, stride[a]));
      // tNext + (steps ? tDelta : 0.0), as the scalar walk adds.
      tNext[a] = XP_PICK4(active, tNext[a], _mm256_add_pd(tNext[a], _mm256_and_pd(steps, tDelta[a])));
      left[a] = _mm256_add_epi64(left[a], steps64); // steps64 is -1 where it steps
      exhausted = _mm256_or_si256(exhausted, _mm256_cmpgt_epi64(_mm256_setzero_si256(), left[a]));
    }
    active = _mm256_andnot_pd(_mm256_castsi256_pd(exhausted), active);
  }
  return first;
}

/**
 * SetUpRaysAVX512 for rays [lane0, lane0 + count) of a packet (count <= 4), four at a time with
 * AVX2: per lane the scalar functions' operations in their order, none fused, so every PlaneRay
 * and sample range is theirs to the bit
 * (RayCasterAnalytic.ThePacketsRaysSetUpSeveralAtATimeGiveTheIntegralsToTheBit).
 */
XP_EXACT_AVX2 void SetUpRaysAVX2(const AttenuationVolume& volume, const IndexRay* rays, int count, RayPacket& packet, int lane0)
{
  alignas(32) double in[7][4] = {};
  for (int l = 0; l < 4; ++l)
  {
    const IndexRay& ray = rays[std::min(l, count - 1)];
    for (int a = 0; a < 3; ++a)
      in[a][l] = ray.start[a], in[3 + a][l] = ray.direction[a];
    in[6][l] = ray.length;
  }
  alignas(32) long long laneBits[4];
  for (int l = 0; l < 4; ++l)
    laneBits[l] = l < count ? -1 : 0;
  const __m256d lanes = _mm256_castsi256_pd(_mm256_load_si256(reinterpret_cast<const __m256i*>(laneBits)));
  const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0), signBit = _mm256_set1_pd(-0.0);
  __m256d start[3], direction[3];
  for (int a = 0; a < 3; ++a)
    start[a] = _mm256_load_pd(in[a]), direction[a] = _mm256_load_pd(in[3 + a]);
  // ClipForInterpolation: ClipToBox against [0, padded - 1 - 1e-4].
  const Eigen::Vector3d upperD = volume.PaddedDimensions().cast<double>() - Eigen::Vector3d::Constant(1.0 + 1e-4);
  __m256d tEnter = zero, tExit = _mm256_load_pd(in[6]);
  __m256d hit = lanes;
  for (int a = 0; a < 3; ++a)
  {
    const __m256d d = direction[a], p = start[a], hi = _mm256_set1_pd(upperD[a]);
    const __m256d flat = _mm256_cmp_pd(d, zero, _CMP_EQ_OQ);
    const __m256d outside = _mm256_or_pd(_mm256_cmp_pd(p, zero, _CMP_LT_OQ), _mm256_cmp_pd(p, hi, _CMP_GT_OQ));
    hit = _mm256_andnot_pd(_mm256_and_pd(flat, outside), hit);
    const __m256d ta = _mm256_div_pd(_mm256_sub_pd(zero, p), d), tb = _mm256_div_pd(_mm256_sub_pd(hi, p), d);
    const __m256d swap = _mm256_cmp_pd(ta, tb, _CMP_GT_OQ);
    const __m256d low = XP_PICK4(swap, ta, tb), high = XP_PICK4(swap, tb, ta);
    // std::max(t0, ta), std::min(t1, tb), where the ray is not flat along this axis
    tEnter = XP_PICK4(_mm256_andnot_pd(flat, _mm256_cmp_pd(tEnter, low, _CMP_LT_OQ)), tEnter, low);
    tExit = XP_PICK4(_mm256_andnot_pd(flat, _mm256_cmp_pd(high, tExit, _CMP_LT_OQ)), tExit, high);
  }
  hit = _mm256_and_pd(hit, _mm256_cmp_pd(tEnter, tExit, _CMP_LT_OQ));
  // The dominant axis (Eigen's maxCoeff: the first of equal ones), and b, c as SetUpPlaneRay takes them.
  const __m256d ax = _mm256_andnot_pd(signBit, direction[0]), ay = _mm256_andnot_pd(signBit, direction[1]),
                az = _mm256_andnot_pd(signBit, direction[2]);
  const __m256d overX = _mm256_cmp_pd(ay, ax, _CMP_GT_OQ);
  const __m256d largest = XP_PICK4(overX, ax, ay);
  const __m256d isZ = _mm256_cmp_pd(az, largest, _CMP_GT_OQ), isY = _mm256_andnot_pd(isZ, overX);
  const __m256d isX = _mm256_andnot_pd(_mm256_or_pd(isY, isZ), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
  // a: X, Y or Z; b: Y where a is X, else X; c: Z unless a is, then Y.
  const __m256d da = AlongAxis4(direction, isX, isY), startA = AlongAxis4(start, isX, isY);
  const __m256d db = XP_PICK4(isX, direction[0], direction[1]), startB = XP_PICK4(isX, start[0], start[1]);
  const __m256d dc = XP_PICK4(isZ, direction[2], direction[1]), startC = XP_PICK4(isZ, start[2], start[1]);
  const __m256d upperB = XP_PICK4(isX, _mm256_set1_pd(upperD[0]), _mm256_set1_pd(upperD[1]));
  const __m256d upperC = XP_PICK4(isZ, _mm256_set1_pd(upperD[2]), _mm256_set1_pd(upperD[1]));
  const __m256d forward = _mm256_cmp_pd(da, zero, _CMP_GT_OQ);
  const __m256d entryA = _mm256_add_pd(startA, _mm256_mul_pd(tEnter, da));
  const __m256d roundedA = XP_PICK4(forward, _mm256_round_pd(entryA, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC),
    _mm256_round_pd(entryA, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC));
  const __m128i m0 = _mm256_cvttpd_epi32(roundedA);
  const __m256d t0 = _mm256_div_pd(_mm256_sub_pd(_mm256_cvtepi32_pd(m0), startA), da);
  const __m256d dt = _mm256_div_pd(one, _mm256_andnot_pd(signBit, da));
  const __m256d perPlaneB = _mm256_mul_pd(dt, db), perPlaneC = _mm256_mul_pd(dt, dc);
  const __m256d firstB = _mm256_add_pd(startB, _mm256_mul_pd(t0, db)), firstC = _mm256_add_pd(startC, _mm256_mul_pd(t0, dc));
  // OccupiedSpan: the first occupied block from the entry, then from the exit on the reversed ray.
  const __m256d infinity = _mm256_set1_pd(Infinity);
  const __m256d tFirst = FirstOccupiedAVX2(volume, start, direction, tEnter, tExit, hit);
  const __m256d spanned = _mm256_and_pd(hit, _mm256_cmp_pd(tFirst, infinity, _CMP_NEQ_OQ));
  const __m256d mirror = _mm256_add_pd(tEnter, tExit);
  __m256d reversedStart[3], reversedDirection[3];
  for (int a = 0; a < 3; ++a)
  {
    reversedStart[a] = _mm256_add_pd(start[a], _mm256_mul_pd(mirror, direction[a]));
    // -d (the sign flipped, as Eigen's negation), not 0 - d, which differs at 0.
    reversedDirection[a] = _mm256_xor_pd(direction[a], signBit);
  }
  const __m256d uLast = FirstOccupiedAVX2(volume, reversedStart, reversedDirection, tEnter, _mm256_sub_pd(mirror, tFirst), spanned);
  const __m256d tLast = XP_PICK4(_mm256_cmp_pd(uLast, infinity, _CMP_EQ_OQ), _mm256_sub_pd(mirror, uLast), tExit);
  // EndSample, SamplesIn(tFirst, tLast), and the packet's margin of one sample either side.
  const __m128i endSample = CeilToInt4(_mm256_div_pd(_mm256_sub_pd(tExit, t0), dt));
  const __m128i j0 = _mm_max_epi32(_mm_setzero_si128(), CeilToInt4(_mm256_div_pd(_mm256_sub_pd(tFirst, t0), dt)));
  const __m256d runEnd = XP_PICK4(_mm256_cmp_pd(tExit, tLast, _CMP_LT_OQ), tLast, tExit);
  const __m128i j1 = CeilToInt4(_mm256_div_pd(_mm256_sub_pd(runEnd, t0), dt));
  const __m128i firstSample = _mm_max_epi32(_mm_setzero_si128(), _mm_sub_epi32(j0, _mm_set1_epi32(1)));
  const __m128i lastSample = _mm_min_epi32(endSample, _mm_add_epi32(j1, _mm_set1_epi32(1)));

  LaneSetUps<4> out;
  _mm256_store_pd(out.tEnter, tEnter), _mm256_store_pd(out.tExit, tExit), _mm256_store_pd(out.t0, t0), _mm256_store_pd(out.dt, dt);
  _mm_store_si128(reinterpret_cast<__m128i*>(out.m0), m0);
  _mm_store_si128(reinterpret_cast<__m128i*>(out.first), firstSample);
  _mm_store_si128(reinterpret_cast<__m128i*>(out.last), lastSample);
  _mm_store_ps(out.b0, _mm256_cvtpd_ps(firstB)), _mm_store_ps(out.db, _mm256_cvtpd_ps(perPlaneB));
  _mm_store_ps(out.c0, _mm256_cvtpd_ps(firstC)), _mm_store_ps(out.dc, _mm256_cvtpd_ps(perPlaneC));
  _mm_store_ps(out.upperB, _mm256_cvtpd_ps(upperB)), _mm_store_ps(out.upperC, _mm256_cvtpd_ps(upperC));
  out.hit = static_cast<unsigned>(_mm256_movemask_pd(hit)), out.spanned = static_cast<unsigned>(_mm256_movemask_pd(spanned));
  out.isX = static_cast<unsigned>(_mm256_movemask_pd(isX)), out.isY = static_cast<unsigned>(_mm256_movemask_pd(isY));
  out.forward = static_cast<unsigned>(_mm256_movemask_pd(forward));
  StoreSetUps(volume, out, count, packet, lane0);
}
#undef XP_PICK4

/** How TracePacket samples a packet: two AVX2 passes of eight lanes, or one AVX-512 pass of
 *  sixteen reading voxel rows with loads where it can, or with gathers. */
enum class PacketPath
{
  EightLanes,
  SixteenLanesLoads,
  SixteenLanesGathers,
};

PacketPath PacketPathOf(const RayCastSettings& settings)
{
  if (!settings.wideVectors || !HaveAVX512)
    return PacketPath::EightLanes;
  return WideVoxelReadsOf(settings.voxelReads) == VoxelReads::Loads ? PacketPath::SixteenLanesLoads
                                                                      : PacketPath::SixteenLanesGathers;
}

/** How TracePacket sets a packet's rays up: one at a time, four at a time with AVX2, or eight at a
 *  time with AVX-512 (F, VL and BW); the same packet every way. */
enum class RaySetUp
{
  OneAtATime,
  FourAtATime,
  EightAtATime,
};

/**
 * Line integrals of a packet's `count` rays (at most Size) into integrals[0..count-1]: one pass
 * per distinct (axis, direction) among its rays, one pass except where the dominant axis changes
 * across the panel, along `path`. Lanes from `count` on take no samples. The rays are set up as
 * `setUp` says: the same packet every way.
 */
void TracePacket(const AttenuationVolume& volume, const IndexRay* rays, int count, const std::array<int, 3>& planeSteps,
  PacketPath path, RaySetUp setUp, float* integrals)
{
  RayPacket packet;
  const long long voxelCount = static_cast<long long>(volume.VoxelCount());
  if (setUp == RaySetUp::EightAtATime)
  {
    for (int lane0 = 0; lane0 < count; lane0 += 8)
      SetUpRaysAVX512(volume, rays + lane0, std::min(8, count - lane0), packet, lane0);
  }
  else if (setUp == RaySetUp::FourAtATime)
  {
    for (int lane0 = 0; lane0 < count; lane0 += 4)
      SetUpRaysAVX2(volume, rays + lane0, std::min(4, count - lane0), packet, lane0);
  }
  else
  {
    for (int r = 0; r < count; ++r)
    {
      PlaneRay& planeRay = packet.rays[r];
      planeRay = SetUpPlaneRay(volume, rays[r]);
      if (planeRay.axis < 0)
      {
        continue;
      }
      // The packet samples from the first occupied block to the last, empty ones between included,
      // and one sample more at either end against rounding (in empty blocks samples are exactly 0).
      double tFirst, tLast;
      if (OccupiedSpan(volume, rays[r], planeRay.tEnter, planeRay.tExit, tFirst, tLast))
      {
        int first, last;
        planeRay.SamplesIn(tFirst, tLast, first, last);
        packet.first[r] = std::max(0, first - 1);
        packet.last[r] = std::min(planeRay.EndSample(), last + 1);
      }
    }
  }
  std::fill(integrals, integrals + RayPacket::Size, 0.0f);
  bool done[RayPacket::Size] = {};
  for (int r = 0; r < RayPacket::Size; ++r)
  {
    const PlaneRay& ray = packet.rays[r];
    if (done[r] || ray.axis < 0 || packet.first[r] >= packet.last[r])
    {
      continue;
    }
    float sums[RayPacket::Size];
    const int step = planeSteps[ray.axis];
    switch (path)
    {
      case PacketPath::SixteenLanesLoads:
        SamplePacketAVX512<true>(packet, ray.axis, ray.planes.sa, step, voxelCount, sums);
        break;
      case PacketPath::SixteenLanesGathers:
        SamplePacketAVX512<false>(packet, ray.axis, ray.planes.sa, step, voxelCount, sums);
        break;
      case PacketPath::EightLanes:
        SamplePacketAVX2(packet, 0, ray.axis, ray.planes.sa, step, sums);
        SamplePacketAVX2(packet, 8, ray.axis, ray.planes.sa, step, sums + 8);
        break;
    }
    for (int s = r; s < RayPacket::Size; ++s)
    {
      if (packet.rays[s].axis == ray.axis && packet.rays[s].planes.sa == ray.planes.sa)
      {
        done[s] = true;
        integrals[s] = static_cast<float>(sums[s] * step * packet.rays[s].dt * volume.Quantum());
      }
    }
  }
}

/** Exact integral of the voxels the ray crosses for tEnter <= t < tExit (a Siddon / Amanatides &
 *  Woo voxel walk); the stretch lies inside the stored voxels. */
double SiddonRun(const AttenuationVolume& volume, const IndexRay& ray, double tEnter, double tExit)
{
  const Eigen::Vector3i dims = volume.StoredDimensions();
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
    sum += (tEnd - t) * volume.StoredAt(voxel[0], voxel[1], voxel[2]);
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

/** Exact integral through nearest-neighbour voxels, walking only the occupied blocks. */
double TraceSiddon(const AttenuationVolume& volume, const IndexRay& ray)
{
  // Stored voxel i (padded i + 1) spans padded coordinates [i + 0.5, i + 1.5].
  const Eigen::Vector3d lo = Eigen::Vector3d::Constant(0.5), hi = volume.StoredDimensions().cast<double>() + lo;
  double tEnter, tExit;
  if (!ClipToBox(ray, lo, hi, tEnter, tExit))
  {
    return 0.0;
  }
  double sum = 0.0;
  ForEachOccupiedRun(volume, ray, tEnter, tExit,
    [&](double runStart, double runEnd) { sum += SiddonRun(volume, ray, runStart, runEnd); });
  return sum;
}

/** A DRR's rays in the volume's padded index space (xpJosephRay.h). */
joseph::Job MakeJob(const Eigen::Affine3d& roomToIndex, const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid)
{
  joseph::Job job{};
  const Eigen::Vector3d source = roomToIndex * sourceInRoom, origin = roomToIndex * grid.origin;
  const Eigen::Vector3d column = roomToIndex.linear() * grid.columnStep, row = roomToIndex.linear() * grid.rowStep;
  const Eigen::Vector3d roomOrigin = grid.origin - sourceInRoom;
  for (int a = 0; a < 3; ++a)
  {
    job.source[a] = source[a];
    job.origin[a] = origin[a];
    job.column[a] = column[a];
    job.row[a] = row[a];
    job.roomOrigin[a] = roomOrigin[a];
    job.roomColumn[a] = grid.columnStep[a];
    job.roomRow[a] = grid.rowStep[a];
  }
  job.columns = grid.columns;
  return job;
}

/**
 * The process's GPU, made when first asked for, with the volumes and pixel lists it holds: each
 * is uploaded once and kept while its owner on the host lives (a registration's CT, halved CT and
 * masks), and given back at the next call after the owner is gone. Every call holds its lock.
 */
class SharedGPU
{
public:
  static SharedGPU& Instance()
  {
    static SharedGPU gpu;
    return gpu;
  }

  std::string DeviceName()
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (this->Name.empty())
      this->Name = this->Context().DeviceName();
    return this->Name;
  }

  /** The DRRs of `targets` in one launch; each target's traced pixels receive their integrals. */
  long long Render(const AttenuationVolume& volume, const Eigen::Affine3d& roomToIndex, const std::vector<RenderTarget>& targets,
    bool textureFilter)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    cuda::GPUContext& gpu = this->Context();
    const int volumeHandle = this->VolumeHandle(volume);
    std::vector<joseph::Job> jobs;
    std::vector<int> pixels;
    std::vector<float*> out;
    size_t total = 0;
    for (const RenderTarget& target : targets)
      total += target.pixels->Order().size();
    this->Compact.resize(total);
    total = 0;
    for (const RenderTarget& target : targets)
    {
      jobs.push_back(MakeJob(roomToIndex, target.source, target.grid));
      pixels.push_back(this->PixelHandle(*target.pixels));
      out.push_back(this->Compact.data() + total);
      total += target.pixels->Order().size();
    }
    const long long traced = gpu.Render(volumeHandle, jobs.data(), pixels.data(), static_cast<int>(targets.size()), out.data(),
      textureFilter ? cuda::Interpolation::Texture : cuda::Interpolation::Float);
    for (size_t t = 0; t < targets.size(); ++t)
    {
      const std::vector<int>& order = targets[t].pixels->Order();
      const float* compact = out[t];
      float* lineIntegrals = targets[t].lineIntegrals;
      ParallelFor(size_t{ 0 }, order.size(), size_t{ 16384 },
        [&](size_t begin, size_t end)
        {
          for (size_t n = begin; n < end; ++n)
            lineIntegrals[order[n]] = compact[n];
        });
    }
    return traced;
  }

  /** A metric view (GPUContext::AddMetricView) of `pixels`, kept until Release. */
  int AddMetricView(const TracedPixels& pixels, const std::vector<uint8_t>& xrayBins, int bins, double low, double toCell,
    const std::vector<uint8_t>& cellBins)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    return this->Context().AddMetricView(this->PixelHandle(pixels), xrayBins.data(), bins, low, toCell, cellBins);
  }

  void Release(int handle)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    if (this->GPU)
      this->GPU->Remove(handle);
  }

  long long MutualInformation(const AttenuationVolume& volume, const std::vector<joseph::Job>& jobs, const std::vector<int>& views,
    double* mi)
  {
    std::lock_guard<std::mutex> lock(this->Mutex);
    cuda::GPUContext& gpu = this->Context();
    return gpu.MutualInformation(this->VolumeHandle(volume), jobs.data(), views.data(), static_cast<int>(jobs.size()), mi);
  }

private:
  struct Resident
  {
    std::weak_ptr<const void> owner;
    int handle;
  };

  cuda::GPUContext& Context()
  {
    if (!this->GPU)
      this->GPU = std::make_unique<cuda::GPUContext>();
    return *this->GPU;
  }

  int VolumeHandle(const AttenuationVolume& volume)
  {
    return this->Handle(this->Volumes, volume.Storage(),
      [&]
      {
        const Eigen::Vector3i& dims = volume.PaddedDimensions();
        return this->GPU->AddVolume(volume.Voxels(), joseph::Grid{ { dims[0], dims[1], dims[2] }, volume.Quantum() });
      });
  }

  int PixelHandle(const TracedPixels& pixels)
  {
    return this->Handle(this->PixelLists, pixels.Storage(),
      [&] { return this->GPU->AddPixels(pixels.Order().data(), static_cast<int>(pixels.Order().size())); });
  }

  /** The handle of `owner`'s data on the GPU, uploaded by `upload` when it is not there yet;
   *  the data of owners that are gone is given back first. */
  template <typename Upload>
  int Handle(std::vector<Resident>& list, const std::shared_ptr<const void>& owner, Upload upload)
  {
    this->Context();
    for (auto it = list.begin(); it != list.end();)
    {
      if (it->owner.expired())
      {
        this->GPU->Remove(it->handle);
        it = list.erase(it);
      }
      else
        ++it;
    }
    for (const Resident& resident : list)
      if (!resident.owner.owner_before(owner) && !owner.owner_before(resident.owner))
        return resident.handle;
    const int handle = upload();
    list.push_back({ owner, handle });
    return handle;
  }

  std::mutex Mutex;
  std::unique_ptr<cuda::GPUContext> GPU;
  std::string Name; ///< the GPU's, asked once (every registration records it)
  std::vector<Resident> Volumes, PixelLists;
  std::vector<float> Compact;
};

} // namespace

TracedPixels::TracedPixels(int columns, int rows, const uint8_t* mask)
  : PanelColumns(columns)
  , PanelRows(rows)
{
  static_assert(TileColumns <= PacketSize, "a tile's row must fit in a packet");
  auto pixels = std::make_shared<std::vector<int>>();
  pixels->reserve(static_cast<size_t>(columns) * rows);
  for (int tileRow = 0; tileRow < rows; tileRow += TileRows)
  {
    for (int tileColumn = 0; tileColumn < columns; tileColumn += TileColumns)
    {
      // A tile's rows join the open packet while they fit whole and it holds fewer than two.
      int packetRows = 0;
      for (int row = tileRow; row < std::min(tileRow + TileRows, rows); ++row)
      {
        const size_t rowStart = pixels->size();
        for (int column = tileColumn; column < std::min(tileColumn + TileColumns, columns); ++column)
        {
          const int pixel = row * columns + column;
          if (!mask || mask[pixel])
          {
            pixels->push_back(pixel);
          }
        }
        const int inRow = static_cast<int>(pixels->size() - rowStart);
        if (inRow == 0)
        {
          continue;
        }
        const int open = packetRows > 0 ? static_cast<int>(rowStart) - this->Packets.back() : 0;
        if (packetRows == 0 || packetRows == 2 || open + inRow > PacketSize)
        {
          this->Packets.push_back(static_cast<int>(rowStart));
          packetRows = 0;
        }
        ++packetRows;
      }
    }
  }
  this->Packets.push_back(static_cast<int>(pixels->size()));
  this->Pixels = std::move(pixels);
}

long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const uint8_t* mask, float* lineIntegrals,
  const RayCastSettings& settings)
{
  if (mask)
  {
    const long long count = static_cast<long long>(grid.columns) * grid.rows;
    for (long long i = 0; i < count; ++i)
    {
      if (!mask[i])
      {
        lineIntegrals[i] = 0.0f;
      }
    }
  }
  return RenderLineIntegrals(
    volume, ctToRoom, sourceInRoom, grid, TracedPixels(grid.columns, grid.rows, mask), lineIntegrals, settings);
}

long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const TracedPixels& pixels, float* lineIntegrals,
  const RayCastSettings& settings)
{
  if (volume.Dimensions().minCoeff() < 1)
  {
    throw Error("ray caster: no volume");
  }
  if (pixels.Columns() != grid.columns || pixels.Rows() != grid.rows)
  {
    throw Error("ray caster: the traced pixels are of a " + std::to_string(pixels.Columns()) + " x " +
      std::to_string(pixels.Rows()) + " panel, the grid is " + std::to_string(grid.columns) + " x " +
      std::to_string(grid.rows));
  }
  for (const int step : settings.planeSteps)
    if (step < 1 || step > 4)
      throw Error("ray caster: a plane step must be 1 to 4, not " + std::to_string(step));
  const Eigen::Affine3d roomToIndex = (ctToRoom * volume.PaddedIndexToCT()).inverse();
  if (settings.device == ComputeDevice::CUDA)
    return RenderLineIntegrals(volume, ctToRoom, { RenderTarget{ sourceInRoom, grid, &pixels, lineIntegrals } }, settings);
  const Eigen::Vector3d source = roomToIndex * sourceInRoom;
  const std::vector<int>& order = pixels.Order();
  const long long traced = static_cast<long long>(order.size());
  constexpr int TileColumns = TracedPixels::TileColumns, TileRows = TracedPixels::TileRows;

  const auto rayOf = [&](int pixel)
  {
    const int column = pixel % grid.columns, row = pixel / grid.columns;
    const Eigen::Vector3d toPixel = grid.origin + column * grid.columnStep + row * grid.rowStep - sourceInRoom;
    IndexRay ray;
    ray.length = toPixel.norm();
    ray.start = source;
    ray.direction = roomToIndex.linear() * (toPixel / ray.length);
    return ray;
  };
  const bool packets =
    settings.method == RayCastMethod::Trilinear && settings.stepSize <= 0.0 && settings.vectorized && HaveAVX2;
  if (packets)
  {
    const PacketPath path = PacketPathOf(settings);
    // The rays set up several at a time where the settings allow it: eight with the sixteen lanes'
    // AVX-512, four with AVX2 for the eight lanes'.
    const RaySetUp setUp = !settings.wideSetUp             ? RaySetUp::OneAtATime
      : path != PacketPath::EightLanes && HaveAVX512VL ? RaySetUp::EightAtATime
      : path == PacketPath::EightLanes                 ? RaySetUp::FourAtATime
                                                       : RaySetUp::OneAtATime;
    const std::vector<int>& starts = pixels.PacketStarts();
    const long long packetCount = static_cast<long long>(starts.size()) - 1;
    ParallelFor(0LL, packetCount, static_cast<long long>(TileColumns * TileRows / RayPacket::Size),
      [&](long long begin, long long end)
      {
        IndexRay rays[RayPacket::Size];
        float integrals[RayPacket::Size];
        for (long long p = begin; p < end; ++p)
        {
          const int firstRay = starts[p], count = starts[p + 1] - starts[p];
          for (int r = 0; r < count; ++r)
          {
            rays[r] = rayOf(order[firstRay + r]);
          }
          TracePacket(volume, rays, count, settings.planeSteps, path, setUp, integrals);
          for (int r = 0; r < count; ++r)
          {
            lineIntegrals[order[firstRay + r]] = integrals[r];
          }
        }
      });
    return traced;
  }
  ParallelFor(0LL, traced, static_cast<long long>(TileColumns * TileRows),
    [&](long long begin, long long end)
    {
      for (long long n = begin; n < end; ++n)
      {
        const IndexRay ray = rayOf(order[n]);
        const double integral = settings.method == RayCastMethod::Siddon ? TraceSiddon(volume, ray)
          : settings.stepSize > 0.0 ? TraceTrilinear(volume, ray, settings.stepSize)
                                    : TracePlanes(volume, ray, settings.planeSteps);
        lineIntegrals[order[n]] = static_cast<float>(integral);
      }
    });
  return traced;
}

long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const std::vector<RenderTarget>& targets, const RayCastSettings& settings)
{
  for (const RenderTarget& target : targets)
    if (!target.pixels || target.pixels->Columns() != target.grid.columns || target.pixels->Rows() != target.grid.rows)
      throw Error("ray caster: a target's traced pixels are missing or of another panel size than its grid");
  if (settings.device != ComputeDevice::CUDA)
  {
    long long rays = 0;
    for (const RenderTarget& target : targets)
      rays += RenderLineIntegrals(volume, ctToRoom, target.source, target.grid, *target.pixels, target.lineIntegrals, settings);
    return rays;
  }
  if (volume.Dimensions().minCoeff() < 1)
    throw Error("ray caster: no volume");
  if (settings.method != RayCastMethod::Trilinear || settings.stepSize > 0.0 || settings.planeSteps != std::array<int, 3>{ { 1, 1, 1 } })
    throw Error("ray caster: the GPU casts Joseph's scheme only (trilinear, one sample on every voxel plane)");
  const Eigen::Affine3d roomToIndex = (ctToRoom * volume.PaddedIndexToCT()).inverse();
  return SharedGPU::Instance().Render(volume, roomToIndex, targets, settings.textureFilter);
}

joseph::Job JosephJob(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const Eigen::Vector3d& sourceInRoom,
  const DetectorGrid& grid)
{
  return MakeJob((ctToRoom * volume.PaddedIndexToCT()).inverse(), sourceInRoom, grid);
}

ComputeDeviceChoice ChooseComputeDevice(const std::string& option)
{
  ComputeDeviceChoice choice;
  if (option == "cpu")
    return choice;
  if (option != "cuda" && option != "auto")
    throw InputError("--device", "must be auto, cpu or cuda, not '" + option + "'");
  std::string reason;
  bool usable = cuda::Available(&reason);
  std::string name;
  if (usable)
  {
    try
    {
      name = SharedGPU::Instance().DeviceName();
    }
    catch (const Error& error)
    {
      usable = false;
      reason = error.what();
    }
  }
  if (!usable)
  {
    if (option == "cuda")
      throw InputError("--device", "cuda: " + reason);
    choice.note = "no GPU used: " + reason + "; the rays are cast on the CPU";
    return choice;
  }
  choice.device = ComputeDevice::CUDA;
  choice.description = "cuda (" + name + ")";
  return choice;
}

GPUMutualInformation::GPUMutualInformation(const AttenuationVolume& volume, const std::vector<View>& views, int bins)
  : Volume(volume)
  , VolumeOwner(volume.Storage())
{
  for (const View& view : views)
  {
    if (!view.pixels)
      throw Error("GPU metric: a view without its pixels");
    this->PixelOwners.push_back(view.pixels->Storage());
    this->Handles.push_back(
      SharedGPU::Instance().AddMetricView(*view.pixels, view.xrayBins, bins, view.low, view.toCell, view.cellBins));
    this->Sources.push_back(view.source);
    this->Grids.push_back(view.grid);
  }
}

GPUMutualInformation::~GPUMutualInformation()
{
  for (int handle : this->Handles)
    SharedGPU::Instance().Release(handle);
}

long long GPUMutualInformation::Evaluate(const std::vector<Eigen::Isometry3d>& ctToRoom, std::vector<double>& mi)
{
  std::vector<joseph::Job> jobs;
  std::vector<int> handles;
  for (const Eigen::Isometry3d& pose : ctToRoom)
  {
    const Eigen::Affine3d roomToIndex = (pose * this->Volume.PaddedIndexToCT()).inverse();
    for (size_t v = 0; v < this->Handles.size(); ++v)
    {
      jobs.push_back(MakeJob(roomToIndex, this->Sources[v], this->Grids[v]));
      handles.push_back(this->Handles[v]);
    }
  }
  mi.assign(jobs.size(), 0.0);
  return SharedGPU::Instance().MutualInformation(this->Volume, jobs, handles, mi.data());
}

std::string ComputeDeviceDescription(ComputeDevice device)
{
  return device == ComputeDevice::CUDA ? "cuda (" + SharedGPU::Instance().DeviceName() + ")" : "cpu";
}

bool HasVectorRayCaster()
{
  return HaveAVX2;
}

bool HasWideVectorRayCaster()
{
  return HaveAVX512;
}

VoxelReads WideVoxelReadsOf(VoxelReads requested)
{
  // The loads' word permutations paid on the AMD EPYC and cost on an Intel Xeon, whose gathers
  // were the faster (Performance.md, "Loads or gathers, per CPU").
  if (requested == VoxelReads::Auto)
    return IsAMD ? VoxelReads::Loads : VoxelReads::Gathers;
  return requested;
}

std::string RayCasterPathDescription()
{
  if (HaveAVX512)
    return std::string("AVX-512, 16 lanes, voxels read by ") + ToString(WideVoxelReadsOf(VoxelReads::Auto));
  return HaveAVX2 ? "AVX2, 8 lanes" : "scalar, one ray at a time";
}

const char* ToString(VoxelReads reads)
{
  switch (reads)
  {
    case VoxelReads::Loads:
      return "loads";
    case VoxelReads::Gathers:
      return "gathers";
    case VoxelReads::Auto:
      break;
  }
  return "auto";
}

void LineIntegralsTo12Bit(const float* lineIntegrals, const uint8_t* mask, long long count, uint16_t* transmission)
{
  // Once per DRR of every evaluation: on all threads, as the rays were (one exp a pixel).
  ParallelFor(0LL, count,
    [&](long long begin, long long end)
    {
      for (long long i = begin; i < end; ++i)
      {
        // + 0.5 and truncation: round half up, the values are never negative.
        transmission[i] =
          (mask && !mask[i]) ? 0 : static_cast<uint16_t>(4095.0 * std::exp(-double(lineIntegrals[i])) + 0.5);
      }
    });
}

} // namespace xp
