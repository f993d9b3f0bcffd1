/**
 * @file xpMutualInformation.h
 * @brief Joint histogram of two 12-bit images over the pixels valid in both masks, and the
 *        similarity measures computed from it (paper eq. 1): MI, normalised MI; and NCC.
 *
 * Masked pixels are skipped, never counted as zeros. The histogram keeps its buffer between
 * calls, so a registration evaluates the metric without allocating.
 */
#ifndef xpMutualInformation_h
#define xpMutualInformation_h

#include "vtkXPMetricsModule.h"

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
  int NumberOfBins;
  int MaxValue;
  long long Total = 0;
  std::vector<long long> JointCounts;
  std::vector<long long> FixedCounts;
  std::vector<long long> MovingCounts;
  std::vector<uint16_t> BinOf;
};

/** Normalised cross-correlation over the pixels valid in both masks; 0 when undefined. */
VTKXPMETRICS_EXPORT double NormalizedCrossCorrelation(const uint16_t* fixed, const uint16_t* moving, long long count,
  const uint8_t* fixedMask = nullptr, const uint8_t* movingMask = nullptr);

} // namespace xp

#endif
