#include "xpImageLevels.h"

#include "xpExactVectors.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace xp
{

void LevelTable::Build(const float* values, const uint8_t* mask, long long count)
{
  // The sample's range, then each cell's share of the sample below its middle: a count per cell
  // of the values that lie between its middle and the one before, summed up. No sort: each value
  // finds its cell from the cells' spacing and the exact middles (a sort and a binary search per
  // cell gave the same table, at ten times the time).
  long long n = 0;
  float lowest = 0.0f, highest = 0.0f;
  for (long long i = 0; i < count; ++i)
  {
    if (mask && !mask[i])
      continue;
    const float v = values[i];
    lowest = n == 0 ? v : std::min(lowest, v);
    highest = n == 0 ? v : std::max(highest, v);
    ++n;
  }
  const double low = n == 0 ? 0.0 : lowest, high = n == 0 ? 1.0 : highest;
  const double margin = std::max(0.2 * (high - low), 1e-6);
  this->LowValue = low - margin;
  this->CellsPerValue = RankLevels / (high - low + 2.0 * margin);
  std::vector<float> middle(RankLevels);
  for (int c = 0; c < RankLevels; ++c)
    middle[c] = static_cast<float>(this->LowValue + (c + 0.5) / this->CellsPerValue);
  // below[c] counts the values under middle[c]: a value counts for every cell from the first whose
  // middle exceeds it (the middles never decrease).
  std::vector<long long> first(RankLevels + 1, 0);
  for (long long i = 0; i < count; ++i)
  {
    if (mask && !mask[i])
      continue;
    const float v = values[i];
    const double guess = std::floor((v - this->LowValue) * this->CellsPerValue + 0.5);
    int j = static_cast<int>(std::clamp(guess, 0.0, static_cast<double>(RankLevels)));
    while (j > 0 && middle[j - 1] > v)
      --j;
    while (j < RankLevels && middle[j] <= v)
      ++j;
    ++first[j];
  }
  this->Table.resize(RankLevels);
  long long below = 0;
  for (int c = 0; c < RankLevels; ++c)
  {
    below += first[c];
    this->Table[c] = static_cast<uint16_t>(n == 0 ? 0 : (RankLevels - 1) * static_cast<double>(below) / n);
  }
}

std::vector<uint16_t> Median3x3(const std::vector<uint16_t>& image, int columns, int rows)
{
  std::vector<uint16_t> out(image.size());
  for (int r = 0; r < rows; ++r)
  {
    const int above = std::max(r - 1, 0), below = std::min(r + 1, rows - 1);
    for (int c = 0; c < columns; ++c)
    {
      const int left = std::max(c - 1, 0), right = std::min(c + 1, columns - 1);
      uint16_t window[9];
      int n = 0;
      for (int y : { above, r, below })
        for (int x : { left, c, right })
          window[n++] = image[static_cast<size_t>(y) * columns + x];
      std::nth_element(window, window + 4, window + 9);
      out[static_cast<size_t>(r) * columns + c] = window[4];
    }
  }
  return out;
}

std::vector<uint16_t> EqualizedLevels(const std::vector<uint16_t>& image, const std::vector<uint8_t>& mask)
{
  std::vector<long long> histogram(65536, 0);
  long long valid = 0;
  for (size_t i = 0; i < image.size(); ++i)
    if (mask.empty() || mask[i])
    {
      ++histogram[image[i]];
      ++valid;
    }
  std::vector<uint16_t> level(65536, 0);
  long long below = 0;
  for (size_t v = 0; v < level.size(); ++v)
  {
    level[v] = static_cast<uint16_t>(valid > 0 ? (RankLevels - 1) * (below + 0.5 * histogram[v]) / valid : 0);
    below += histogram[v];
  }
  std::vector<uint16_t> out(image.size());
  for (size_t i = 0; i < image.size(); ++i)
    out[i] = level[image[i]];
  return out;
}

namespace
{

/** |pixel - the mean of its four neighbours| at an interior pixel i of a columns-wide image. */
float NeighbourDifference(const std::vector<uint16_t>& image, size_t i, int columns)
{
  const double neighbours = 0.25 * (image[i - 1] + image[i + 1] + image[i - columns] + image[i + columns]);
  return static_cast<float>(std::abs(image[i] - neighbours));
}

/** The median |difference| of white noise of sd s is 0.6745 x sqrt(1.25) s: 1.25 s^2 is the
 *  variance of a pixel less the mean of four independent neighbours. */
const double MedianDifferencePerSigma = 0.6745 * std::sqrt(1.25);

} // namespace

double RankNoiseLevels(const std::vector<uint16_t>& image, int columns, int rows, const std::vector<uint8_t>& mask)
{
  if (columns < 0 || rows < 0 || image.size() != static_cast<size_t>(columns) * static_cast<size_t>(rows) ||
    (!mask.empty() && mask.size() != image.size()))
    throw std::invalid_argument("RankNoiseLevels: the image (and a mask) must hold columns x rows pixels");
  const std::vector<uint16_t> ranks = EqualizedLevels(image, mask);
  std::vector<float> differences;
  differences.reserve(ranks.size());
  for (int r = 1; r + 1 < rows; ++r)
    for (int c = 1; c + 1 < columns; ++c)
    {
      const size_t i = static_cast<size_t>(r) * columns + c;
      if (mask.empty() || mask[i])
        differences.push_back(NeighbourDifference(ranks, i, columns));
    }
  if (differences.empty())
    return 0.0;
  std::nth_element(differences.begin(), differences.begin() + differences.size() / 2, differences.end());
  return differences[differences.size() / 2] / MedianDifferencePerSigma;
}

std::vector<uint16_t> NoiseScaledLevels(const std::vector<uint16_t>& image, int columns, int rows,
  const std::vector<uint8_t>& mask, double levelsPerSigma, double minSigma)
{
  constexpr int bands = 64;
  int top = 1;
  for (uint16_t v : image)
    top = std::max<int>(top, v);
  const double bandWidth = (top + 1.0) / bands;
  std::vector<std::vector<float>> differences(bands);
  for (int r = 1; r + 1 < rows; ++r)
    for (int c = 1; c + 1 < columns; ++c)
    {
      const size_t i = static_cast<size_t>(r) * columns + c;
      if (!mask.empty() && !mask[i])
        continue;
      differences[std::min(bands - 1, static_cast<int>(image[i] / bandWidth))].push_back(NeighbourDifference(image, i, columns));
    }
  std::vector<double> sigma(bands, -1.0);
  for (int b = 0; b < bands; ++b)
  {
    std::vector<float>& d = differences[b];
    if (d.size() < 50)
      continue;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    sigma[b] = std::max(minSigma, d[d.size() / 2] / MedianDifferencePerSigma);
  }
  // Bands with too few pixels take their nearest measured neighbour's sd.
  for (int b = 0; b < bands; ++b)
    if (sigma[b] < 0.0)
    {
      for (int k = 1; k < bands && sigma[b] < 0.0; ++k)
      {
        if (b - k >= 0 && differences[b - k].size() >= 50)
          sigma[b] = sigma[b - k];
        else if (b + k < bands && differences[b + k].size() >= 50)
          sigma[b] = sigma[b + k];
      }
      if (sigma[b] < 0.0)
        sigma[b] = minSigma;
    }
  std::vector<double> level(static_cast<size_t>(top) + 1, 0.0);
  for (int v = 1; v <= top; ++v)
    level[v] = level[v - 1] + levelsPerSigma / sigma[std::min(bands - 1, static_cast<int>(v / bandWidth))];
  std::vector<uint16_t> out(image.size());
  for (size_t i = 0; i < image.size(); ++i)
    out[i] = static_cast<uint16_t>(std::min(65535.0, std::round(level[image[i]])));
  return out;
}

namespace
{

/** In-place separable Gaussian of a w x h grid, edges replicated; its weights sum to 1 when
 *  `normalized`, else their peak is 1 (a normalised convolution divides by its own weights).
 *  Each output sums its taps in the same order (left to right, then top to bottom) whichever
 *  loop computes it: the edges with clamping, the interior of a row and the columns tap by tap
 *  over the whole row, so that the compiler vectorises across outputs. No wider than the grid:
 *  taps beyond it would all read its edge. */
template <typename T>
XP_WIDE_EXACT void Blur(std::vector<T>& grid, int w, int h, double sigma, bool normalized = false)
{
  const int radius = std::max(1, static_cast<int>(std::min(std::ceil(3.0 * sigma), static_cast<double>(std::max(w, h)))));
  std::vector<T> kernel(2 * radius + 1);
  T sum = 0;
  for (int i = -radius; i <= radius; ++i)
    sum += kernel[i + radius] = static_cast<T>(std::exp(-0.5 * i * i / (sigma * sigma)));
  if (normalized)
    for (T& weight : kernel)
      weight /= sum;
  std::vector<T> out(grid.size());
  const int interiorBegin = std::min(radius, w), interiorEnd = std::max(interiorBegin, w - radius);
  for (int y = 0; y < h; ++y)
  {
    const T* in = grid.data() + static_cast<size_t>(y) * w;
    T* row = out.data() + static_cast<size_t>(y) * w;
    const auto edge = [&](int x)
    {
      T s = 0;
      for (int k = -radius; k <= radius; ++k)
        s += kernel[k + radius] * in[std::clamp(x + k, 0, w - 1)];
      row[x] = s;
    };
    for (int x = 0; x < interiorBegin; ++x)
      edge(x);
    for (int x = interiorEnd; x < w; ++x)
      edge(x);
    T* __restrict interior = row + interiorBegin;
    const int count = interiorEnd - interiorBegin;
    std::fill(interior, interior + count, T(0));
    for (int k = 0; k <= 2 * radius; ++k)
    {
      const T weight = kernel[k];
      const T* __restrict taps = in + interiorBegin - radius + k;
      for (int x = 0; x < count; ++x)
        interior[x] += weight * taps[x];
    }
  }
  std::vector<T> sums(static_cast<size_t>(w));
  for (int y = 0; y < h; ++y)
  {
    std::fill(sums.begin(), sums.end(), T(0));
    for (int k = -radius; k <= radius; ++k)
    {
      const T weight = kernel[k + radius];
      const T* row = out.data() + static_cast<size_t>(std::clamp(y + k, 0, h - 1)) * w;
      for (int x = 0; x < w; ++x)
        sums[x] += weight * row[x];
    }
    std::copy(sums.begin(), sums.end(), grid.begin() + static_cast<std::ptrdiff_t>(y) * w);
  }
}

} // namespace

std::vector<uint16_t> GaussianSmoothed(
  const std::vector<uint16_t>& image, int columns, int rows, double sigmaPixels, int scale)
{
  std::vector<float> grid(image.begin(), image.end());
  Blur(grid, columns, rows, sigmaPixels, true);
  std::vector<uint16_t> smoothed(image.size());
  for (size_t i = 0; i < grid.size(); ++i)
    smoothed[i] = static_cast<uint16_t>(std::min(65535.0f, std::round(grid[i] * static_cast<float>(scale))));
  return smoothed;
}

void SubtractLowPass(float* values, const uint8_t* mask, int columns, int rows, double sigmaPixels)
{
  if (sigmaPixels > 0.0)
    MaskedLowPass(mask, columns, rows, sigmaPixels).Subtract(values);
}

MaskedLowPass::MaskedLowPass(const uint8_t* mask, int columns, int rows, double sigmaPixels)
  : Mask(mask)
  , Columns(columns)
  , Rows(rows)
{
  if (!(sigmaPixels > 0.0))
    return;
  this->Factor = std::max(1, static_cast<int>(std::lround(sigmaPixels / 4.0)));
  this->GridWidth = (columns + this->Factor - 1) / this->Factor;
  this->GridHeight = (rows + this->Factor - 1) / this->Factor;
  this->GridSigma = sigmaPixels / this->Factor;
  this->Weight.assign(static_cast<size_t>(this->GridWidth) * this->GridHeight, 0.0);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (!mask || mask[static_cast<size_t>(r) * columns + c])
        this->Weight[static_cast<size_t>(r / this->Factor) * this->GridWidth + c / this->Factor] += 1.0;
  Blur(this->Weight, this->GridWidth, this->GridHeight, this->GridSigma);
  const int w = this->GridWidth;
  this->ColumnCell.resize(static_cast<size_t>(columns));
  this->ColumnLow.resize(static_cast<size_t>(columns));
  this->ColumnHigh.resize(static_cast<size_t>(columns));
  this->ColumnWeight.resize(static_cast<size_t>(columns));
  for (int c = 0; c < columns; ++c)
  {
    this->ColumnCell[c] = c / this->Factor;
    // Bilinear between cell centres: pixel c lies at (c + 0.5) / factor - 0.5 in cell units.
    const double x = std::clamp((c + 0.5) / this->Factor - 0.5, 0.0, w - 1.0);
    this->ColumnLow[c] = std::min(static_cast<int>(x), w - 1);
    this->ColumnHigh[c] = std::min(this->ColumnLow[c] + 1, w - 1);
    this->ColumnWeight[c] = x - this->ColumnLow[c];
  }
}

XP_WIDE_EXACT void MaskedLowPass::Subtract(float* values) const
{
  if (this->Weight.empty())
    return;
  const int columns = this->Columns, rows = this->Rows, factor = this->Factor, w = this->GridWidth, h = this->GridHeight;
  const uint8_t* mask = this->Mask;
  const int* cellOf = this->ColumnCell.data();
  std::vector<double> sum(this->Weight.size(), 0.0);
  for (int r = 0; r < rows; ++r)
  {
    double* cells = sum.data() + static_cast<size_t>(r / factor) * w;
    const float* row = values + static_cast<size_t>(r) * columns;
    const uint8_t* valid = mask ? mask + static_cast<size_t>(r) * columns : nullptr;
    for (int c = 0; c < columns; ++c)
      if (!valid || valid[c])
        cells[cellOf[c]] += row[c];
  }
  Blur(sum, w, h, this->GridSigma);
  for (size_t cell = 0; cell < sum.size(); ++cell)
    sum[cell] = this->Weight[cell] > 1e-9 ? sum[cell] / this->Weight[cell] : 0.0;
  for (int r = 0; r < rows; ++r)
  {
    const double y = std::clamp((r + 0.5) / factor - 0.5, 0.0, h - 1.0);
    const int y0 = std::min(static_cast<int>(y), h - 1), y1 = std::min(y0 + 1, h - 1);
    const double fy = y - y0;
    const double* low0 = sum.data() + static_cast<size_t>(y0) * w;
    const double* low1 = sum.data() + static_cast<size_t>(y1) * w;
    float* row = values + static_cast<size_t>(r) * columns;
    const uint8_t* valid = mask ? mask + static_cast<size_t>(r) * columns : nullptr;
    for (int c = 0; c < columns; ++c)
    {
      if (valid && !valid[c])
        continue;
      const int x0 = this->ColumnLow[c], x1 = this->ColumnHigh[c];
      const double fx = this->ColumnWeight[c];
      const double low = (1 - fy) * ((1 - fx) * low0[x0] + fx * low0[x1]) + fy * ((1 - fx) * low1[x0] + fx * low1[x1]);
      row[c] = static_cast<float>(row[c] - low);
    }
  }
}

} // namespace xp
