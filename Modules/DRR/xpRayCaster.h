/**
 * @file xpRayCaster.h
 * @brief Line integrals of attenuation from an X-ray source to detector pixels (the DRR kernel).
 *
 * Works on raw buffers so that a registration can call it once per pose with reused memory.
 * Rays are clipped to the volume and to the source-detector segment, empty 32^3 blocks are skipped,
 * and only pixels that the mask marks valid are traced: the cost scales with the valid count.
 * Every loop is bounded by the number of cells a ray can cross, so grazing rays, rays parallel to
 * the slices and rays that miss the volume end in bounded time with a defined result (0).
 */
#ifndef xpRayCaster_h
#define xpRayCaster_h

#include "vtkXPDRRModule.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace xp
{
class AttenuationVolume;
struct XRayView;

/** How a buffer's pixels sit on the panel, in Room mm: pixel (c, r) = origin + c*columnStep + r*rowStep. */
struct VTKXPDRR_EXPORT DetectorGrid
{
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d columnStep = Eigen::Vector3d::UnitX();
  Eigen::Vector3d rowStep = Eigen::Vector3d::UnitY();
  int columns = 0;
  int rows = 0;

  /** Buffer row r = detector row r (top row first, as in PNG and DICOM). */
  static DetectorGrid TopRowFirst(const XRayView& view);
  /** Buffer row r = detector row rows-1-r (VTK image data, whose j runs up). */
  static DetectorGrid BottomRowFirst(const XRayView& view);
};

enum class RayCastMethod
{
  Trilinear, ///< trilinear interpolation at a fixed step along the ray (default)
  Siddon     ///< exact integral through piecewise-constant voxels (reference, slower)
};

struct VTKXPDRR_EXPORT RayCastSettings
{
  RayCastMethod method = RayCastMethod::Trilinear;
  /**
   * Sampling step along the ray in mm for Trilinear. 0 (default): one sample on every voxel plane
   * of the ray's dominant axis (Joseph's scheme; the step is that axis' spacing / |cos|, and
   * trilinear interpolation on a plane is bilinear), the fastest and the reference for accuracy.
   */
  double stepSize = 0.0;
  /**
   * Joseph's scheme on eight neighbouring rays at a time with AVX2, where the CPU has it (see
   * HasVectorRayCaster). false: one ray at a time in portable code, the reference that the vector
   * path is tested against. Both give the same samples; sums differ by float rounding only.
   */
  bool vectorized = true;
};

/** Whether this CPU runs the vectorised ray caster (AVX2 and FMA). */
VTKXPDRR_EXPORT bool HasVectorRayCaster();

/**
 * The pixels a DRR traces, in the order the ray caster visits them: tiles of 16 x 8, so that
 * neighbouring rays, which read the same voxels, run together (packets of eight take
 * consecutive entries); the list also spreads masked work evenly over threads. It depends only
 * on the panel size and the mask: a registration builds it once per mask and renders every pose
 * with it.
 */
class VTKXPDRR_EXPORT TracedPixels
{
public:
  static constexpr int TileColumns = 16, TileRows = 8;

  /** All pixels of a columns x rows panel, or those whose `mask` value is non-zero. */
  TracedPixels(int columns, int rows, const uint8_t* mask);

  int Columns() const { return this->PanelColumns; }
  int Rows() const { return this->PanelRows; }
  /** Pixel indices (row * Columns() + column), each below Columns() * Rows(). */
  const std::vector<int>& Order() const { return this->Pixels; }

private:
  int PanelColumns = 0;
  int PanelRows = 0;
  std::vector<int> Pixels;
};

/**
 * Line integral of mu (dimensionless) for every pixel of `grid` whose `mask` value is non-zero
 * (all pixels when mask is null); other pixels get 0. `ctToRoom` places the CT in the room
 * (planned set-up composed with the patient's misalignment). Uses all vtkSMPTools threads.
 * @return the number of rays traced.
 */
VTKXPDRR_EXPORT long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const uint8_t* mask, float* lineIntegrals,
  const RayCastSettings& settings = {});

/** The same for the pixels of `pixels` (built for this grid's size); other pixels are left as they are. */
VTKXPDRR_EXPORT long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const TracedPixels& pixels, float* lineIntegrals,
  const RayCastSettings& settings = {});

/** 12-bit transmission round(4095 * exp(-integral)); 0 where the mask is zero. */
VTKXPDRR_EXPORT void LineIntegralsTo12Bit(
  const float* lineIntegrals, const uint8_t* mask, long long count, uint16_t* transmission);

} // namespace xp

#endif
