#include "xpPreAlignment.h"

#include "xpError.h"
#include "xpExactVectors.h"
#include "xpMutualInformation.h"
#include "xpPoseOptimizer.h"

#include <Eigen/Geometry>
#include <vtkSMPTools.h>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

namespace xp
{

namespace
{

constexpr double RadiansPerDegree = M_PI / 180.0;

/** The inverse of a 2D motion, per pixel: T^-1 p = S^-1 R^-1 (p - center - shift) + center. */
struct InverseMotion
{
  explicit InverseMotion(const Motion2D& motion)
    : c(std::cos(-motion.rotation * RadiansPerDegree))
    , s(std::sin(-motion.rotation * RadiansPerDegree))
    , toColumn(1.0 / motion.scale[0])
    , toRow(1.0 / motion.scale[1])
    , center(motion.center)
    , shift(motion.shift)
  {
  }
  double c, s, toColumn, toRow;
  Eigen::Vector2d center, shift;
};

/** WarpPixels for pixels [k0, k1), one at a time: the reference the vectorised warp matches. */
void WarpPixelRange(const uint16_t* moving, int columns, int rows, const InverseMotion& m, const PixelIndex* pixels,
  size_t k0, size_t k1, uint16_t* out, uint8_t* valid)
{
  for (size_t k = k0; k < k1; ++k)
  {
    const int row = pixels[k].row, column = pixels[k].column;
    const double dx = column - m.center[0] - m.shift[0], dy = row - m.center[1] - m.shift[1];
    const double x = (m.c * dx - m.s * dy) * m.toColumn + m.center[0], y = (m.s * dx + m.c * dy) * m.toRow + m.center[1];
    // Inside when floor(x) and floor(x) + 1 are columns: 0 <= x < columns - 1 (NaN is not),
    // where truncation is the floor, without a call to floor per pixel.
    if (!(x >= 0.0 && y >= 0.0 && x < columns - 1 && y < rows - 1))
    {
      valid[k] = 0;
      out[k] = 0;
      continue;
    }
    const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
    const double fx = x - x0, fy = y - y0;
    const uint16_t* p = moving + static_cast<size_t>(y0) * columns + x0;
    const double top = p[0] + fx * (p[1] - p[0]), bottom = p[columns] + fx * (p[columns + 1] - p[columns]);
    // + 0.5 and truncation: round half up, the values are never negative.
    out[k] = static_cast<uint16_t>(top + fy * (bottom - top) + 0.5);
    valid[k] = 1;
  }
}

#if defined(__GNUC__) && defined(__x86_64__)
#define XP_WARP_AVX2 1
/**
 * WarpPixelRange four pixels at a time: the same double operations in the same order (AVX2
 * without FMA, so nothing is fused), a 32-bit gather for each pair of horizontal neighbours, so
 * the values are bit for bit the scalar ones. The last k1 - k0 mod 4 pixels go one at a time.
 */
__attribute__((target("avx2"))) void WarpPixelRangeAVX2(const uint16_t* moving, int columns, int rows,
  const InverseMotion& m, const PixelIndex* pixels, size_t k0, size_t k1, uint16_t* out, uint8_t* valid)
{
  const __m256d cx = _mm256_set1_pd(m.center[0]), cy = _mm256_set1_pd(m.center[1]);
  const __m256d sx = _mm256_set1_pd(m.shift[0]), sy = _mm256_set1_pd(m.shift[1]);
  const __m256d c = _mm256_set1_pd(m.c), s = _mm256_set1_pd(m.s);
  const __m256d toColumn = _mm256_set1_pd(m.toColumn), toRow = _mm256_set1_pd(m.toRow);
  const __m256d zero = _mm256_setzero_pd(), half = _mm256_set1_pd(0.5);
  const __m256d lastX = _mm256_set1_pd(columns - 1), lastY = _mm256_set1_pd(rows - 1);
  const __m128i width = _mm_set1_epi32(columns), low16 = _mm_set1_epi32(0xffff);
  const __m256i byAxis = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7); // (c, r) x 4 -> c x 4, r x 4
  const int* words = reinterpret_cast<const int*>(moving);
  size_t k = k0;
  for (; k + 4 <= k1; k += 4)
  {
    const __m256i both = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(pixels + k)), byAxis);
    const __m256d column = _mm256_cvtepi32_pd(_mm256_castsi256_si128(both));
    const __m256d row = _mm256_cvtepi32_pd(_mm256_extracti128_si256(both, 1));
    const __m256d dx = _mm256_sub_pd(_mm256_sub_pd(column, cx), sx), dy = _mm256_sub_pd(_mm256_sub_pd(row, cy), sy);
    const __m256d x = _mm256_add_pd(_mm256_mul_pd(_mm256_sub_pd(_mm256_mul_pd(c, dx), _mm256_mul_pd(s, dy)), toColumn), cx);
    const __m256d y = _mm256_add_pd(_mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(s, dx), _mm256_mul_pd(c, dy)), toRow), cy);
    // Ordered comparisons: false for NaN, as the scalar test.
    const __m256d inside = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(x, zero, _CMP_GE_OQ), _mm256_cmp_pd(y, zero, _CMP_GE_OQ)),
      _mm256_and_pd(_mm256_cmp_pd(x, lastX, _CMP_LT_OQ), _mm256_cmp_pd(y, lastY, _CMP_LT_OQ)));
    const int insideBits = _mm256_movemask_pd(inside);
    if (insideBits == 0)
    {
      for (int lane = 0; lane < 4; ++lane)
        out[k + lane] = 0, valid[k + lane] = 0;
      continue;
    }
    // Lanes outside truncate x and y of 0 and read pixel 0: their values are dropped below.
    const __m128i x0 = _mm256_cvttpd_epi32(_mm256_and_pd(x, inside)), y0 = _mm256_cvttpd_epi32(_mm256_and_pd(y, inside));
    const __m256d fx = _mm256_sub_pd(x, _mm256_cvtepi32_pd(x0)), fy = _mm256_sub_pd(y, _mm256_cvtepi32_pd(y0));
    const __m128i at = _mm_add_epi32(_mm_mullo_epi32(y0, width), x0);
    const __m128i upper = _mm_i32gather_epi32(words, at, 2), lower = _mm_i32gather_epi32(words, _mm_add_epi32(at, width), 2);
    // Each pair's left pixel in its low 16 bits, its right in the high: left + fx (right - left).
    const __m128i upperLeft = _mm_and_si128(upper, low16), lowerLeft = _mm_and_si128(lower, low16);
    const __m256d top = _mm256_add_pd(_mm256_cvtepi32_pd(upperLeft),
      _mm256_mul_pd(fx, _mm256_cvtepi32_pd(_mm_sub_epi32(_mm_srli_epi32(upper, 16), upperLeft))));
    const __m256d bottom = _mm256_add_pd(_mm256_cvtepi32_pd(lowerLeft),
      _mm256_mul_pd(fx, _mm256_cvtepi32_pd(_mm_sub_epi32(_mm_srli_epi32(lower, 16), lowerLeft))));
    const __m128i value = _mm256_cvttpd_epi32(_mm256_add_pd(_mm256_add_pd(top, _mm256_mul_pd(fy, _mm256_sub_pd(bottom, top))), half));
    alignas(16) int values[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(values), value);
    for (int lane = 0; lane < 4; ++lane)
    {
      const bool in = (insideBits >> lane) & 1;
      out[k + lane] = in ? static_cast<uint16_t>(values[lane]) : 0;
      valid[k + lane] = in ? 1 : 0;
    }
  }
  WarpPixelRange(moving, columns, rows, m, pixels, k, k1, out, valid);
}

