/**
 * @file xpAttenuationVolume.h
 * @brief A CT converted once to linear attenuation, laid out for fast ray casting.
 *
 * mu = muWater * (1 + HU/1000), clamped at 0; voxels below an air threshold (default -950 HU,
 * well below lung and fat but above the noise of air in real scans) are air, mu = 0. The voxels are
 * stored with one voxel of zeros around the volume, so trilinear sampling needs no bounds
 * checks, and an occupancy grid of 32^3-voxel blocks marks where any attenuation is, so rays skip
 * empty space. Only the box that holds the CT's non-air voxels is stored (a pelvis CT's 512 x 512
 * slices hold the body in about 460 x 400): less memory to fill, which on a fresh process costs as
 * much as the filling. Build it once per CT and reuse it for every pose.
 *
 * mu is stored as 16-bit steps of Quantum() (the volume's largest mu / 65535): half the memory
 * of floats, so more of the CT stays in cache, and the two x-neighbours of a sample fit in one
 * 32-bit load, which halves the gathers of the ray caster. A second copy with y fastest does the
 * same for rays that step along x. Air stays exactly 0; the rounding is at most half a step,
 * 1e-5 of bone's mu in a CT whose densest voxel is 3000 HU, and averages out along a ray.
 */
#ifndef xpAttenuationVolume_h
#define xpAttenuationVolume_h

#include "vtkXPDRRModule.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <vector>

namespace xp
{

/** Linear attenuation of water (1/mm) at the DRR's effective energy, about 70 keV: the DRR
 *  model's default, mu = WaterAttenuationPerMM (1 + HU/1000). */
constexpr double WaterAttenuationPerMM = 0.0193;

class VTKXPDRR_EXPORT AttenuationVolume
{
public:
  static constexpr int BlockShift = 5; ///< occupancy blocks are 2^5 = 32 voxels wide

  AttenuationVolume() = default;

  /**
   * @param hounsfield voxels, x fastest, dims[0] * dims[1] * dims[2] values
   * @param indexToCT  voxel index -> CT (LPS) mm; may include rotation (DirectionMatrix)
   * @param muWater    attenuation of water (1/mm)
   * @param airThreshold HU below which a voxel is air (mu = 0)
   */
  template <typename HU> // float, or int16_t as the CT readers keep whole-number HU
  AttenuationVolume(const HU* hounsfield, const Eigen::Vector3i& dims, const Eigen::Affine3d& indexToCT,
    double muWater, double airThreshold = DefaultAirThreshold);

  /** The same, with the voxels where `keep` is 0 taken as air (-1000 HU): a CT's body alone
   *  (xp::BodyOf) without a copy of the CT. `keep` holds one flag per voxel, x fastest. */
  template <typename HU>
  AttenuationVolume(const HU* hounsfield, const uint8_t* keep, const Eigen::Vector3i& dims, const Eigen::Affine3d& indexToCT,
    double muWater, double airThreshold = DefaultAirThreshold);

  static constexpr double DefaultAirThreshold = -950.0;

  /**
   * The same CT at half resolution along the index axes whose `factors` are 2 (the others 1):
   * each voxel the mean mu of the voxels it covers (an odd last layer averages what it has). For
   * coarse stages that render half-size images: a ray takes half the samples, and an eighth of
   * the voxels stays in cache (2 x 2 x 2). A CT of thick slices may halve its pixels only.
   */
  AttenuationVolume Halved(const Eigen::Vector3i& factors = Eigen::Vector3i::Constant(2)) const;

  /** The CT's grid: its voxel counts, and voxel index -> CT mm. */
  const Eigen::Vector3i& Dimensions() const { return this->Dims; }
  const Eigen::Affine3d& IndexToCT() const { return this->CTIndexToCT; }
  /** mu of CT voxel (i, j, k); 0 outside the CT and outside the stored box. */
  float At(int i, int j, int k) const;

