#include "xpRTImageGeometry.h"

#include "xpError.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

constexpr double Degree = M_PI / 180.0;
// Panels normal to the beam axis within this (0.01 degree).
constexpr double NormalTolerance = 0.01 * Degree;

/** Gantry system -> fixed system: Ry(gantry angle) Rx(gantry pitch). */
Eigen::Matrix3d GantryToFixed(double angle, double pitch)
{
  return (Eigen::AngleAxisd(angle * Degree, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(pitch * Degree, Eigen::Vector3d::UnitX()))
    .toRotationMatrix();
}

} // namespace

RTImageGeometry RTImageGeometryOf(const XRayView& view, const Eigen::Vector3d& isocenter)
{
  RTImageGeometry g;
  const Eigen::Vector3d axis = view.source - isocenter;
  g.sad = axis.norm();
  if (!(g.sad > 0.0))
    throw InputError("imager " + view.name, "the source sits at the isocentre: no beam axis");
  const Eigen::Vector3d s = axis / g.sad;
  g.gantryPitch = std::asin(std::clamp(-s.y(), -1.0, 1.0)) / Degree;
  g.gantryAngle = std::atan2(s.x(), s.z()) / Degree;
  if (g.gantryAngle < 0.0)
    g.gantryAngle += 360.0;
  const Eigen::Matrix3d toGantry = GantryToFixed(g.gantryAngle, g.gantryPitch).transpose();
  const Eigen::Vector3d row = toGantry * view.rowDirection, column = toGantry * view.columnDirection;
  // NORMAL: rows and columns lie in the receptor plane, perpendicular to the beam axis (Z).
  if (std::abs(row.z()) > std::sin(NormalTolerance) || std::abs(column.z()) > std::sin(NormalTolerance))
    throw InputError("imager " + view.name, "the panel is tilted against its beam axis (RT Image Plane NON_NORMAL is not supported)");
  g.receptorAngle = std::atan2(row.y(), row.x()) / Degree;
  // Down the image is the receptor's -Y: Rz(angle) applied to -Y.
  const double a = g.receptorAngle * Degree;
  if ((column - Eigen::Vector3d(std::sin(a), -std::cos(a), 0.0)).norm() > 1e-3)
    throw InputError("imager " + view.name, "the panel is mirrored (column direction is not the receptor's -Y)");
  g.columns = view.Columns();
  g.rows = view.Rows();
  g.pixelSpacing = Eigen::Vector2d(view.pixelSpacing[1], view.pixelSpacing[0]);
  g.receptorTranslation = toGantry * (view.detectorCenter - isocenter);
  g.sid = g.sad - g.receptorTranslation.z();
  // The first pixel's centre, relative to the panel centre, in receptor mm (x along rows, y up).
  g.imagePosition = Eigen::Vector2d(-0.5 * (g.columns - 1) * view.pixelSpacing[0], 0.5 * (g.rows - 1) * view.pixelSpacing[1]);
  return g;
}

XRayView ViewOfRTImage(const RTImageGeometry& g, const Eigen::Vector3d& isocenter, const std::string& name)
{
  const Eigen::Matrix3d toFixed = GantryToFixed(g.gantryAngle, g.gantryPitch);
  const double a = g.receptorAngle * Degree;
  const Eigen::Vector3d receptorX(std::cos(a), std::sin(a), 0.0), receptorY(-std::sin(a), std::cos(a), 0.0);
  XRayView view;
  view.name = name;
  view.source = isocenter + toFixed * Eigen::Vector3d(0.0, 0.0, g.sad);
  view.rowDirection = toFixed * receptorX;
  view.columnDirection = -(toFixed * receptorY);
  view.pixelSpacing = Eigen::Vector2d(g.pixelSpacing[1], g.pixelSpacing[0]);
  view.size = Eigen::Vector2i(g.columns, g.rows);
  // The receptor plane lies SID from the source along the beam axis; its origin is translated.
  const Eigen::Vector3d origin(g.receptorTranslation.x(), g.receptorTranslation.y(), g.sad - g.sid);
  const Eigen::Vector3d firstPixel = origin + g.imagePosition.x() * receptorX + g.imagePosition.y() * receptorY;
  const Eigen::Vector3d centreInGantry = firstPixel + 0.5 * (g.columns - 1) * view.pixelSpacing[0] * receptorX -
    0.5 * (g.rows - 1) * view.pixelSpacing[1] * receptorY;
  view.detectorCenter = isocenter + toFixed * centreInGantry;
  return view;
}

} // namespace xp