/**
 * WarpPixelRangeAVX2 eight pixels at a time with AVX-512: the same double operations in the same
 * order, none fused (XP_EXACT_AVX512), so the values are bit for bit the scalar ones.
 */
XP_EXACT_AVX512 void WarpPixelRangeAVX512(const uint16_t* moving, int columns, int rows, const InverseMotion& m,
  const PixelIndex* pixels, size_t k0, size_t k1, uint16_t* out, uint8_t* valid)
{
  const __m512d cx = _mm512_set1_pd(m.center[0]), cy = _mm512_set1_pd(m.center[1]);
  const __m512d sx = _mm512_set1_pd(m.shift[0]), sy = _mm512_set1_pd(m.shift[1]);
  const __m512d c = _mm512_set1_pd(m.c), s = _mm512_set1_pd(m.s);
  const __m512d toColumn = _mm512_set1_pd(m.toColumn), toRow = _mm512_set1_pd(m.toRow);
  const __m512d zero = _mm512_setzero_pd(), half = _mm512_set1_pd(0.5);
  const __m512d lastX = _mm512_set1_pd(columns - 1), lastY = _mm512_set1_pd(rows - 1);
  const __m256i width = _mm256_set1_epi32(columns), low16 = _mm256_set1_epi32(0xffff);
  // (c, r) x 8 -> c x 8, r x 8
  const __m512i byAxis = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 1, 3, 5, 7, 9, 11, 13, 15);
  const int* words = reinterpret_cast<const int*>(moving);
  size_t k = k0;
  for (; k + 8 <= k1; k += 8)
  {
    const __m512i both = _mm512_permutexvar_epi32(byAxis, _mm512_loadu_si512(pixels + k));
    const __m512d column = _mm512_cvtepi32_pd(_mm512_castsi512_si256(both));
    const __m512d row = _mm512_cvtepi32_pd(_mm512_extracti64x4_epi64(both, 1));
    const __m512d dx = _mm512_sub_pd(_mm512_sub_pd(column, cx), sx), dy = _mm512_sub_pd(_mm512_sub_pd(row, cy), sy);
    const __m512d x = _mm512_add_pd(_mm512_mul_pd(_mm512_sub_pd(_mm512_mul_pd(c, dx), _mm512_mul_pd(s, dy)), toColumn), cx);
    const __m512d y = _mm512_add_pd(_mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(s, dx), _mm512_mul_pd(c, dy)), toRow), cy);
    // Ordered comparisons: false for NaN, as the scalar test.
    const __mmask8 inside = _mm512_cmp_pd_mask(x, zero, _CMP_GE_OQ) & _mm512_cmp_pd_mask(y, zero, _CMP_GE_OQ) &
      _mm512_cmp_pd_mask(x, lastX, _CMP_LT_OQ) & _mm512_cmp_pd_mask(y, lastY, _CMP_LT_OQ);
    if (inside == 0)
    {
      _mm_storeu_si128(reinterpret_cast<__m128i*>(out + k), _mm_setzero_si128());
      _mm_storel_epi64(reinterpret_cast<__m128i*>(valid + k), _mm_setzero_si128());
      continue;
    }
    // Lanes outside truncate x and y of 0 and read pixel 0: their values are dropped below.
    const __m256i x0 = _mm512_cvttpd_epi32(_mm512_maskz_mov_pd(inside, x)), y0 = _mm512_cvttpd_epi32(_mm512_maskz_mov_pd(inside, y));
    const __m512d fx = _mm512_sub_pd(x, _mm512_cvtepi32_pd(x0)), fy = _mm512_sub_pd(y, _mm512_cvtepi32_pd(y0));
    const __m256i at = _mm256_add_epi32(_mm256_mullo_epi32(y0, width), x0);
    const __m256i upper = _mm256_i32gather_epi32(words, at, 2), lower = _mm256_i32gather_epi32(words, _mm256_add_epi32(at, width), 2);
    // Each pair's left pixel in its low 16 bits, its right in the high: left + fx (right - left).
    const __m256i upperLeft = _mm256_and_si256(upper, low16), lowerLeft = _mm256_and_si256(lower, low16);
    const __m512d top = _mm512_add_pd(_mm512_cvtepi32_pd(upperLeft),
      _mm512_mul_pd(fx, _mm512_cvtepi32_pd(_mm256_sub_epi32(_mm256_srli_epi32(upper, 16), upperLeft))));
    const __m512d bottom = _mm512_add_pd(_mm512_cvtepi32_pd(lowerLeft),
      _mm512_mul_pd(fx, _mm512_cvtepi32_pd(_mm256_sub_epi32(_mm256_srli_epi32(lower, 16), lowerLeft))));
    const __m256i value = _mm512_cvttpd_epi32(_mm512_add_pd(_mm512_add_pd(top, _mm512_mul_pd(fy, _mm512_sub_pd(bottom, top))), half));
    // The values are whole numbers in [0, 4096): their low 16 bits are the value.
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + k), _mm_maskz_mov_epi16(inside, _mm256_cvtepi32_epi16(value)));
    _mm_storel_epi64(reinterpret_cast<__m128i*>(valid + k), _mm_maskz_set1_epi8(inside, 1));
  }
  WarpPixelRange(moving, columns, rows, m, pixels, k, k1, out, valid);
}

