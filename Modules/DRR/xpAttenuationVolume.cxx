#include "xpAttenuationVolume.h"

#include "xpError.h"
#include "xpParallel.h"
#include "xpPageMemory.h"

#include <algorithm>
#include <cstdlib>
#include <cstdint>
#include <limits>
#include <cmath>

namespace xp
{

namespace
{

/** Zeroed voxels mapped from the kernel (xpPageMemory.h): pages are first touched by the threads
 *  that fill them, and a freed volume goes back at once. */
std::shared_ptr<uint16_t> AllocateVoxels(size_t count)
{
  return std::shared_ptr<uint16_t>(static_cast<uint16_t*>(AllocatePages(count * sizeof(uint16_t))), &FreePages);
}

/** Where a CT's non-air voxels are, and the largest HU among them. */
struct NonAirBox
{
  Eigen::Vector3i low = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
  Eigen::Vector3i high = Eigen::Vector3i::Constant(-1); // inclusive
  float highest = -1000.0f;

  explicit NonAirBox(float lowestHighest)
    : highest(lowestHighest)
  {
  }
  bool Empty() const { return (this->high.array() < this->low.array()).any(); }
  void Add(const NonAirBox& other)
  {
    this->low = this->low.cwiseMin(other.low);
    this->high = this->high.cwiseMax(other.high);
    this->highest = std::max(this->highest, other.highest);
  }
};

/** HU of voxel `i` as a float; -1000 (air) where `keep` is given and 0. */
template <typename HU>
float KeptHU(const HU* hounsfield, const uint8_t* keep, size_t i)
{
  return keep && !keep[i] ? -1000.0f : static_cast<float>(hounsfield[i]);
}

/** One pass over the CT, slices in parallel; within a row only the stretch between its first and
 *  last non-air voxel is searched for the highest value. */
template <typename HU>
NonAirBox FindNonAirBox(const HU* hounsfield, const uint8_t* keep, const Eigen::Vector3i& dims, float air)
{
  // Non-air: at or above the threshold and of positive mu (above -1000 HU).
  const float lowest = std::max(air, std::nextafter(-1000.0f, 0.0f));
  std::vector<NonAirBox> slices(dims[2], NonAirBox(air));
  ParallelFor(0, dims[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
      {
        NonAirBox& box = slices[k];
        for (int j = 0; j < dims[1]; ++j)
        {
          const size_t row = (static_cast<size_t>(k) * dims[1] + j) * dims[0];
          int first = 0, last = dims[0] - 1;
          while (first <= last && KeptHU(hounsfield, keep, row + first) < lowest)
            ++first;
          if (first > last)
            continue;
          while (KeptHU(hounsfield, keep, row + last) < lowest)
            --last;
          float highest = box.highest;
          for (int i = first; i <= last; ++i)
            highest = std::max(highest, KeptHU(hounsfield, keep, row + i));
          box.highest = highest;
          box.low = box.low.cwiseMin(Eigen::Vector3i(first, j, k));
          box.high = box.high.cwiseMax(Eigen::Vector3i(last, j, k));
        }
      }
    });
  NonAirBox all(air);
  for (const NonAirBox& slice : slices)
    all.Add(slice);
  return all;
}

} // namespace

template <typename HU>
AttenuationVolume::AttenuationVolume(
  const HU* hounsfield, const Eigen::Vector3i& dims, const Eigen::Affine3d& indexToCT, double muWater, double airThreshold)
  : AttenuationVolume(hounsfield, nullptr, dims, indexToCT, muWater, airThreshold)
{
}

template <typename HU>
AttenuationVolume::AttenuationVolume(const HU* hounsfield, const uint8_t* keep, const Eigen::Vector3i& dims,
  const Eigen::Affine3d& indexToCT, double muWater, double airThreshold)
  : Dims(dims)
  , CTIndexToCT(indexToCT)
  , Water(muWater)
{
  if (dims.minCoeff() < 1)
  {
    throw Error("attenuation volume: empty CT");
  }
  if ((dims + Eigen::Vector3i::Constant(2)).cast<double>().prod() >= 2147483647.0)
  {
    throw Error("attenuation volume: more than 2^31 voxels are not supported");
  }
  if (!(muWater > 0.0))
  {
    throw InputError("mu_water", "must be positive");
  }
  const float air = static_cast<float>(airThreshold);
  NonAirBox box = FindNonAirBox(hounsfield, keep, dims, air);
  if (box.Empty())
  {
    box.low = box.high = Eigen::Vector3i::Zero(); // one voxel of air keeps the layout valid
  }
  this->Origin = box.low;
  this->Store(hounsfield, keep, dims, box.low, box.high - box.low + Eigen::Vector3i::Ones(), box.highest, air);
}

template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const float*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);
template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const int16_t*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);
template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const float*, const uint8_t*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);
template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const int16_t*, const uint8_t*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);

