/**
 * @file xpRTImageGeometry.h
 * @brief An imager in the terms of a DICOM RT Image (IEC 61217 gantry and X-ray image receptor
 *        systems), and back: what xpose writes into its RT Image DRRs and reads from an RT Image.
 *
 * The source lies on the gantry's beam axis, at Radiation Machine SAD from the isocentre: at
 * gantry angle theta and gantry pitch phi, the gantry system is the fixed one rotated by
 * Ry(theta) Rx(phi), and the source is at Ry(theta) Rx(phi) (0, 0, SAD) from the isocentre
 * (gantry 90: source at +X; pitch 90: source at -Y). The receptor's origin is the X-Ray Image
 * Receptor Translation (gantry mm); its axes are the gantry's rotated by the X-Ray Image
 * Receptor Angle about Z. Image rows run along +X of the receptor and down the image along its
 * -Y; RT Image Position is the first pixel's centre in receptor mm. Only panels normal to the
 * beam axis (RT Image Plane NORMAL) are described.
 */
#ifndef xpRTImageGeometry_h
#define xpRTImageGeometry_h

#include "vtkXPGeometryModule.h"
#include "xpXRayView.h"

#include <Eigen/Core>

namespace xp
{

struct RTImageGeometry
{
  double gantryAngle = 0.0;    ///< degrees, [0, 360): Gantry Angle (300A,011E)
  double gantryPitch = 0.0;    ///< degrees, (-90, 90): Gantry Pitch Angle (300A,014A)
  double receptorAngle = 0.0;  ///< degrees, (-180, 180]: X-Ray Image Receptor Angle (3002,000E)
  double sad = 1000.0;         ///< Radiation Machine SAD (3002,0022), mm
  double sid = 1500.0;         ///< RT Image SID (3002,0026), mm: source to the receptor plane
  Eigen::Vector3d receptorTranslation = Eigen::Vector3d::Zero(); ///< (3002,000D), gantry mm
  Eigen::Vector2d imagePosition = Eigen::Vector2d::Zero();       ///< RT Image Position (3002,0012)
  Eigen::Vector2d pixelSpacing = Eigen::Vector2d::Ones(); ///< Image Plane Pixel Spacing: [between rows, between columns]
  int rows = 1, columns = 1;
};

/**
 * The RT Image terms of `view` about the room isocentre. Throws xp::InputError naming the
 * imager when its panel is not normal to the beam axis within 0.01 degree (RT Image Plane
 * NON_NORMAL is not written) or is mirrored.
 */
VTKXPGEOMETRY_EXPORT RTImageGeometry RTImageGeometryOf(const XRayView& view, const Eigen::Vector3d& isocenter);

/** The imager that RT Image terms describe, about the room isocentre. */
VTKXPGEOMETRY_EXPORT XRayView ViewOfRTImage(const RTImageGeometry& geometry, const Eigen::Vector3d& isocenter, const std::string& name);

} // namespace xp

#endif
