#include "xpEntropyMask.h"

#include "xpError.h"
#include "xpXRayView.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/** Half resolution by 2x2 means, then a 3x3 binomial ([1 2 1]/4) smoothing with clamped edges. */
std::vector<float> HalfResolutionSmoothed(const uint16_t* image, int columns, int rows, int& halfColumns, int& halfRows)
{
  halfColumns = columns / 2;
  halfRows = rows / 2;
  std::vector<float> half(static_cast<size_t>(halfColumns) * halfRows);
  for (int y = 0; y < halfRows; ++y)
    for (int x = 0; x < halfColumns; ++x)
    {
      const uint16_t* p = image + static_cast<size_t>(2 * y) * columns + 2 * x;
      half[static_cast<size_t>(y) * halfColumns + x] = 0.25f * (p[0] + p[1] + p[columns] + p[columns + 1]);
    }
  std::vector<float> across(half.size()), smooth(half.size());
  for (int y = 0; y < halfRows; ++y)
    for (int x = 0; x < halfColumns; ++x)
    {
      const float* row = half.data() + static_cast<size_t>(y) * halfColumns;
      across[static_cast<size_t>(y) * halfColumns + x] =
        0.25f * row[std::max(x - 1, 0)] + 0.5f * row[x] + 0.25f * row[std::min(x + 1, halfColumns - 1)];
    }
  for (int y = 0; y < halfRows; ++y)
    for (int x = 0; x < halfColumns; ++x)
    {
      const auto at = [&](int yy) { return across[static_cast<size_t>(std::clamp(yy, 0, halfRows - 1)) * halfColumns + x]; };
      smooth[static_cast<size_t>(y) * halfColumns + x] = 0.25f * at(y - 1) + 0.5f * at(y) + 0.25f * at(y + 1);
    }
  return smooth;
}

} // namespace

EntropyMaskResult ComputeEntropyMask(
  const uint16_t* image, int columns, int rows, const uint8_t* roi, const EntropyMaskSettings& settings)
{
  const int w = settings.window, r = w / 2;
  if (w < 3 || w % 2 == 0)
  {
    throw InputError("entropy window", "must be odd and at least 3");
  }
  if (settings.binWidth < 1 || settings.maxValue < settings.binWidth)
  {
    throw InputError("entropy bin width", "must be between 1 and the maximum grey value");
  }
  int hc = 0, hr = 0;
  if (columns / 2 < 2 * w || rows / 2 < 2 * w)
  {
    throw InputError("X-ray image", "too small for the entropy mask (" + std::to_string(columns) + "x" +
        std::to_string(rows) + " pixels)");
  }
  const std::vector<float> smooth = HalfResolutionSmoothed(image, columns, rows, hc, hr);
  const int bins = settings.maxValue / settings.binWidth + 1;
  std::vector<int> binned(smooth.size());
  for (size_t i = 0; i < smooth.size(); ++i)
  {
    binned[i] = std::clamp(static_cast<int>(smooth[i]) / settings.binWidth, 0, bins - 1);
  }

  // Block entropy by a sliding histogram along each row: H = ln N - (1/N) sum c ln c, where the
  // sum is updated in O(1) as one column of the window leaves and one enters.
  const int n = w * w;
  std::vector<double> cLogC(n + 1, 0.0);
  for (int c = 1; c <= n; ++c)
    cLogC[c] = c * std::log(static_cast<double>(c));
  const double normaliser = std::log(static_cast<double>(bins)); // bins >= 2: maxValue >= binWidth
  std::vector<float> halfEntropy(smooth.size(), -1.0f);
  std::vector<int> counts(bins);
  double sum = 0.0;
  long long defined = 0;
  for (int y = r; y < hr - r; ++y)
  {
    std::fill(counts.begin(), counts.end(), 0);
    double s = 0.0;
    const auto add = [&](int bin, int delta)
    {
      s -= cLogC[counts[bin]];
      counts[bin] += delta;
      s += cLogC[counts[bin]];
    };
    for (int yy = y - r; yy <= y + r; ++yy)
      for (int xx = 0; xx < w; ++xx)
        add(binned[static_cast<size_t>(yy) * hc + xx], +1);
    for (int x = r; x < hc - r; ++x)
    {
      if (x > r)
      {
        for (int yy = y - r; yy <= y + r; ++yy)
        {
          add(binned[static_cast<size_t>(yy) * hc + x - r - 1], -1);
          add(binned[static_cast<size_t>(yy) * hc + x + r], +1);
        }
      }
      const double h = std::max(0.0, (std::log(static_cast<double>(n)) - s / n) / normaliser);
      halfEntropy[static_cast<size_t>(y) * hc + x] = static_cast<float>(h);
      sum += h;
      ++defined;
    }
  }
  EntropyMaskResult result;
  result.imageEntropy = sum / static_cast<double>(defined);
  const double threshold = settings.thresholdScale * result.imageEntropy;

  result.mask.assign(static_cast<size_t>(columns) * rows, 0);
  result.entropy.assign(result.mask.size(), 0.0f);
  long long valid = 0;
  for (int y = 0; y < rows; ++y)
  {
    const int hy = std::min(y / 2, hr - 1);
    for (int x = 0; x < columns; ++x)
    {
      const size_t i = static_cast<size_t>(y) * columns + x;
      const float h = halfEntropy[static_cast<size_t>(hy) * hc + std::min(x / 2, hc - 1)];
      result.entropy[i] = std::max(h, 0.0f);
      result.mask[i] = (h >= 0.0f && h >= threshold && (!roi || roi[i])) ? 1 : 0;
      valid += result.mask[i];
    }
  }
  result.validFraction = static_cast<double>(valid) / result.mask.size();
  return result;
}