template <typename HU>
void AttenuationVolume::Store(const HU* hounsfield, const uint8_t* keep, const Eigen::Vector3i& arrayDims,
  const Eigen::Vector3i& low, const Eigen::Vector3i& size, float highest, float air)
{
  this->Padded = size + Eigen::Vector3i::Constant(2);
  this->PaddedToCT = this->CTIndexToCT * Eigen::Translation3d((this->Origin - Eigen::Vector3i::Ones()).cast<double>());
  this->MinSpacing = this->CTIndexToCT.linear().colwise().norm().minCoeff();
  this->MaxSpacing = this->CTIndexToCT.linear().colwise().norm().maxCoeff();
  const size_t nx = this->Padded[0], nxy = nx * this->Padded[1];
  this->Mu = AllocateVoxels(this->VoxelCount());
  // mu = muWater (1 + HU/1000) = scale (HU + 1000): exactly 0 for air, so empty blocks are
  // found; voxels below airThreshold (noise in the air around the patient) count as air.
  const double highestMu = this->Water / 1000.0 * std::max(0.0, highest + 1000.0);
  this->Step = highestMu > 0.0 ? highestMu / 65535.0 : 1.0;
  const float scale = static_cast<float>(this->Water / 1000.0 / this->Step);
  ParallelFor(0, size[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
      {
        for (int j = 0; j < size[1]; ++j)
        {
          const size_t in = (static_cast<size_t>(low[2] + k) * arrayDims[1] + low[1] + j) * arrayDims[0] + low[0];
          uint16_t* out = this->Mu.get() + (k + 1) * nxy + (j + 1) * nx + 1;
          for (int i = 0; i < size[0]; ++i)
          {
            const float hu = KeptHU(hounsfield, keep, in + i);
            const float steps = hu < air ? 0.0f : std::min(65535.0f, scale * std::max(0.0f, hu + 1000.0f));
            out[i] = static_cast<uint16_t>(steps + 0.5f);
          }
        }
      }
    });

  // The y-fastest copy, slice by slice.
  const size_t ny = this->Padded[1];
  this->MuYFastest = AllocateVoxels(this->VoxelCount());
  ParallelFor(0, this->Padded[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
      {
        const uint16_t* in = this->Mu.get() + k * nxy;
        uint16_t* out = this->MuYFastest.get() + k * nxy;
        for (size_t j = 0; j < ny; ++j)
          for (size_t i = 0; i < nx; ++i)
            out[i * ny + j] = in[j * nx + i];
      }
    });

  // A block is occupied when any voxel that trilinear samples inside it may touch is non-zero:
  // voxels of the block and one beyond on the high side.
  const int b = 1 << BlockShift;
  this->Blocks = (this->Padded + Eigen::Vector3i::Constant(b - 1)) / b;
  this->Occupied.assign(static_cast<size_t>(this->Blocks.prod()), 0);
  ParallelFor(0, this->Blocks[2],
    [&](int bz0, int bz1)
    {
      for (int bz = bz0; bz < bz1; ++bz)
      {
        for (int by = 0; by < this->Blocks[1]; ++by)
        {
          for (int bx = 0; bx < this->Blocks[0]; ++bx)
          {
            bool any = false;
            const int z1 = std::min(this->Padded[2], (bz + 1) * b + 1), y1 = std::min(this->Padded[1], (by + 1) * b + 1),
                      x1 = std::min(this->Padded[0], (bx + 1) * b + 1);
            for (int z = bz * b; z < z1 && !any; ++z)
              for (int y = by * b; y < y1 && !any; ++y)
                for (int x = bx * b; x < x1 && !any; ++x)
                  any = this->Mu.get()[z * nxy + y * nx + x] != 0;
            this->Occupied[(static_cast<size_t>(bz) * this->Blocks[1] + by) * this->Blocks[0] + bx] = any;
          }
        }
      }
    });
}

