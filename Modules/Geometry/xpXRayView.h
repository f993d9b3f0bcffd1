/**
 * @file xpXRayView.h
 * @brief One X-ray source and its flat panel, in Room coordinates (IEC 61217 fixed, mm).
 *
 * Pixel (col i, row j) has its centre at
 *   center + (i - (cols-1)/2) * du * rowDirection + (j - (rows-1)/2) * dv * columnDirection,
 * row 0 being the first (top) row as stored in DICOM and PNG (Coordinates.md).
 */
#ifndef xpXRayView_h
#define xpXRayView_h

#include "vtkXPGeometryModule.h"

#include <Eigen/Core>
#include <optional>
#include <string>

namespace xp
{

/** A ray from the source through a pixel centre: direction is unit length, Room frame. */
struct Ray
{
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
};

struct VTKXPGEOMETRY_EXPORT XRayView
{
  std::string name;
  Eigen::Vector3d source = Eigen::Vector3d::Zero();          ///< focal spot, Room mm
  Eigen::Vector3d detectorCenter = Eigen::Vector3d::Zero();  ///< centre of the pixel array, Room mm
  Eigen::Vector3d rowDirection = Eigen::Vector3d::UnitX();    ///< along a row (increasing column)
  Eigen::Vector3d columnDirection = Eigen::Vector3d::UnitY(); ///< down a column (increasing row)
  Eigen::Vector2d pixelSpacing = Eigen::Vector2d::Ones();     ///< [between columns, between rows] mm
  Eigen::Vector2i size = Eigen::Vector2i::Ones();             ///< [columns, rows]

  int Columns() const { return size[0]; }
  int Rows() const { return size[1]; }

  /** Room position of the centre of pixel (col, row); fractional indices are allowed. */
  Eigen::Vector3d PixelCenter(double col, double row) const;

  /** Unit panel normal pointing from the panel towards the source. */
  Eigen::Vector3d NormalTowardsSource() const;

  /** Distance from the source to the panel plane (mm). */
  double SourceToPanelDistance() const;

  /**
   * Perspective projection of a Room point onto the panel: (col, row) as fractional pixel
   * indices. Throws xp::Error when the point is not between the source's plane and beyond it
   * (on or behind the source), where no projection exists.
   */
  Eigen::Vector2d Project(const Eigen::Vector3d& roomPoint) const;

  /** The ray from the source through the centre of pixel (col, row). */
  Ray PixelRay(double col, double row) const;

  /** The same panel (same physical extent) sampled with a different number of pixels. */
  XRayView Resampled(int columns, int rows) const;

  /** The panel read out binned to `columns` x `rows` (each a whole fraction of its own size,
   *  the factors may differ per axis): Resampled to that size; none for any other size. */
  std::optional<XRayView> Binned(int columns, int rows) const;
};

} // namespace xp

#endif
