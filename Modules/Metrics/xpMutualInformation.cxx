#include "xpMutualInformation.h"

#include "xpError.h"

#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/** Counts below this have their c ln c looked up (32 KiB): a registration's joint histograms hold
 *  mostly such counts, and an entry is the very value the product gives (the same operations). */
constexpr long long TabulatedCounts = 4096;

const std::vector<double>& CLogCTable()
{
  static const std::vector<double> table = []
  {
    std::vector<double> values(TabulatedCounts, 0.0);
    for (long long c = 1; c < TabulatedCounts; ++c)
      values[static_cast<size_t>(c)] = static_cast<double>(c) * std::log(static_cast<double>(c));
    return values;
  }();
  return table;
}

/** -sum p ln p over counts that sum to `total`. */
double Entropy(const std::vector<long long>& counts, long long total)
{
  if (total <= 0)
  {
    return 0.0;
  }
  // H = ln N - (1/N) sum c ln c: no division per bin, and a log only for counts beyond the table.
  const double* cLogC = CLogCTable().data();
  double sum = 0.0;
  for (long long c : counts)
  {
    if (c > 0)
    {
      sum += c < TabulatedCounts ? cLogC[c] : static_cast<double>(c) * std::log(static_cast<double>(c));
    }
  }
  return std::log(static_cast<double>(total)) - sum / static_cast<double>(total);
}

} // namespace

JointHistogram::JointHistogram(int bins, int maxValue)
  : NumberOfBins(bins)
  , MaxValue(maxValue)
{
  if (bins < 2 || bins > 1024)
  {
    throw InputError("--bins", "must be between 2 and 1024");
  }
  if (maxValue < 1)
  {
    throw Error("joint histogram: maximum grey value must be positive");
  }
  this->JointCounts.assign(static_cast<size_t>(bins) * bins, 0);
  this->FixedCounts.assign(bins, 0);
  this->MovingCounts.assign(bins, 0);
  // bin = value * bins / (maxValue + 1), through a lookup table (12-bit: 4096 entries).
  this->BinOf.resize(static_cast<size_t>(maxValue) + 1);
  for (int v = 0; v <= maxValue; ++v)
  {
    this->BinOf[v] = static_cast<uint16_t>(static_cast<long long>(v) * bins / (maxValue + 1));
  }
}

void JointHistogram::Compute(const uint16_t* fixed, const uint16_t* moving, long long count, const uint8_t* fixedMask,
  const uint8_t* movingMask)
{
  std::fill(this->JointCounts.begin(), this->JointCounts.end(), 0);
  const size_t bins = static_cast<size_t>(this->NumberOfBins);
  long long total = 0;
  for (long long i = 0; i < count; ++i)
  {
    if ((fixedMask && !fixedMask[i]) || (movingMask && !movingMask[i]))
    {
      continue;
    }
    ++this->JointCounts[this->Bin(fixed[i]) * bins + this->Bin(moving[i])];
    ++total;
  }
  this->Total = total;
  this->CountMarginals();
}

void JointHistogram::Compute(const uint16_t* fixed, const uint16_t* moving, const std::vector<int>& pixels)
{
  std::fill(this->JointCounts.begin(), this->JointCounts.end(), 0);
  const size_t bins = static_cast<size_t>(this->NumberOfBins);
  for (const int i : pixels)
    ++this->JointCounts[this->Bin(fixed[i]) * bins + this->Bin(moving[i])];
  this->Total = static_cast<long long>(pixels.size());
  this->CountMarginals();
}

void JointHistogram::CountMarginals()
{
  const int bins = this->NumberOfBins;
  std::fill(this->FixedCounts.begin(), this->FixedCounts.end(), 0);
  std::fill(this->MovingCounts.begin(), this->MovingCounts.end(), 0);
  for (int f = 0; f < bins; ++f)
  {
    for (int m = 0; m < bins; ++m)
    {
      const long long c = this->JointCounts[static_cast<size_t>(f) * bins + m];
      this->FixedCounts[f] += c;
      this->MovingCounts[m] += c;
    }
  }
}

double JointHistogram::FixedEntropy() const
{
  return Entropy(this->FixedCounts, this->Total);
}

double JointHistogram::MovingEntropy() const
{
  return Entropy(this->MovingCounts, this->Total);
}

double JointHistogram::JointEntropy() const
{
  return Entropy(this->JointCounts, this->Total);
}

double JointHistogram::MutualInformation() const
{
  if (this->Total == 0)
  {
    return 0.0;
  }
  return std::max(0.0, this->FixedEntropy() + this->MovingEntropy() - this->JointEntropy());
}

double JointHistogram::NormalizedMutualInformation() const
{
  const double joint = this->JointEntropy();
  return joint > 0.0 ? (this->FixedEntropy() + this->MovingEntropy()) / joint : 1.0;
}

} // namespace xp
