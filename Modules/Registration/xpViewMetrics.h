/**
 * @file xpViewMetrics.h
 * @brief The image metrics of one view, as ITK's registration framework separates them from the
 *        projector and the optimiser: each holds its view's X-ray as prepared once
 *        (PrepareXRay) and measures the DRR's line integrals at a pose against it.
 *
 * StereoSimilarity renders the views' DRRs (DRRProjector) and sums one term per view: MI^2 from
 * MutualInformationMetric, or with a correlation objective the CorrelationMetric's value (MI is
 * measured then too: the gate and the record read it).
 */
#ifndef xpViewMetrics_h
#define xpViewMetrics_h

#include "vtkXPRegistrationModule.h"

#include "xpImageLevels.h"
#include "xpMutualInformation.h"

#include <cstdint>
#include <vector>

namespace xp
{

/** One view's metric: its value for the DRR's line integrals (0 where the mask is 0). */
class VTKXPREGISTRATION_EXPORT ViewMetric
{
public:
  virtual ~ViewMetric() = default;
  /** Measures the DRR whose line integrals are `integrals` (the view's panel, rows top first)
   *  and returns the metric's value; several calls may run side by side on different views. */
  virtual double Measure(const std::vector<float>& integrals) = 0;
};

/**
 * Mutual information of the X-ray's levels and the DRR's (xpImageLevels.h): with equalisation,
 * the DRR's line integrals as levels of their distribution at the first pose measured, less
 * their shading wider than the high-pass and ranked again; without, the DRR's 12-bit
 * transmission against the X-ray's own values.
 */
class VTKXPREGISTRATION_EXPORT MutualInformationMetric : public ViewMetric
{
public:
  /**
   * @param mask        the view's mask (null: every pixel); kept by pointer: it must outlive this
   * @param xrayLevels  the X-ray as MI reads it: PrepareXRay's levels, or its own values
   * @param highPassPixels the DRR's levels less their low-pass of this sd (pixels; 0: none)
   */
  MutualInformationMetric(const uint8_t* mask, int columns, int rows, std::vector<uint16_t> xrayLevels, int bins, bool equalize,
    double highPassPixels);

  /** The mutual information (nats). */
  double Measure(const std::vector<float>& integrals) override;
  /** The DRR's levels of the last measure (0 where masked). */
  const std::vector<uint16_t>& DRRLevels() const { return this->DRRRanks; }
  const std::vector<uint16_t>& XRayLevels() const { return this->XRay; }
  /** The DRR's levels for `integrals` without measuring (after a GPU measured them: no high-pass). */
  void SetDRRLevels(const std::vector<float>& integrals);
  /** Line integral -> level, fixed at the first measure (empty before it). */
  const LevelTable& IntegralLevels() const { return this->Integral; }
  int Bins() const { return this->Histogram.Bins(); }
  bool Equalizes() const { return this->Equalize; }

private:
  void Rank(const std::vector<float>& integrals);

  const uint8_t* Mask;
  std::vector<int> Valid; ///< the pixels the mask keeps (every pixel without one), in order
  std::vector<uint16_t> XRay;
  std::vector<uint16_t> DRRRanks; ///< with equalisation: the levels; without: the 12-bit DRR (0 where masked)
  JointHistogram Histogram;
  bool Equalize = true;
  double HighPassPixels = 0.0;
  MaskedLowPass DRRHighPass;
  LevelTable Integral, Structure;
  std::vector<float> Scratch; ///< the high-pass's levels (0 where masked: never written there)
};

/**
 * Pearson correlation of the X-ray's structure (its ranks less their low-pass: PrepareXRay) with
 * the DRR's (its line integrals, negated so that more matter is darker as in the ranks, less
 * their low-pass of the same sd) over the mask. A small bone among others: MI over its shadow
 * follows whichever neighbour fills the most bins, a correlation its own outline and inside.
 */
class VTKXPREGISTRATION_EXPORT CorrelationMetric : public ViewMetric
{
public:
  /** `mask` is kept by pointer; `xrayStructure` is PrepareXRay's structure. */
  CorrelationMetric(const uint8_t* mask, int columns, int rows, std::vector<float> xrayStructure, double lowPassPixels);

  /** The correlation, -1 to 1. */
  double Measure(const std::vector<float>& integrals) override;

private:
  const uint8_t* Mask;
  std::vector<float> XRay;
  MaskedLowPass LowPass;
  std::vector<float> Scratch;
};

} // namespace xp

#endif