std::vector<uint8_t> TransferMask(const std::vector<uint8_t>& mask, const XRayView& from, const XRayView& to)
{
  if (mask.size() != static_cast<size_t>(from.Columns()) * from.Rows())
  {
    throw InputError("mask", "size does not match the X-ray's panel");
  }
  std::vector<uint8_t> out(static_cast<size_t>(to.Columns()) * to.Rows(), 0);
  for (int row = 0; row < to.Rows(); ++row)
  {
    for (int column = 0; column < to.Columns(); ++column)
    {
      const Eigen::Vector3d onPanel = to.PixelCenter(column, row);
      // The ray from `to`'s source through the pixel, met with `from`'s panel plane.
      const Eigen::Vector3d n = from.NormalTowardsSource();
      const Eigen::Vector3d direction = onPanel - to.source;
      const double denominator = n.dot(direction);
      if (std::abs(denominator) < 1e-12)
        continue;
      const double t = n.dot(from.detectorCenter - to.source) / denominator;
      const Eigen::Vector3d hit = to.source + t * direction - from.detectorCenter;
      const long c = std::lround(hit.dot(from.rowDirection) / from.pixelSpacing[0] + 0.5 * (from.Columns() - 1));
      const long r = std::lround(hit.dot(from.columnDirection) / from.pixelSpacing[1] + 0.5 * (from.Rows() - 1));
      if (c >= 0 && r >= 0 && c < from.Columns() && r < from.Rows())
      {
        out[static_cast<size_t>(row) * to.Columns() + column] = mask[static_cast<size_t>(r) * from.Columns() + c];
      }
    }
  }
  return out;
}

namespace
{

/** One axis of DilateMask: `lines` lines of `length` pixels, `step` apart along a line and
 *  `lineStep` between lines; a pixel is set when a 1 lies within `radius` of it on its line. */
void DilateLines(const uint8_t* in, uint8_t* out, int lines, int length, size_t step, size_t lineStep, int radius)
{
  for (int line = 0; line < lines; ++line)
  {
    const size_t first = line * lineStep;
    int last = -radius - 1; // the last 1 at or before position p
    for (int p = 0; p < length + radius; ++p)
    {
      if (p < length && in[first + p * step])
        last = p;
      const int at = p - radius;
      if (at >= 0 && last >= at - radius)
        out[first + at * step] = 1;
    }
  }
}

} // namespace

std::vector<uint8_t> DilateMask(const std::vector<uint8_t>& mask, int columns, int rows, int radius)
{
  if (radius <= 0)
    return mask;
  std::vector<uint8_t> across(mask.size(), 0), out(mask.size(), 0);
  DilateLines(mask.data(), across.data(), rows, columns, 1, static_cast<size_t>(columns), radius);
  DilateLines(across.data(), out.data(), columns, rows, static_cast<size_t>(columns), 1, radius);
  return out;
}

} // namespace xp