  /** The stored box: CT voxels StoredOrigin() + [0, StoredDimensions()), every non-air voxel. */
  const Eigen::Vector3i& StoredOrigin() const { return this->Origin; }
  Eigen::Vector3i StoredDimensions() const { return this->Padded - Eigen::Vector3i::Constant(2); }
  /** mu of stored voxel (i, j, k), each in [0, StoredDimensions()). */
  float StoredAt(int i, int j, int k) const
  {
    return static_cast<float>(this->Step * this->Mu.get()[this->Offset(i, j, k)]);
  }
  const Eigen::Vector3i& PaddedDimensions() const { return this->Padded; }
  /** Padded voxel index (stored index + 1) -> CT mm. */
  const Eigen::Affine3d& PaddedIndexToCT() const { return this->PaddedToCT; }
  /** Padded voxels, x fastest, in steps of Quantum(); two extra zeros after the last voxel let
   *  a 32-bit load start at any voxel. */
  const uint16_t* Voxels() const { return this->Mu.get(); }
  /** The same voxels with y fastest, then x, then z: padded (x, y, z) at y + x * ny + z * nx * ny. */
  const uint16_t* VoxelsYFastest() const { return this->MuYFastest.get(); }
  /** The length of Voxels() and of VoxelsYFastest(): the padded voxels and the two zeros after them. */
  size_t VoxelCount() const
  {
    return static_cast<size_t>(this->Padded[0]) * this->Padded[1] * this->Padded[2] + 2;
  }
  /** The voxels' owner, shared by copies: a GPU keeps its copy of the volume while this lives. */
  std::shared_ptr<const void> Storage() const { return this->Mu; }
  /** mu (1/mm) of one step of Voxels(). */
  double Quantum() const { return this->Step; }

  const Eigen::Vector3i& BlockDimensions() const { return this->Blocks; }
  /** One flag per block, non-zero where it holds attenuation: block (bx, by, bz) at
   *  bx + by * BlockDimensions()[0] + bz * BlockDimensions()[0] * BlockDimensions()[1]. */
  const uint8_t* OccupancyGrid() const { return this->Occupied.data(); }
  /** Smallest voxel spacing (mm), the default sampling step. */
  double MinimumSpacing() const { return this->MinSpacing; }
  /** Largest voxel spacing (mm): how coarse the CT is along its worst axis. */
  double MaximumSpacing() const { return this->MaxSpacing; }
  double MuWater() const { return this->Water; }
  /** Fraction of occupancy blocks that hold attenuation (for reports and benchmarks). */
  double OccupiedFraction() const;

private:
  /** Stores mu of the voxels low + [0, size) of `hounsfield`, an arrayDims array of HU whose
   *  largest non-air value is `highest`, as the voxels of StoredOrigin() + [0, size); where `keep`
   *  is given, its 0 voxels as air. */
  template <typename HU>
  void Store(const HU* hounsfield, const uint8_t* keep, const Eigen::Vector3i& arrayDims, const Eigen::Vector3i& low,
    const Eigen::Vector3i& size, float highest, float airThreshold);

  /** Voxels() value of CT voxel (i, j, k), 0 outside the stored box. */
  uint16_t StepsAt(int i, int j, int k) const;
  /** Offset in Voxels() of stored voxel (i, j, k). */
  size_t Offset(int i, int j, int k) const
  {
    return (static_cast<size_t>(k + 1) * this->Padded[1] + (j + 1)) * this->Padded[0] + (i + 1);
  }

  Eigen::Vector3i Dims = Eigen::Vector3i::Zero();
  Eigen::Affine3d CTIndexToCT = Eigen::Affine3d::Identity();
  Eigen::Vector3i Origin = Eigen::Vector3i::Zero();
  Eigen::Vector3i Padded = Eigen::Vector3i::Zero();
  Eigen::Vector3i Blocks = Eigen::Vector3i::Zero();
  Eigen::Affine3d PaddedToCT = Eigen::Affine3d::Identity();
  /** Padded voxels, on 2 MiB huge pages where the kernel allows (rays jump between slices). */
  std::shared_ptr<uint16_t> Mu;
  std::shared_ptr<uint16_t> MuYFastest;
  std::vector<uint8_t> Occupied;
  double MinSpacing = 1.0;
  double MaxSpacing = 1.0;
  double Water = 0.0;
  double Step = 1.0;
};

} // namespace xp

#endif
