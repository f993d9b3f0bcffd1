#include "xpCTCoverage.h"

#include "xpError.h"

#include <vtkSMPTools.h>

#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/** The body's outline along the slice axis: voxels (i, j) with attenuation in any slice, widened
 *  by `radius` voxels (a square). */
std::vector<uint8_t> Outline(const AttenuationVolume& volume, int radiusI, int radiusJ)
{
  const Eigen::Vector3i& d = volume.Dimensions();
  std::vector<uint8_t> seen(static_cast<size_t>(d[0]) * d[1], 0);
  const Eigen::Vector3i stored = volume.StoredDimensions(), origin = volume.StoredOrigin(); // all attenuation is there
  for (int k = 0; k < stored[2]; ++k)
    for (int j = 0; j < stored[1]; ++j)
      for (int i = 0; i < stored[0]; ++i)
        if (volume.StoredAt(i, j, k) > 0.0f)
          seen[static_cast<size_t>(origin[1] + j) * d[0] + origin[0] + i] = 1;
  std::vector<uint8_t> wide(seen.size(), 0), rows(seen.size(), 0);
  for (int j = 0; j < d[1]; ++j)
    for (int i = 0; i < d[0]; ++i)
      for (int n = std::max(0, i - radiusI); n <= std::min(d[0] - 1, i + radiusI) && !rows[static_cast<size_t>(j) * d[0] + i]; ++n)
        rows[static_cast<size_t>(j) * d[0] + i] = seen[static_cast<size_t>(j) * d[0] + n];
  for (int j = 0; j < d[1]; ++j)
    for (int i = 0; i < d[0]; ++i)
      for (int n = std::max(0, j - radiusJ); n <= std::min(d[1] - 1, j + radiusJ) && !wide[static_cast<size_t>(j) * d[0] + i]; ++n)
        wide[static_cast<size_t>(j) * d[0] + i] = rows[static_cast<size_t>(n) * d[0] + i];
  return wide;
}

} // namespace

std::vector<uint8_t> CTCoverageMask(
  const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const XRayView& view, double marginMM)
{
  return CTCoverage(volume, marginMM).Mask(ctToRoom, view);
}

CTCoverage::CTCoverage(const AttenuationVolume& volume, double marginMM)
  : Volume(volume)
  , MarginMM(marginMM)
{
  // CT voxel index -> CT mm, and its spacing along each index axis.
  this->IndexToCT = volume.IndexToCT();
  this->Spacing = Eigen::Vector3d(this->IndexToCT.linear().col(0).norm(), this->IndexToCT.linear().col(1).norm(),
    this->IndexToCT.linear().col(2).norm());
  this->Outline = xp::Outline(volume, static_cast<int>(std::ceil(marginMM / this->Spacing[0])),
    static_cast<int>(std::ceil(marginMM / this->Spacing[1])));
  const Eigen::Vector3i& d = volume.Dimensions();
  this->OutlineLow = Eigen::Vector2d(d[0], d[1]);
  this->OutlineHigh = Eigen::Vector2d(-1, -1);
  for (int j = 0; j < d[1]; ++j)
    for (int i = 0; i < d[0]; ++i)
      if (this->Outline[static_cast<size_t>(j) * d[0] + i])
      {
        this->OutlineLow = this->OutlineLow.cwiseMin(Eigen::Vector2d(i, j));
        this->OutlineHigh = this->OutlineHigh.cwiseMax(Eigen::Vector2d(i, j));
      }
  this->OutlineLow.array() -= 0.5;
  this->OutlineHigh.array() += 0.5;
}

std::vector<uint8_t> CTCoverage::Mask(const Eigen::Isometry3d& ctToRoom, const XRayView& view, uint8_t ends) const
{
  std::vector<uint8_t> mask = this->EndFaces(ctToRoom, view);
  for (uint8_t& m : mask)
    m = (m & ends) == 0;
  return mask;
}

