/**
 * @file xpStereoGeometry.h
 * @brief The room's X-ray system: isocentre, imagers and couch, and its JSON file (Coordinates.md).
 *
 * The file's `format_version` is 1 when absent (isocentre and imagers) and 2 with a `couch`
 * object; a version this reader does not know is refused.
 */
#ifndef xpStereoGeometry_h
#define xpStereoGeometry_h

#include "xpCouch.h"
#include "xpXRayView.h"

#include <string>
#include <vector>

namespace xp
{

struct VTKXPGEOMETRY_EXPORT StereoGeometry
{
  std::string name;
  Eigen::Vector3d isocenter = Eigen::Vector3d::Zero(); ///< Room mm
  std::vector<XRayView> views;
  /** The treatment couch (format_version 2); none: a file of version 1, whose couch is read as
   *  6-DOF without limits about the isocentre. */
  std::optional<CouchDescription> couch;

  /** The view called `name`, or nullptr. */
  const XRayView* FindView(const std::string& viewName) const;
};

/**
 * Checks the geometry and throws xp::InputError naming `origin` (usually the file) and the
 * field: directions not unit or not orthogonal, non-positive spacing or size, a source on the
 * panel plane, a central ray (source to isocentre) that misses the panel, duplicate names.
 */
VTKXPGEOMETRY_EXPORT void ValidateGeometry(const StereoGeometry& geometry, const std::string& origin);

/** As ValidateGeometry, and also requires at least two imagers (a stereo registration). */
VTKXPGEOMETRY_EXPORT void ValidateStereoGeometry(
  const StereoGeometry& geometry, const std::string& origin);

/** Parses and validates JSON text; `origin` names the source in error messages. */
VTKXPGEOMETRY_EXPORT StereoGeometry ParseStereoGeometry(
  const std::string& jsonText, const std::string& origin);

/** Reads and validates a geometry file. */
VTKXPGEOMETRY_EXPORT StereoGeometry ReadStereoGeometry(const std::string& path);

/** The JSON text of a geometry, in the file format that ReadStereoGeometry reads. */
VTKXPGEOMETRY_EXPORT std::string FormatStereoGeometry(const StereoGeometry& geometry);

/** Writes a geometry file; throws xp::Error if the file cannot be written. */
VTKXPGEOMETRY_EXPORT void WriteStereoGeometry(const StereoGeometry& geometry, const std::string& path);

} // namespace xp

#endif
