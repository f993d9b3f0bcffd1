/**
 * @file xpBoneCut.h
 * @brief Where a bone's crop cut the bone: the faces of its box that the bone fills a good part
 *        of, and the pixels near their shadow, which the X-ray shows running on.
 *
 * A crop of one bone out of a CT ends where its box ends: the radius of the wrist set is cut
 * across its shaft. Its DRR then ends in a sharp rim where the X-ray shows the shaft going on, and
 * a similarity over the bone's shadow and a margin reads that rim and the shaft beyond it as a
 * mismatch that a pose can lessen by sliding or turning the bone. A box touches any crop at each
 * of its faces; a cut is a face of the volume that the bone reaches with a last layer of at least 5 % of the
 * largest layer along that axis and 60 % of the layer three voxels inwards: a rounded end closes
 * towards its face, a cut leaves the cross-section as it was.
 */
#ifndef xpBoneCut_h
#define xpBoneCut_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpXRayView.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace xp
{

/** The centres (CT mm) of the non-air voxels in the volume's cut faces; empty when none is cut. */
VTKXPREGISTRATION_EXPORT std::vector<Eigen::Vector3d> CutFacePoints(const AttenuationVolume& volume);

/**
 * Sets to 0 the pixels of `mask` (columns x rows of `view`, row 0 first; empty = all valid, then
 * filled) within `radiusMM` on the panel of the projection of any of `points` (CT mm) placed by
 * `ctToRoom`.
 */
VTKXPREGISTRATION_EXPORT void LeaveOutAroundPoints(std::vector<uint8_t>& mask, const XRayView& view,
  const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& ctToRoom, double radiusMM);

/** The same on a columns x rows buffer of `view`'s size (an OpenCV mask's data, 255 = kept). */
VTKXPREGISTRATION_EXPORT void LeaveOutAroundPoints(uint8_t* mask, const XRayView& view,
  const std::vector<Eigen::Vector3d>& points, const Eigen::Isometry3d& ctToRoom, double radiusMM);

} // namespace xp

#endif