std::vector<uint8_t> CTCoverage::EndFaces(const Eigen::Isometry3d& ctToRoom, const XRayView& view) const
{
  const Eigen::Vector3i& d = this->Volume.Dimensions();
  const std::vector<uint8_t>& outline = this->Outline;
  const Eigen::Affine3d roomToIndex = (ctToRoom * this->IndexToCT).inverse();
  const double kLow = -0.5 + this->MarginMM / this->Spacing[2], kHigh = d[2] - 0.5 - this->MarginMM / this->Spacing[2];
  const int columns = view.Columns(), rows = view.Rows();
  std::vector<uint8_t> faces(static_cast<size_t>(columns) * rows, 0);
  if (this->OutlineHigh[0] < this->OutlineLow[0])
    return faces; // no attenuation anywhere: nothing to cross
  const Eigen::Vector3d source = roomToIndex * view.source;
  vtkSMPTools::For(0, rows, [&](int firstRow, int lastRow)
    {
      for (int row = firstRow; row < lastRow; ++row)
        for (int column = 0; column < columns; ++column)
        {
          const Eigen::Vector3d direction = roomToIndex * view.PixelCenter(column, row) - source;
          // The ray's parameter range over the outline's lateral extent.
          double t0 = 0.0, t1 = 1.0;
          for (int axis = 0; axis < 2; ++axis)
          {
            if (std::abs(direction[axis]) < 1e-12)
            {
              if (source[axis] < this->OutlineLow[axis] || source[axis] > this->OutlineHigh[axis])
                t1 = -1.0;
              continue;
            }
            double ta = (this->OutlineLow[axis] - source[axis]) / direction[axis],
                   tb = (this->OutlineHigh[axis] - source[axis]) / direction[axis];
            if (ta > tb)
              std::swap(ta, tb);
            t0 = std::max(t0, ta);
            t1 = std::min(t1, tb);
          }
          if (t0 > t1)
            continue;
          // Only the parts of [t0, t1] beyond the end slices can uncover the pixel: most rays
          // have none, and the slice index is linear in t.
          double inside0 = t0, inside1 = t1; // where kLow <= k <= kHigh
          if (std::abs(direction[2]) < 1e-12)
          {
            if (source[2] < kLow || source[2] > kHigh)
              inside1 = inside0 - 1.0; // the whole range is beyond
          }
          else
          {
            double ta = (kLow - source[2]) / direction[2], tb = (kHigh - source[2]) / direction[2];
            if (ta > tb)
              std::swap(ta, tb);
            inside0 = std::max(t0, ta);
            inside1 = std::min(t1, tb);
          }
          if (inside0 <= t0 && inside1 >= t1)
            continue;
          // One sample per voxel crossed laterally over a part beyond one end face; the part
          // lies wholly beyond that face, so its middle names it.
          const double lateral = std::max(std::abs(direction[0]), std::abs(direction[1]));
          const double step = lateral > 1e-12 ? 1.0 / lateral : std::max(t1 - t0, 1e-3);
          const auto faceCrossedInBody = [&](double from, double to) -> uint8_t
          {
            const uint8_t face = source[2] + 0.5 * (from + to) * direction[2] < kLow ? FirstSliceFace : LastSliceFace;
            for (double t = from; t <= to; t += step)
            {
              const Eigen::Vector3d p = source + t * direction;
              const int i = std::clamp(static_cast<int>(std::lround(p[0])), 0, d[0] - 1);
              const int j = std::clamp(static_cast<int>(std::lround(p[1])), 0, d[1] - 1);
              if (outline[static_cast<size_t>(j) * d[0] + i] && (p[2] < kLow || p[2] > kHigh))
                return face;
            }
            return 0;
          };
          uint8_t& face = faces[static_cast<size_t>(row) * columns + column];
          if (inside0 > inside1)
            face = faceCrossedInBody(t0, t1);
          else
            face = (inside0 > t0 ? faceCrossedInBody(t0, inside0) : 0) | (inside1 < t1 ? faceCrossedInBody(inside1, t1) : 0);
        }
    });
  return faces;
}

