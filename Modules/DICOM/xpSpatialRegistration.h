/**
 * @file xpSpatialRegistration.h
 * @brief A registration result as a DICOM Spatial Registration object (REG), which a treatment
 *        planning system, 3D Slicer (SlicerRT) or a record-and-verify system loads with the CT.
 */
#ifndef xpSpatialRegistration_h
#define xpSpatialRegistration_h

#include "vtkXPDICOMModule.h"
#include "xpDICOMSeries.h"

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

namespace xp
{

/** A DICOM image another object refers to, as its own file names it. */
struct InstanceReference
{
  std::string sopClassUID;
  std::string sopInstanceUID;
  std::string seriesInstanceUID;
  std::string studyInstanceUID;
};

/** What the REG says besides the identity it copies from the CT. */
struct SpatialRegistration
{
  /** CT (LPS mm) -> the treatment session's Frame of Reference: where the anatomy at a planned
   *  CT point was found (MisalignmentInCT). */
  Eigen::Isometry3d ctToSession = Eigen::Isometry3d::Identity();
  std::string contentLabel = "XPOSE_POSE";    ///< CS: capitals, digits, space, _; 16 at most
  std::string contentDescription;             ///< LO: 64 characters at most
  std::string creator = "xpose^";             ///< Content Creator's Name (PN)
  std::string seriesDescription = "xpose patient pose";
  /** Images of the treatment session (the X-rays the pose was found from), in its Frame of
   *  Reference; they may belong to another study than the CT's. */
  std::vector<InstanceReference> sessionImages;
};

/**
 * Writes `registration` as a Spatial Registration Storage object to `path`: patient and study
 * copied from the first file of the CT series, a new series and SOP instance, a new Frame of
 * Reference for the treatment session, and in the Registration Sequence that Frame of Reference
 * (identity, with the session images) and the CT's (the rigid matrix, with every CT image); the
 * Common Instance Reference lists them all by series and study. Returns the new
 * SOP Instance UID. Throws xp::InputError naming the CT file when it has no Study Instance or
 * Frame of Reference UID, xp::Error naming `path` when it cannot be written.
 */
VTKXPDICOM_EXPORT std::string WriteSpatialRegistration(
  const CTSeriesInfo& ct, const SpatialRegistration& registration, const std::string& path);

/**
 * The rigid matrix a REG file holds for `frameOfReferenceUID` (into the REG's own Frame of
 * Reference). Throws xp::InputError naming `path` and the attribute when the file is not a REG
 * or holds no such matrix.
 */
VTKXPDICOM_EXPORT Eigen::Isometry3d ReadSpatialRegistrationMatrix(const std::string& path, const std::string& frameOfReferenceUID);

/** The identity of the DICOM image at `path`; none when the file is not DICOM or lacks one of
 *  the four UIDs. */
VTKXPDICOM_EXPORT std::optional<InstanceReference> ReadInstanceReference(const std::string& path);

/** A new DICOM UID under the root 2.25 (a random UUID as a decimal number, PS3.5 B.2). */
VTKXPDICOM_EXPORT std::string NewDICOMUID();

} // namespace xp

#endif
