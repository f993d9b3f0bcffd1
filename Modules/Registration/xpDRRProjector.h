/**
 * @file xpDRRProjector.h
 * @brief The projector of a registration: the DRRs' line integrals over each view's valid pixels
 *        at a pose, every pixel's ray cast or a stride's nodes cast and the pixels between
 *        interpolated, on the CPU or the GPU (xpRayCaster.h), into buffers kept between poses.
 *
 * The metric (StereoSimilarity) turns them into levels and similarities; the projector knows
 * nothing of the X-rays' grey values.
 */
#ifndef xpDRRProjector_h
#define xpDRRProjector_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpRayCaster.h"
#include "xpXRayView.h"

#include <cstdint>
#include <vector>

namespace xp
{

/** One view of a registration: its geometry, its X-ray and the pixels that count. */
struct RegistrationView
{
  XRayView view;                 ///< the panel as rendered (size = the images' size)
  std::vector<uint16_t> xray;    ///< row 0 first; 12-bit levels inside the registration
  std::vector<uint8_t> mask;     ///< 1 = valid; empty = all valid
};

/** The width of one of the view's pixels (the wider axis) where the central ray passes the
 *  isocentre: the panel's spacing shrunk by the magnification there. */
VTKXPREGISTRATION_EXPORT double PixelSpacingAtIsocenter(const XRayView& view, const Eigen::Vector3d& roomIsocenter);

/** Rays cast on every `columns`-th pixel along a row and on every `rows`-th row; the pixels
 *  between are interpolated bilinearly (DRRProjector::SetStride). */
struct RenderStride
{
  int columns = 1;
  int rows = 1;
  bool operator==(const RenderStride& other) const { return columns == other.columns && rows == other.rows; }
};

/** The CT's sample spacing along a room direction (at the planned pose): the voxel's extent along
 *  it, seen as the ellipsoid its spacings span (1/|A^-1 d| for the index-to-CT matrix A). Along a
 *  CT axis, that axis's spacing; 1 mm for an isotropic 1 mm CT in any direction. */
VTKXPREGISTRATION_EXPORT double CTSpacingAlong(
  const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomDirection);

/**
 * The render stride (StereoSimilarity::SetRenderStride) for DRRs of `volume` on these views, per
 * panel axis: 2 where two pixels at the isocentre span no more than the CT's sample spacing along
 * that axis (CTSpacingAlong; within 10 %: over a body 300 mm deep the magnification varies by
 * about 15 % either side of the isocentre's), so that the rendered nodes are no farther apart than
 * the CT's own samples and bilinear interpolation between them loses no detail the CT holds;
 * otherwise 1. A CT of 0.9 mm pixels and 3 mm slices, seen on 0.52 mm pixels at the isocentre by
 * panels whose columns run along the slices, casts every column of every second row: the slices
 * allow nodes 1 mm apart along them, the pixels do not across.
 */
VTKXPREGISTRATION_EXPORT RenderStride RenderStrideFor(const AttenuationVolume& volume, const std::vector<RegistrationView>& views,
  const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomIsocenter);

/** Line integrals of the views' valid pixels at a pose (0 at masked pixels, which are never traced). */
class VTKXPREGISTRATION_EXPORT DRRProjector
{
public:
  /** `volume` and `views` (their panels and masks) are kept by reference: both must outlive this.
   *  Throws xp::InputError when a view's mask does not cover its panel. */
  DRRProjector(const AttenuationVolume& volume, const std::vector<RegistrationView>& views);
  DRRProjector(const DRRProjector&) = delete;
  DRRProjector& operator=(const DRRProjector&) = delete;

  /** Cast every `stride.columns`-th pixel's ray along a row on every `stride.rows`-th row (1 to 8
   *  each), the pixels between bilinear; {1, 1}: every valid pixel's ray. */
  void SetStride(const RenderStride& stride);
  const RenderStride& Stride() const { return this->Settings; }
  /** Sample every steps[a]-th voxel plane along the rays' dominant CT index axis a
   *  (RayCastSettings::planeSteps; CPU only); { 1, 1, 1 }: every plane, the default. */
  void SetPlaneSteps(const std::array<int, 3>& steps) { this->RayCast.planeSteps = steps; }
  void SetDevice(ComputeDevice device) { this->RayCast.device = device; }
  ComputeDevice Device() const { return this->RayCast.device; }

  /** Renders every view at `ctToRoom` into Integrals (on the GPU in one launch); returns the rays cast. */
  long long Render(const Eigen::Isometry3d& ctToRoom) const;
  /** View v's line integrals from the last Render, row 0 first. */
  const std::vector<float>& Integrals(size_t v) const { return this->Buffers[v]; }
  /** Where view v's rays are cast (the panel, or the stride's nodes) and which of them. */
  const DetectorGrid& Grid(size_t v) const { return this->Grids[v]; }
  const TracedPixels& Traced(size_t v) const { return this->TracedPixelsOf[v]; }

private:
  const AttenuationVolume& Volume;
  const std::vector<RegistrationView>& Views;
  RenderStride Settings;
  RayCastSettings RayCast;
  /** Per view, built once per stride (the mask is fixed): where the rays are cast, which of them
   *  (the valid pixels, or the nodes their interpolation reads), and, with a stride, the nodes'
   *  line integrals. */
  std::vector<DetectorGrid> Grids;
  std::vector<TracedPixels> TracedPixelsOf;
  mutable std::vector<std::vector<float>> NodeIntegrals;
  mutable std::vector<std::vector<float>> Buffers;
};

} // namespace xp

#endif