EndFaceEvidence MeasureAnatomyBeyondEndFaces(const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr,
  const std::vector<uint8_t>& content, const std::vector<uint8_t>& endFaces, double minExcess)
{
  const size_t n = xray.size();
  if (drr.size() != n || endFaces.size() != n || !(content.empty() || content.size() == n))
    throw InputError("end-face evidence", "the X-ray, DRR, content mask and end-face labels differ in size");
  const auto counts = [&](size_t i) { return content.empty() || content[i]; };
  EndFaceEvidence evidence;
  for (size_t i = 0; i < n; ++i)
    if (counts(i))
      for (int f = 0; f < 2; ++f)
        evidence.pixels[f] += (endFaces[i] >> f) & 1;
  // The X-ray value each DRR level predicts: the median X-ray value of the covered rays in each
  // of 64 DRR levels of equal count (robust to the pre-alignment's misplaced edges).
  std::vector<std::pair<uint16_t, uint16_t>> covered; // (DRR, X-ray)
  for (size_t i = 0; i < n; ++i)
    if (counts(i) && endFaces[i] == 0)
      covered.emplace_back(drr[i], xray[i]);
  constexpr int levels = 64;
  if (!(minExcess > 0.0) || static_cast<long long>(covered.size()) < 8 * levels) // NaN: the safe side
  {
    evidence.facesToLeaveOut = BothEndFaces;
    return evidence;
  }
  std::sort(covered.begin(), covered.end());
  std::vector<uint16_t> upper(levels);
  std::vector<double> predicted(levels);
  std::vector<uint16_t> values;
  for (int l = 0; l < levels; ++l)
  {
    const size_t from = covered.size() * l / levels, to = covered.size() * (l + 1) / levels;
    values.clear();
    for (size_t i = from; i < to; ++i)
      values.push_back(covered[i].second);
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    predicted[l] = values[values.size() / 2];
    upper[l] = covered[to - 1].first;
  }
  // The DRR's values rise as attenuation falls; the X-ray's may rise (transmission) or fall (log).
  const double polarity = predicted.back() >= predicted.front() ? 1.0 : -1.0;
  // DRR values beyond the covered ones, up to its empty rays (4095), predict values towards the
  // X-ray's open field (its least attenuated 0.5 %): when the body fills the covered rows, no
  // covered ray shows the open field.
  std::vector<uint16_t> sorted = xray;
  const size_t rank = static_cast<size_t>((polarity > 0 ? 0.995 : 0.005) * (sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + rank, sorted.end());
  const double openField = sorted[rank], lastCovered = upper.back();
  const bool extend = polarity * (openField - predicted.back()) > 0.0 && lastCovered < 4095.0;
  const auto predict = [&](uint16_t d)
  {
    if (extend && d > lastCovered)
      return predicted.back() + (openField - predicted.back()) * std::min(1.0, (d - lastCovered) / (4095.0 - lastCovered));
    const int l = static_cast<int>(std::lower_bound(upper.begin(), upper.end(), d) - upper.begin());
    return predicted[std::min(l, levels - 1)];
  };
  const double range = std::max(std::abs(openField - predicted.front()), 1.0);
  const long long minPixels = std::max<long long>(50, static_cast<long long>(n / 200));
  std::vector<double> excess;
  for (int f = 0; f < 2; ++f)
  {
    const uint8_t face = static_cast<uint8_t>(1 << f);
    excess.clear(); // positive: more attenuated than its DRR predicts
    for (size_t i = 0; i < n; ++i)
      if (counts(i) && (endFaces[i] & face))
        excess.push_back(polarity * (predict(drr[i]) - xray[i]) / range);
    if (static_cast<long long>(excess.size()) < minPixels)
    {
      evidence.facesToLeaveOut |= face;
      continue;
    }
    const size_t upperQuartile = excess.size() * 3 / 4;
    std::nth_element(excess.begin(), excess.begin() + upperQuartile, excess.end());
    evidence.excess[f] = excess[upperQuartile];
    if (evidence.excess[f] >= minExcess)
      evidence.facesToLeaveOut |= face;
  }
  return evidence;
}

} // namespace xp
