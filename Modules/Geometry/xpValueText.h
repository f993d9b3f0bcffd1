/**
 * @file xpValueText.h
 * @brief The text forms of sizes and points that options and result.json's `inputs` use:
 *        parsed once at the edge into typed values, each refusal naming its field, and written
 *        back in the same form.
 */
#ifndef xpValueText_h
#define xpValueText_h

#include "vtkXPGeometryModule.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <utility>

namespace xp
{

/** "1024x768" -> {1024, 768} (1 to 16384 each); throws xp::InputError naming `field`. */
VTKXPGEOMETRY_EXPORT std::pair<int, int> ParseSize(const std::string& text, const std::string& field);

/** ParseSize as a panel's columns and rows. */
VTKXPGEOMETRY_EXPORT Eigen::Vector2i ParseImageSize(const std::string& text, const std::string& field);

/** "x,y,z" -> a point in mm; throws xp::InputError naming `field`. */
VTKXPGEOMETRY_EXPORT Eigen::Vector3d ParsePoint(const std::string& text, const std::string& field);

/** ParseImageSize and ParsePoint for an option that may be left out: empty text is none. */
VTKXPGEOMETRY_EXPORT std::optional<Eigen::Vector2i> ParseSizeIfGiven(const std::string& text, const std::string& field);
VTKXPGEOMETRY_EXPORT std::optional<Eigen::Vector3d> ParsePointIfGiven(const std::string& text, const std::string& field);

/** {512, 384} -> "512x384": what ParseSize reads. */
VTKXPGEOMETRY_EXPORT std::string SizeText(const Eigen::Vector2i& size);

/** A point as "x,y,z" to 10 significant digits: what ParsePoint reads. */
VTKXPGEOMETRY_EXPORT std::string PointText(const Eigen::Vector3d& point);

} // namespace xp

#endif