const bool HaveAVX2 = (__builtin_cpu_init(), __builtin_cpu_supports("avx2"));
const bool HaveAVX512 =
  HaveAVX2 && __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw");
#endif

/** In-plane rotation (degrees, image coordinates) of a view's projection under a small 3D
 *  rotation `omega` (radians, Room axes) about the isocentre, by projecting a ring of points. */
double ProjectedRotation(const XRayView& view, const Eigen::Vector3d& isocenter, const Eigen::Vector3d& omega)
{
  const Eigen::Vector3d axis = (isocenter - view.source).normalized();
  const Eigen::Vector3d u = axis.unitOrthogonal(), v = axis.cross(u);
  const Eigen::Matrix3d rotation = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  const Eigen::Vector2d centre = view.Project(isocenter);
  double sum = 0.0;
  for (int k = 0; k < 8; ++k)
  {
    const double a = k * M_PI / 4.0;
    const Eigen::Vector3d p = isocenter + 50.0 * (std::cos(a) * u + std::sin(a) * v);
    const Eigen::Vector2d before = view.Project(p) - centre;
    const Eigen::Vector2d after = view.Project(isocenter + rotation * (p - isocenter)) - centre;
    sum += std::atan2(before[0] * after[1] - before[1] * after[0], before.dot(after));
  }
  return sum / 8.0 / RadiansPerDegree;
}

} // namespace

