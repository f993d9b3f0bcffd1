/**
 * @file xpMutualInformation.h
 * @brief Joint histogram of two 12-bit images over the pixels valid in both masks, and the
 *        similarity measures computed from it (paper eq. 1): MI, normalised MI; and the
 *        correlation (NCC).
 *
 * Masked pixels are skipped, never counted as zeros. The histogram keeps its buffer between
 * calls, so a registration evaluates the metric without allocating.
 */
#ifndef xpMutualInformation_h
#define xpMutualInformation_h

#include "vtkXPMetricsModule.h"

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace xp
{

class VTKXPMETRICS_EXPORT JointHistogram
{
public:
  /** `bins` per axis (2..1024) over grey values 0..maxValue (4095 for 12-bit images). */
  explicit JointHistogram(int bins = 64, int maxValue = 4095);

  /**
   * Counts the pixel pairs (fixed[i], moving[i]) for which both masks are non-zero (a null mask
   * is all valid). Values above maxValue go to the last bin.
   */
  void Compute(const uint16_t* fixed, const uint16_t* moving, long long count, const uint8_t* fixedMask = nullptr,
    const uint8_t* movingMask = nullptr);
  /** Counts the pixel pairs at the indices `pixels` lists (a mask's pixels, listed once): the
   *  counts of Compute with that mask, without reading the pixels it leaves out. */
  void Compute(const uint16_t* fixed, const uint16_t* moving, const std::vector<int>& pixels);

  int Bins() const { return this->NumberOfBins; }
  long long Samples() const { return this->Total; }
  /** counts[fixedBin * bins + movingBin] */
  const std::vector<long long>& Counts() const { return this->JointCounts; }

  /** Shannon entropies in nats. */
  double FixedEntropy() const;
  double MovingEntropy() const;
  double JointEntropy() const;

  /** MI = H(F) + H(M) - H(F, M); 0 when no pixel is valid. */
  double MutualInformation() const;
  /** (H(F) + H(M)) / H(F, M), in [1, 2]; 1 when no pixel is valid. */
  double NormalizedMutualInformation() const;

private:
  /** A grey value's bin: values above MaxValue go to the last. */
  size_t Bin(uint16_t value) const
  {
    return value > this->MaxValue ? static_cast<size_t>(this->NumberOfBins - 1) : this->BinOf[value];
  }
  /** FixedCounts and MovingCounts from JointCounts. */
  void CountMarginals();

  int NumberOfBins;
  int MaxValue;
  long long Total = 0;
  std::vector<long long> JointCounts;
  std::vector<long long> FixedCounts;
  std::vector<long long> MovingCounts;
  std::vector<uint16_t> BinOf;
};

/**
 * The correlation (Pearson's; normalised cross-correlation) of two images over the `count`
 * pixels valid in both masks (null: every pixel); 0 where fewer than two pixels are valid or
 * either image is flat over them. The one correlation of xpose: the metric's NCC, the X-ray's
 * polarity and the gate's held-out structure.
 */
template <typename A, typename B>
double PearsonCorrelation(const A* a, const B* b, size_t count, const uint8_t* maskA = nullptr, const uint8_t* maskB = nullptr)
{
  double n = 0, sa = 0, sb = 0, sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < count; ++i)
  {
    if ((maskA && !maskA[i]) || (maskB && !maskB[i]))
      continue;
    const double x = a[i], y = b[i];
    n += 1, sa += x, sb += y, sab += x * y, saa += x * x, sbb += y * y;
  }
  if (n < 2)
    return 0.0;
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  return va > 0.0 && vb > 0.0 ? (sab - sa * sb / n) / std::sqrt(va * vb) : 0.0;
}

} // namespace xp

#endif
