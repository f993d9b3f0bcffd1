#include "xpViewMetrics.h"

#include "xpRayCaster.h"

namespace xp
{

MutualInformationMetric::MutualInformationMetric(const uint8_t* mask, int columns, int rows, std::vector<uint16_t> xrayLevels,
  int bins, bool equalize, double highPassPixels)
  : Mask(mask)
  , XRay(std::move(xrayLevels))
  , DRRRanks(XRay.size())
  , Histogram(bins)
  , Equalize(equalize)
  , HighPassPixels(equalize ? highPassPixels : 0.0)
  , DRRHighPass(mask, columns, rows, HighPassPixels)
{
  // Every measure reads only these pixels: a view's masks leave out half of its panel or more.
  for (size_t i = 0; i < this->XRay.size(); ++i)
    if (!mask || mask[i])
      this->Valid.push_back(static_cast<int>(i));
}

double MutualInformationMetric::Measure(const std::vector<float>& integrals)
{
  this->Rank(integrals);
  this->Histogram.Compute(this->XRay.data(), this->DRRRanks.data(), this->Valid);
  return this->Histogram.MutualInformation();
}

void MutualInformationMetric::SetDRRLevels(const std::vector<float>& integrals)
{
  for (size_t i = 0; i < integrals.size(); ++i)
    this->DRRRanks[i] = (this->Mask && !this->Mask[i]) ? 0 : this->Integral(integrals[i]);
}

void MutualInformationMetric::Rank(const std::vector<float>& integrals)
{
  const long long count = static_cast<long long>(integrals.size());
  const uint8_t* mask = this->Mask;
  uint16_t* out = this->DRRRanks.data();
  if (!this->Equalize)
  {
    LineIntegralsTo12Bit(integrals.data(), mask, count, out);
    return;
  }
  // The distributions at the first pose measured fix the levels for every later pose.
  if (this->Integral.Empty())
    this->Integral.Build(integrals.data(), mask, count);
  // The masked pixels' levels stay 0 (DRRRanks and Scratch start zeroed and are written only at
  // the valid pixels).
  if (this->HighPassPixels <= 0.0)
  {
    for (const int i : this->Valid)
      out[i] = this->Integral(integrals[i]);
    return;
  }
  std::vector<float>& structure = this->Scratch;
  structure.resize(integrals.size());
  for (const int i : this->Valid)
    structure[i] = this->Integral(integrals[i]);
  this->DRRHighPass.Subtract(structure.data());
  if (this->Structure.Empty())
    this->Structure.Build(structure.data(), mask, count);
  for (const int i : this->Valid)
    out[i] = this->Structure(structure[i]);
}

CorrelationMetric::CorrelationMetric(const uint8_t* mask, int columns, int rows, std::vector<float> xrayStructure, double lowPassPixels)
  : Mask(mask)
  , XRay(std::move(xrayStructure))
  , LowPass(mask, columns, rows, lowPassPixels)
{
}

double CorrelationMetric::Measure(const std::vector<float>& integrals)
{
  // Negated: more matter, less transmission, a lower rank in the X-ray.
  std::vector<float>& structure = this->Scratch;
  structure.resize(integrals.size());
  for (size_t i = 0; i < integrals.size(); ++i)
    structure[i] = -integrals[i];
  this->LowPass.Subtract(structure.data());
  return PearsonCorrelation(this->XRay.data(), structure.data(), structure.size(), this->Mask);
}

} // namespace xp