namespace
{

/** Register2D's search; with `stretch`, a scale per panel axis (percent from 1) as well. */
Motion2D SearchMotion2D(const std::vector<uint16_t>& fixed, const std::vector<uint16_t>& moving, int columns, int rows,
  const Eigen::Vector2d& center, const uint8_t* fixedMask, int bins, double initialStepPixels, bool stretch)
{
  const size_t pixels = static_cast<size_t>(columns) * rows;
  if (fixed.size() != pixels || moving.size() != pixels)
  {
    throw InputError("2D registration", "image sizes differ");
  }
  JointHistogram histogram(bins);
  std::vector<PixelIndex> kept; // the pixels the mask keeps, and their fixed values
  std::vector<uint16_t> fixedKept;
  for (int row = 0, i = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column, ++i)
      if (!fixedMask || fixedMask[i])
      {
        kept.push_back({ column, row });
        fixedKept.push_back(fixed[i]);
      }
  std::vector<uint16_t> warped(kept.size());
  std::vector<uint8_t> valid(kept.size());
  Motion2D motion;
  motion.center = center;
  auto set = [&](const std::vector<double>& x)
  {
    motion.shift = { x[0], x[1] };
    motion.rotation = x[2];
    if (stretch)
      motion.scale = { 1.0 + 0.01 * x[3], 1.0 + 0.01 * x[4] };
  };
  auto mi = [&](const std::vector<double>& x)
  {
    set(x);
    WarpPixels(moving, columns, rows, motion, kept, warped, valid);
    histogram.Compute(fixedKept.data(), warped.data(), static_cast<long long>(kept.size()), valid.data());
    return histogram.MutualInformation();
  };
  // Shift along columns and rows (pixels) and in-plane rotation (degrees), by the optimiser
  // component the 6-DOF stages use (Nelder-Mead); a stretch in percent, from 2 % steps.
  ParameterSearch search;
  const double reach = 0.25 * std::min(columns, rows);
  search.lower = { -reach, -reach, -20.0 };
  search.upper = { reach, reach, 20.0 };
  const double step = initialStepPixels > 0.0 ? initialStepPixels : 0.03 * columns;
  search.step = { step, step, initialStepPixels > 0.0 ? 0.5 : 2.0 };
  search.tolerance = { 0.05, 0.05, 0.02 };
  search.maxEvaluations = 400;
  std::vector<double> x = { 0.0, 0.0, 0.0 };
  if (stretch)
  {
    for (std::vector<double>* values : { &search.lower, &search.upper, &search.step, &search.tolerance, &x })
      values->resize(5);
    search.lower[3] = search.lower[4] = -20.0;
    search.upper[3] = search.upper[4] = 20.0;
    search.step[3] = search.step[4] = 2.0;
    // The halves' distance needs the scale to 0.05 % (0.1 pixel across 200), not more.
    search.tolerance = { 0.1, 0.1, 0.05, 0.05, 0.05 };
  }
  MaximizeParameters(mi, x, search);
  set(x);
  return motion;
}

/** The columns and the rows of the pixels `mask` keeps, each sorted. */
std::array<std::vector<int>, 2> SortedValidColumnsAndRows(const std::vector<uint8_t>& mask, int columns, int rows)
{
  if (mask.size() != static_cast<size_t>(columns) * rows)
    throw InputError("halves' 2D registration", "the mask's size differs from the images'");
  std::array<std::vector<int>, 2> valid;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (mask[static_cast<size_t>(r) * columns + c])
        valid[0].push_back(c), valid[1].push_back(r);
  std::sort(valid[0].begin(), valid[0].end()); // the rows come sorted
  return valid;
}

} // namespace

