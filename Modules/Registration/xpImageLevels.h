/**
 * @file xpImageLevels.h
 * @brief The grey levels that MI bins: ranks instead of raw values, and structure instead of
 *        shading.
 *
 * Ranks make the histogram's bins hold equal shares of the valid pixels whatever the grey-level
 * mapping of the image. Subtracting a wide low-pass removes the smooth shading that scatter, the
 * heel effect and a couch add to an X-ray and a DRR does not have, before the ranks are taken.
 */
#ifndef xpImageLevels_h
#define xpImageLevels_h

#include "vtkXPRegistrationModule.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace xp
{

/** 4096 levels: the 12-bit range MI's histogram spans. */
constexpr int RankLevels = 4096;

/** Monotone map of values to levels 0..4095 by their rank among a reference sample. */
class VTKXPREGISTRATION_EXPORT LevelTable
{
public:
  /** The reference: the values of `count` pixels whose mask is non-zero (null = all). */
  void Build(const float* values, const uint8_t* mask, long long count);
  bool Empty() const { return this->Table.empty(); }
  /** Level of a value: the share of the reference below it, in cells 1/4096 of its range wide
   *  (20 % wider than the reference's on each side: later poses may see a little more). */
  uint16_t operator()(float value) const
  {
    long long cell = static_cast<long long>((value - this->LowValue) * this->CellsPerValue);
    cell = cell < 0 ? 0 : (cell >= RankLevels ? RankLevels - 1 : cell);
    return this->Table[static_cast<size_t>(cell)];
  }
  /** The map as data (for a GPU that applies it): cell = (value - Low()) * ToCell(), truncated
   *  and clamped to the table; level = Levels()[cell]. */
  double Low() const { return this->LowValue; }
  double ToCell() const { return this->CellsPerValue; }
  const std::vector<uint16_t>& Levels() const { return this->Table; }

private:
  double LowValue = 0.0;
  double CellsPerValue = 1.0;
  std::vector<uint16_t> Table;
};

/** Each pixel the median of its 3x3 neighbourhood (edges replicated). Noise with heavy tails (a
 *  log of few quanta, a "for presentation" image's unsharp mask of it, dead and hot pixels) loses
 *  its outliers, and an edge keeps its place. */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> Median3x3(const std::vector<uint16_t>& image, int columns, int rows);

/**
 * A columns x rows image smoothed by a Gaussian of sd `sigmaPixels` (separable, edges
 * replicated), its values multiplied by `scale` before rounding so that the averages keep the
 * levels between the stored ones (an 8- or 12-bit image smoothed would otherwise fall back onto
 * its own few levels). The result must fit 16 bits: scale * the largest value <= 65535.
 */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> GaussianSmoothed(
  const std::vector<uint16_t>& image, int columns, int rows, double sigmaPixels, int scale);

/** Mid-rank levels of a 12-bit image over its valid pixels (histogram equalisation). */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> EqualizedLevels(const std::vector<uint16_t>& image, const std::vector<uint8_t>& mask);

/**
 * The noise sd of a columns x rows image's ranks (EqualizedLevels over the valid pixels), in
 * levels of RankLevels: from each valid pixel's difference to the mean of its four neighbours, the
 * median absolute one (edges do not count), scaled to the sd of white noise. Ranks make it the
 * noise against the image's own contrast whatever its grey-level mapping: a thick body's starved
 * interior, where few levels carry the anatomy, reads noisier than the same photons over a thin
 * one. 0 without interior valid pixels; std::invalid_argument when the image (or a non-empty
 * mask) does not hold columns x rows pixels.
 */
VTKXPREGISTRATION_EXPORT double RankNoiseLevels(const std::vector<uint16_t>& image, int columns, int rows, const std::vector<uint8_t>& mask);

/**
 * The grey levels of a columns x rows image re-spaced so that its noise has the same size at
 * every level: the noise sd at each of 64 level bands is estimated from the valid pixels'
 * differences to their four neighbours (median absolute difference: edges do not count), and a
 * level's new value is the integral of 1 / sd up to it, times `levelsPerSigma` (a variance-
 * stabilising transform, found from the image itself). An sd below `minSigma` levels counts as
 * `minSigma` (ties of a noise-free image). Clamped to 0..65535.
 */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> NoiseScaledLevels(const std::vector<uint16_t>& image, int columns, int rows,
  const std::vector<uint8_t>& mask, double levelsPerSigma, double minSigma);

/**
 * `values` minus their Gaussian low-pass of sd `sigmaPixels`, over the valid pixels only
 * (normalised convolution: masked pixels neither count nor receive); computed on a grid coarser
 * by about sigma / 4 and interpolated back, so it costs little more than one pass over the image.
 */
VTKXPREGISTRATION_EXPORT void SubtractLowPass(
  float* values, const uint8_t* mask, int columns, int rows, double sigmaPixels);

/**
 * SubtractLowPass for one mask, applied many times: the mask's own low-pass (the normalised
 * convolution's weights) is computed once. A registration high-passes every DRR over the same
 * mask, and the weights were half of that work. Results equal SubtractLowPass's to the last bit.
 * The mask (null: all pixels) must outlive the object.
 */
class VTKXPREGISTRATION_EXPORT MaskedLowPass
{
public:
  MaskedLowPass(const uint8_t* mask, int columns, int rows, double sigmaPixels);
  void Subtract(float* values) const;

private:
  const uint8_t* Mask;
  int Columns, Rows, Factor = 1, GridWidth = 0, GridHeight = 0;
  double GridSigma = 0.0;
  std::vector<double> Weight; ///< the valid pixels per grid cell, blurred
  /// Per panel column: its grid cell, the two cells it is interpolated between and the weight of
  /// the second (the same for every row and every call of Subtract).
  std::vector<int> ColumnCell, ColumnLow, ColumnHigh;
  std::vector<double> ColumnWeight;
};

} // namespace xp

#endif
