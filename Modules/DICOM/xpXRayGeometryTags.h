/**
 * @file xpXRayGeometryTags.h
 * @brief The imager an X-ray DICOM file's own tags describe, whatever its kind: RT Image
 *        (xpRTImage.h) or a projection radiograph, DX, CR or XA (xpCArmGeometry.h gives the
 *        conventions); and where those tags disagree with a geometry file.
 */
#ifndef xpXRayGeometryTags_h
#define xpXRayGeometryTags_h

#include "vtkXPDICOMModule.h"
#include "xpRTImage.h"
#include "xpXRayView.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace xp
{

/**
 * The imager a DX, CR or XA image describes about `roomIsocenter`, named by its file. Needs
 * Distance Source to Detector (0018,1110), Distance Source to Patient (0018,1111), Positioner
 * Primary and Secondary Angle (0018,1510/1511), Imager Pixel Spacing (0018,1164), Rows, Columns
 * and Patient Orientation (0020,0020); the patient lies as its Patient Position (0018,5100)
 * says, or as `patientPosition` (HFS, HFP, FFS, FFP) says where the file has none. A Positioner
 * Type (0018,1508) other than CARM is refused: its angles mean something else. Throws
 * xp::InputError naming the file and the tag when one is missing, malformed or contradicts another.
 */
VTKXPDICOM_EXPORT XRayView ReadProjectionXRayView(
  const std::string& path, const Eigen::Vector3d& roomIsocenter, const std::string& patientPosition = "");

/** ReadRTImageView or ReadProjectionXRayView, as the file's SOP Class UID says; other classes
 *  are refused, naming the file and the class. */
VTKXPDICOM_EXPORT XRayView ReadXRayViewFromTags(
  const std::string& path, const Eigen::Vector3d& roomIsocenter, const std::string& patientPosition = "");

/**
 * Where the geometry tags of the X-ray DICOM file at `path` (RT Image, DX, CR or XA) disagree
 * with `view` (a geometry file's imager) beyond 0.5 mm or 0.1 degree: one line per tag, naming
 * it and both values. Files of other kinds (PNG, other classes) and absent tags give nothing to
 * compare; an imager the file's kind cannot describe gives one line that says so. `subset`
 * PixelSpacing compares the pixels' spacing alone.
 */
VTKXPDICOM_EXPORT std::vector<std::string> XRayTagDisagreements(const std::string& path, const XRayView& view,
  const Eigen::Vector3d& roomIsocenter, const std::string& patientPosition = "", XRayTagSubset subset = XRayTagSubset::All);

} // namespace xp

#endif