bool WarpLanesAvailable(WarpLanes lanes)
{
  switch (lanes)
  {
    case WarpLanes::Widest:
    case WarpLanes::One:
      return true;
#ifdef XP_WARP_AVX2
    case WarpLanes::Four:
      return HaveAVX2;
    case WarpLanes::Eight:
      return HaveAVX512;
#endif
    default:
      return false;
  }
}

void WarpPixels(const std::vector<uint16_t>& moving, int columns, int rows, const Motion2D& motion,
  const std::vector<PixelIndex>& pixels, std::vector<uint16_t>& out, std::vector<uint8_t>& valid, WarpLanes lanes)
{
  if (moving.size() != static_cast<size_t>(columns) * rows || columns < 2 || rows < 2)
    throw InputError("2D warp", "the moving image's size differs from its columns x rows, or is under 2 x 2");
  if (!WarpLanesAvailable(lanes))
    throw Error("2D warp: this CPU cannot warp " + std::to_string(static_cast<int>(lanes)) + " pixels at a time");
  out.resize(pixels.size());
  valid.resize(pixels.size());
  const InverseMotion inverse(motion);
  using Range = void (*)(const uint16_t*, int, int, const InverseMotion&, const PixelIndex*, size_t, size_t, uint16_t*, uint8_t*);
  Range range = WarpPixelRange;
#ifdef XP_WARP_AVX2
  if (lanes == WarpLanes::Eight || (lanes == WarpLanes::Widest && HaveAVX512))
    range = WarpPixelRangeAVX512;
  else if (lanes == WarpLanes::Four || (lanes == WarpLanes::Widest && HaveAVX2))
    range = WarpPixelRangeAVX2;
#endif
  vtkSMPTools::For(size_t{ 0 }, pixels.size(),
    [&](size_t k0, size_t k1) { range(moving.data(), columns, rows, inverse, pixels.data(), k0, k1, out.data(), valid.data()); });
}

Motion2D Register2D(const std::vector<uint16_t>& fixed, const std::vector<uint16_t>& moving, int columns, int rows,
  const Eigen::Vector2d& center, const uint8_t* fixedMask, int bins, double initialStepPixels)
{
  return SearchMotion2D(fixed, moving, columns, rows, center, fixedMask, bins, initialStepPixels, false);
}

double HalvesApart(const std::vector<uint16_t>& fixed, const std::vector<uint16_t>& moving, const std::vector<uint8_t>& mask,
  int columns, int rows, const Eigen::Vector2d& center, int bins, double initialStepPixels)
{
  const std::array<std::vector<int>, 2> valid = SortedValidColumnsAndRows(mask, columns, rows);
  if (valid[0].empty())
    return 0.0;
  const int medianColumn = valid[0][valid[0].size() / 2], medianRow = valid[1][valid[1].size() / 2];
  double apart = 0.0;
  for (int split = 0; split < 2; ++split)
  {
    Eigen::Vector2d shifts[2];
    for (int side = 0; side < 2; ++side)
    {
      std::vector<uint8_t> half = mask;
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < columns; ++c)
          if ((split == 0 ? c >= medianColumn : r >= medianRow) != (side == 1))
            half[static_cast<size_t>(r) * columns + c] = 0;
      shifts[side] = Register2D(fixed, moving, columns, rows, center, half.data(), bins, initialStepPixels).shift;
    }
    apart = std::max(apart, (shifts[0] - shifts[1]).norm());
  }
  return apart;
}

