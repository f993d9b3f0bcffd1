#include "xpAttenuationVolume.h"

#include "xpError.h"
#include "xpHugePages.h"

#include <vtkSMPThreadLocal.h>
#include <vtkSMPTools.h>

#include <algorithm>
#include <cstdlib>
#include <cstdint>

namespace xp
{

namespace
{

/** Zeroed voxels on huge pages: a ray touches voxels far apart in memory, and 4 KiB pages would
 *  cost a TLB miss on most samples. Pages are first touched by the threads that fill them. */
std::shared_ptr<uint16_t> AllocateVoxels(size_t count)
{
  return std::shared_ptr<uint16_t>(static_cast<uint16_t*>(AllocateHugePages(count * sizeof(uint16_t))), &FreeHugePages);
}

} // namespace

template <typename HU>
AttenuationVolume::AttenuationVolume(
  const HU* hounsfield, const Eigen::Vector3i& dims, const Eigen::Affine3d& indexToCT, double muWater, double airThreshold)
  : Dims(dims)
  , Padded(dims + Eigen::Vector3i::Constant(2))
  , Water(muWater)
{
  if (dims.minCoeff() < 1)
  {
    throw Error("attenuation volume: empty CT");
  }
  if (this->Padded.cast<double>().prod() >= 2147483647.0)
  {
    throw Error("attenuation volume: more than 2^31 voxels are not supported");
  }
  if (!(muWater > 0.0))
  {
    throw InputError("mu_water", "must be positive");
  }
  this->PaddedToCT = indexToCT * Eigen::Translation3d(-1.0, -1.0, -1.0);
  this->MinSpacing = indexToCT.linear().colwise().norm().minCoeff();
  this->MaxSpacing = indexToCT.linear().colwise().norm().maxCoeff();
  const size_t nx = this->Padded[0], nxy = nx * this->Padded[1];
  this->Mu = AllocateVoxels(nxy * this->Padded[2] + 2);
  // mu = muWater (1 + HU/1000) = scale (HU + 1000): exactly 0 for air, so empty blocks are
  // found; voxels below airThreshold (noise in the air around the patient) count as air.
  const float air = static_cast<float>(airThreshold);
  const size_t voxelCount = static_cast<size_t>(dims[0]) * dims[1] * dims[2];
  vtkSMPThreadLocal<float> highestOfThread(air);
  vtkSMPTools::For(0, static_cast<vtkIdType>(voxelCount), vtkIdType(1) << 20,
    [&](vtkIdType begin, vtkIdType end)
    {
      float& highest = highestOfThread.Local();
      for (vtkIdType i = begin; i < end; ++i)
        highest = std::max(highest, static_cast<float>(hounsfield[i]));
    });
  float highest = air;
  for (const float h : highestOfThread)
    highest = std::max(highest, h);
  const double highestMu = muWater / 1000.0 * std::max(0.0, highest + 1000.0);
  this->Step = highestMu > 0.0 ? highestMu / 65535.0 : 1.0;
  const float scale = static_cast<float>(muWater / 1000.0 / this->Step);
  vtkSMPTools::For(0, dims[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
      {
        for (int j = 0; j < dims[1]; ++j)
        {
          const HU* in = hounsfield + (static_cast<size_t>(k) * dims[1] + j) * dims[0];
          uint16_t* out = this->Mu.get() + (k + 1) * nxy + (j + 1) * nx + 1;
          for (int i = 0; i < dims[0]; ++i)
          {
            const float hu = static_cast<float>(in[i]);
            const float steps = hu < air ? 0.0f : std::min(65535.0f, scale * std::max(0.0f, hu + 1000.0f));
            out[i] = static_cast<uint16_t>(steps + 0.5f);
          }
        }
      }
    });

  // The y-fastest copy, slice by slice.
  const size_t ny = this->Padded[1];
  this->MuYFastest = AllocateVoxels(nxy * this->Padded[2] + 2);
  vtkSMPTools::For(0, this->Padded[2],
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
  vtkSMPTools::For(0, this->Blocks[2],
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

template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const float*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);
template VTKXPDRR_EXPORT AttenuationVolume::AttenuationVolume(
  const int16_t*, const Eigen::Vector3i&, const Eigen::Affine3d&, double, double);

AttenuationVolume AttenuationVolume::Halved() const
{
  const Eigen::Vector3i half = (this->Dims + Eigen::Vector3i::Ones()) / 2;
  // Back to HU, which the constructor takes: mean mu = muWater (1 + HU / 1000).
  std::vector<float> hounsfield(static_cast<size_t>(half.prod()));
  vtkSMPTools::For(0, half[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < half[1]; ++j)
          for (int i = 0; i < half[0]; ++i)
          {
            long sum = 0; // in steps of Quantum()
            int count = 0;
            for (int z = 2 * k; z < std::min(2 * k + 2, this->Dims[2]); ++z)
              for (int y = 2 * j; y < std::min(2 * j + 2, this->Dims[1]); ++y)
                for (int x = 2 * i; x < std::min(2 * i + 2, this->Dims[0]); ++x, ++count)
                  sum += this->Mu.get()[this->Offset(x, y, z)];
            hounsfield[(static_cast<size_t>(k) * half[1] + j) * half[0] + i] =
              static_cast<float>(1000.0 * (this->Step * sum / count / this->Water - 1.0));
          }
    });
  // Half voxel i is centred where original voxels 2i and 2i + 1 meet.
  const Eigen::Affine3d indexToCT = this->PaddedToCT * Eigen::Translation3d(1.5, 1.5, 1.5) * Eigen::Scaling(2.0);
  // Air stays air: a mean of 0 maps to -1000 HU, below every threshold; partial air is kept.
  return AttenuationVolume(hounsfield.data(), half, indexToCT, this->Water, -1000.0 + 1e-3);
}

float AttenuationVolume::At(int i, int j, int k) const
{
  return static_cast<float>(this->Step * this->Mu.get()[this->Offset(i, j, k)]);
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
