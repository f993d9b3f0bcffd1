/**
 * @file xpRTImage.h
 * @brief DRRs as DICOM RT Images, with enough geometry in their tags to rebuild the imager, and
 *        the imager an RT Image's tags describe (xpRTImageGeometry.h gives the conventions); the
 *        report's picture as a Secondary Capture beside them.
 */
#ifndef xpRTImage_h
#define xpRTImage_h

#include "vtkXPDICOMModule.h"
#include "xpDICOMSeries.h"
#include "xpXRayView.h"

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace xp
{

/** One DRR and where it was made. */
struct RTImageDRR
{
  XRayView view;                        ///< the imager, Room mm
  Eigen::Vector3d roomIsocenter = Eigen::Vector3d::Zero();
  Eigen::Vector3d isocenterInCT = Eigen::Vector3d::Zero(); ///< LPS mm: Isocenter Position (300A,012C)
  std::string patientPosition = "HFS";
  std::vector<uint16_t> pixels;         ///< 12-bit (0..4095), row 0 first, view.Columns() per row
  std::string description;              ///< RT Image Description, e.g. the pose it shows
};

/**
 * Writes `drr` as an RT Image Storage object (Image Type DERIVED\SECONDARY\DRR, RT Image Plane
 * NORMAL, gantry angle and pitch, receptor translation and angle, SAD, SID, pixel spacing and
 * position) into `path`, in the CT's study and Frame of Reference, derived from every CT image.
 * Views of one run share `seriesUID`. Returns the SOP Instance UID. Throws xp::InputError when
 * the imager's panel is not normal to its beam axis, xp::Error when the file cannot be written.
 */
VTKXPDICOM_EXPORT std::string WriteRTImageDRR(
  const CTSeriesInfo& ct, const RTImageDRR& drr, const std::string& seriesUID, int instanceNumber, const std::string& path);

/**
 * The imager an RT Image describes about `roomIsocenter`, named by its RT Image Label. Needs RT
 * Image Plane NORMAL, Radiation Machine SAD, RT Image SID, Image Plane Pixel Spacing, Rows,
 * Columns and Gantry Angle; Gantry Pitch Angle, X-Ray Image Receptor Angle and Translation and RT
 * Image Position default to an untilted, centred panel. Throws xp::InputError naming the file
 * and the tag when one is missing, malformed or contradicts another.
 */
VTKXPDICOM_EXPORT XRayView ReadRTImageView(const std::string& path, const Eigen::Vector3d& roomIsocenter);

/**
 * Writes the picture in the PNG file `png` (the report's summary, 8-bit grey or colour) as a
 * Secondary Capture image in the CT's study, into `path`. Returns the SOP Instance UID. Throws
 * xp::InputError naming the PNG when it cannot be decoded, xp::Error when `path` cannot be written.
 */
VTKXPDICOM_EXPORT std::string WriteSecondaryCapture(
  const CTSeriesInfo& ct, const std::string& png, const std::string& description, const std::string& path);

/** Which of an X-ray file's geometry tags a comparison reads. */
enum class XRayTagSubset
{
  All,         ///< every tag that places the imager
  PixelSpacing ///< the pixels' spacing alone: what tells a binned read-out from another panel
};

/**
 * Where the geometry tags of the RT Image at `path` disagree with `view` (a geometry file's
 * imager) beyond 0.5 mm or 0.1 degree: one line per tag, naming it and both values. A file that
 * is not an RT Image, and tags that are absent, give nothing to compare.
 */
VTKXPDICOM_EXPORT std::vector<std::string> RTImageDisagreements(const std::string& path, const XRayView& view,
  const Eigen::Vector3d& roomIsocenter, XRayTagSubset subset = XRayTagSubset::All);

} // namespace xp

#endif
