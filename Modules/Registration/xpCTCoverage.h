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

/** The CT's end faces, as bits: the first slice's and the last slice's. */
enum CTEndFace : uint8_t
{
  FirstSliceFace = 1,
  LastSliceFace = 2,
  BothEndFaces = 3
};

/** The same, with the body's outline found once for many poses and views. */
class VTKXPREGISTRATION_EXPORT CTCoverage
{
public:
  /** Keeps a reference to `volume`, which must outlive this. */
  CTCoverage(const AttenuationVolume& volume, double marginMM);
  /** CTCoverageMask, leaving out only the rays beyond the end faces in `ends` (CTEndFace bits). */
  std::vector<uint8_t> Mask(const Eigen::Isometry3d& ctToRoom, const XRayView& view, uint8_t ends = BothEndFaces) const;
  /** For each pixel, the CTEndFace bits of the faces beyond which its ray crosses the body. */
  std::vector<uint8_t> EndFaces(const Eigen::Isometry3d& ctToRoom, const XRayView& view) const;

private:
  const AttenuationVolume& Volume;
  double MarginMM;
  Eigen::Affine3d IndexToCT;
  Eigen::Vector3d Spacing;
  std::vector<uint8_t> Outline;      ///< (i, j), i fastest
  Eigen::Vector2d OutlineLow, OutlineHigh; ///< the outline's extent in voxel indices (+-0.5)
};


/**
 * Whether an X-ray shows anatomy beyond the CT's end faces, measured against the DRR of the same
 * view at about the right pose. The rays that stay within the CT tell how DRR values map to the
 * X-ray's, whatever the physics (the median X-ray value of each DRR level; towards the X-ray's
 * open field for DRR values beyond the covered ones). The rays beyond a face are then compared
 * with what their DRR predicts: where the CT is shorter than the anatomy the X-ray shows, a good
 * part of them is clearly more attenuated than predicted; where the CT reaches as far, they agree
 * to noise and misalignment, and they are information that the registration should keep.
 */
struct EndFaceEvidence
{
  /** Per face (first slice, last slice): how much more attenuated than predicted the upper
   *  quarter of its rays is, in fractions of the X-ray's range (open field to the most
   *  attenuated covered level); X-ray-only objects over less than a quarter do not count. */
  double excess[2] = { 0.0, 0.0 };
  long long pixels[2] = { 0, 0 }; ///< per face: the pixels whose rays cross the body beyond it
  uint8_t facesToLeaveOut = 0;    ///< CTEndFace bits
};

/**
 * @param xray, drr   the view's X-ray and its DRR at the pose, 12-bit, same size
 * @param content     1 = a pixel to consider; empty = all
 * @param endFaces    CTCoverage::EndFaces at the pose
 * @param minExcess   a face is left out when its excess reaches this; 0 = always. A face crossed by
 *                    too few pixels to tell, or a view with too few covered ones, leaves its rays
 *                    out (the CT's end as the limit is the safe side).
 */
VTKXPREGISTRATION_EXPORT EndFaceEvidence MeasureAnatomyBeyondEndFaces(const std::vector<uint16_t>& xray,
  const std::vector<uint16_t>& drr, const std::vector<uint8_t>& content, const std::vector<uint8_t>& endFaces,
  double minExcess);

} // namespace xp

#endif
