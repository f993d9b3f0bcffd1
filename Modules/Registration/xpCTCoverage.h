/**
 * @file xpCTCoverage.h
 * @brief The pixels whose rays stay within the CT wherever they cross the patient.
 *
 * A planning CT ends a few centimetres beyond the target, and an X-ray's field goes further. A
 * ray that crosses the body beyond the CT's end slices sees anatomy in the X-ray that its DRR
 * cannot show: no setting of the pose makes the two agree there, and the optimiser trades a
 * little misalignment for a better match of that partial anatomy. Those pixels are left out.
 */
#ifndef xpCTCoverage_h
#define xpCTCoverage_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpXRayView.h"

#include <cstdint>
#include <vector>

namespace xp
{

/**
 * 1 for each pixel of `view` whose ray, with the CT placed by `ctToRoom`, is between the CT's
 * first and last slices (less `marginMM`) wherever it passes through the body's outline (the
 * voxels with attenuation in any slice, seen along the slice axis, widened by `marginMM`);
 * 0 elsewhere. Rows top first.
 */
VTKXPREGISTRATION_EXPORT std::vector<uint8_t> CTCoverageMask(
  const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const XRayView& view, double marginMM);

/** The same, with the body's outline found once for many poses and views. */
class VTKXPREGISTRATION_EXPORT CTCoverage
{
public:
  /** Keeps a reference to `volume`, which must outlive this. */
  CTCoverage(const AttenuationVolume& volume, double marginMM);
  std::vector<uint8_t> Mask(const Eigen::Isometry3d& ctToRoom, const XRayView& view) const;

private:
  const AttenuationVolume& Volume;
  double MarginMM;
  Eigen::Affine3d IndexToCT;
  Eigen::Vector3d Spacing;
  std::vector<uint8_t> Outline;      ///< (i, j), i fastest
  Eigen::Vector2d OutlineLow, OutlineHigh; ///< the outline's extent in voxel indices (+-0.5)
};

} // namespace xp

#endif