AttenuationVolume AttenuationVolume::Halved(const Eigen::Vector3i& factors) const
{
  if (((factors.array() != 1) && (factors.array() != 2)).any())
    throw Error("halved volume: each axis's factor must be 1 or 2");
  // Along a halved axis, half voxel i is centred where original voxels 2i and 2i + 1 meet; only
  // the half voxels that overlap the stored box can hold attenuation.
  const Eigen::Vector3i less = factors - Eigen::Vector3i::Ones();
  AttenuationVolume half;
  half.Dims = (this->Dims + less).cwiseQuotient(factors);
  half.CTIndexToCT =
    this->CTIndexToCT * Eigen::Translation3d(0.5 * less.cast<double>()) * Eigen::Scaling(factors.cast<double>());
  half.Water = this->Water;
  half.Origin = this->Origin.cwiseQuotient(factors);
  const Eigen::Vector3i size =
    (this->Origin + this->StoredDimensions() - Eigen::Vector3i::Ones()).cwiseQuotient(factors) - half.Origin +
    Eigen::Vector3i::Ones();
  // Back to HU, which Store takes: mean mu = muWater (1 + HU / 1000). A half voxel covers CT
  // voxels from one before the stored box to one beyond it at most: the padding's zeros, so the
  // padded voxels are read without bounds checks.
  std::vector<float> hounsfield(static_cast<size_t>(size.prod()));
  const uint16_t* mu = this->Mu.get();
  const size_t nx = this->Padded[0], nxy = nx * this->Padded[1];
  const Eigen::Vector3i toPadded = Eigen::Vector3i::Ones() - this->Origin;
  ParallelFor(0, size[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < size[1]; ++j)
          for (int i = 0; i < size[0]; ++i)
          {
            const Eigen::Vector3i first = factors.cwiseProduct(half.Origin + Eigen::Vector3i(i, j, k));
            const Eigen::Vector3i last = (first + less).cwiseMin(this->Dims - Eigen::Vector3i::Ones());
            long sum = 0; // in steps of Quantum()
            int count = 0;
            for (int z = first[2]; z <= last[2]; ++z)
              for (int y = first[1]; y <= last[1]; ++y)
              {
                const uint16_t* row = mu + static_cast<size_t>(z + toPadded[2]) * nxy + static_cast<size_t>(y + toPadded[1]) * nx;
                for (int x = first[0]; x <= last[0]; ++x, ++count)
                  sum += row[x + toPadded[0]];
              }
            hounsfield[(static_cast<size_t>(k) * size[1] + j) * size[0] + i] =
              static_cast<float>(1000.0 * (this->Step * sum / count / this->Water - 1.0));
          }
    });
  float highest = -1000.0f;
  for (const float h : hounsfield)
    highest = std::max(highest, h);
  // Air stays air: a mean of 0 maps to -1000 HU, below every threshold; partial air is kept.
  half.Store(hounsfield.data(), nullptr, size, Eigen::Vector3i::Zero(), size, highest, -1000.0f + 1e-3f);
  return half;
}

uint16_t AttenuationVolume::StepsAt(int i, int j, int k) const
{
  const Eigen::Vector3i stored = Eigen::Vector3i(i, j, k) - this->Origin;
  if ((stored.array() < 0).any() || (stored.array() >= this->StoredDimensions().array()).any())
  {
    return 0;
  }
  return this->Mu.get()[this->Offset(stored[0], stored[1], stored[2])];
}

float AttenuationVolume::At(int i, int j, int k) const
{
  return static_cast<float>(this->Step * this->StepsAt(i, j, k));
}

double AttenuationVolume::OccupiedFraction() const
{
  if (this->Occupied.empty())
  {
    return 0.0;
  }
  return static_cast<double>(std::count(this->Occupied.begin(), this->Occupied.end(), 1)) / this->Occupied.size();
}

} // namespace xp