double StretchedHalvesApart(const std::vector<uint16_t>& drr, const std::vector<uint16_t>& xray, const std::vector<uint8_t>& mask,
  int columns, int rows, int bins, double initialStepPixels, Motion2D* motion)
{
  const std::array<std::vector<int>, 2> valid = SortedValidColumnsAndRows(mask, columns, rows);
  if (valid[0].empty())
    return 0.0;
  // The halves' centroids along each axis: the means of the valid pixels before and from the
  // median (HalvesApart's split), and the valid pixels' centroid.
  Eigen::Vector2d centroid, between;
  for (int axis = 0; axis < 2; ++axis)
  {
    const std::vector<int>& values = valid[axis];
    const int median = values[values.size() / 2];
    double below = 0.0, above = 0.0;
    size_t belowCount = 0;
    for (int value : values)
      value < median ? (below += value, ++belowCount) : (above += value);
    centroid[axis] = (below + above) / values.size();
    between[axis] = belowCount > 0 ? above / (values.size() - belowCount) - below / belowCount : 0.0;
  }
  const Motion2D found = SearchMotion2D(drr, xray, columns, rows, centroid, mask.data(), bins, initialStepPixels, true);
  if (motion)
    *motion = found;
  return std::max(std::abs(found.scale[0] - 1.0) * between[0], std::abs(found.scale[1] - 1.0) * between[1]);
}

Pose InverseProjection(const std::vector<XRayView>& views, const std::vector<Motion2D>& motions, const Eigen::Vector3d& isocenter)
{
  if (views.size() != motions.size() || views.size() < 2)
  {
    throw InputError("inverse projection", "needs the 2D motions of at least two views");
  }
  const size_t n = views.size();
  Eigen::MatrixXd translation(2 * n, 3), rotation(n, 3);
  Eigen::VectorXd shifts(2 * n), angles(n);
  for (size_t v = 0; v < n; ++v)
  {
    const Eigen::Vector2d centre = views[v].Project(isocenter);
    for (int a = 0; a < 3; ++a)
    {
      // Numerical Jacobians: 1 mm along each Room axis, 0.01 rad about each.
      translation.block<2, 1>(2 * v, a) = views[v].Project(isocenter + Eigen::Vector3d::Unit(a)) - centre;
      rotation(v, a) = ProjectedRotation(views[v], isocenter, 0.01 * Eigen::Vector3d::Unit(a)) / (0.01 / RadiansPerDegree);
    }
    shifts.segment<2>(2 * v) = motions[v].shift;
    angles[v] = motions[v].rotation;
  }
  Pose update;
  update.translation = translation.colPivHouseholderQr().solve(shifts);
  // Minimum-norm rotation (degrees about X, Y, Z): the unobservable component stays 0.
  const Eigen::Vector3d omega = rotation.completeOrthogonalDecomposition().solve(angles);
  update.pitch = omega[0];
  update.roll = omega[1];
  update.yaw = omega[2];
  return update;
}

PreAlignmentResult PreAlign(StereoSimilarity& similarity, const Pose& start, const Eigen::Vector3d& isocenter, int maxIterations)
{
  PreAlignmentResult result;
  result.pose = start;
  const long long drrsBefore = similarity.RenderedDRRs();
  result.objective = similarity.Evaluate(start);
  const std::vector<RegistrationView>& items = similarity.Views();
  std::vector<XRayView> views;
  for (const RegistrationView& item : items)
    views.push_back(item.view);
  for (int iteration = 0; iteration < maxIterations; ++iteration)
  {
    // The views' 2D registrations are independent: one thread each (their warps then run in it).
    std::vector<Motion2D> motions(items.size());
    vtkSMPTools::For(size_t{ 0 }, items.size(), size_t{ 1 },
      [&](size_t first, size_t last)
      {
        for (size_t v = first; v < last; ++v)
          motions[v] = Register2D(similarity.XRayLevels(v), similarity.LastDRRLevels(v), items[v].view.Columns(),
            items[v].view.Rows(), items[v].view.Project(isocenter), items[v].mask.empty() ? nullptr : items[v].mask.data());
      });
    const Pose update = InverseProjection(views, motions, isocenter);
    const Pose candidate =
      Pose::FromTransform(update.ToTransform(isocenter) * result.pose.ToTransform(isocenter), isocenter);
    const double objective = similarity.Evaluate(candidate);
    ++result.iterations;
    if (objective <= result.objective)
    {
      similarity.Evaluate(result.pose); // leave the similarity's DRRs at the kept pose
      break;
    }
    result.pose = candidate;
    result.objective = objective;
    if (update.translation.norm() < 0.05 && std::abs(update.pitch) + std::abs(update.roll) + std::abs(update.yaw) < 0.05)
    {
      break;
    }
  }
  result.drrs = similarity.RenderedDRRs() - drrsBefore;
  return result;
}

} // namespace xp
