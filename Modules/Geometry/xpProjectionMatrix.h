/**
 * @file xpProjectionMatrix.h
 * @brief An imager as a 3x4 projection matrix, the form C-arm and biplane calibrations give.
 *
 * P maps a Room point (x, y, z, 1), mm, to homogeneous pixel coordinates (w col, w row, w), with
 * (col, row) the 0-based pixel-centre indices of XRayView::Project (row 0 the top row) and w > 0
 * in front of the source. P = K [R | t] up to scale: K holds the focal lengths in pixels (the
 * source-to-panel distance over the pixel spacing) and the principal point; R's rows are the
 * panel's row direction, its column direction and the direction from the source to the panel.
 */
#ifndef xpProjectionMatrix_h
#define xpProjectionMatrix_h

#include "vtkXPGeometryModule.h"

#include "xpXRayView.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace xp
{

using ProjectionMatrix = Eigen::Matrix<double, 3, 4>;

/** The projection matrix of `view`, scaled so that w is the depth along the central ray (mm). */
VTKXPGEOMETRY_EXPORT ProjectionMatrix ProjectionMatrixOf(const XRayView& view);

/**
 * The view a projection matrix describes, for a panel of `size` pixels spaced `pixelSpacing`
 * (mm; P fixes only their ratio to the source distance); `pointInFront` (the isocentre) lies
 * between the source and the panel, which fixes P's sign. Throws xp::InputError naming `origin`
 * when P is singular, skewed (rows and columns not at right angles, beyond 0.01 degree) or its
 * focal lengths' ratio disagrees with the spacing's beyond 0.1 %.
 */
VTKXPGEOMETRY_EXPORT XRayView ViewFromProjectionMatrix(const ProjectionMatrix& projection, const Eigen::Vector2d& pixelSpacing,
  const Eigen::Vector2i& size, const Eigen::Vector3d& pointInFront, const std::string& name, const std::string& origin);

/** Reads 12 numbers (3 rows of 4; '#' starts a comment) from a text file; throws xp::InputError
 *  naming the file when it holds more, fewer or a non-number. */
VTKXPGEOMETRY_EXPORT ProjectionMatrix ReadProjectionMatrix(const std::string& path);

/** P = K [R | t] from a pinhole calibration: K (3 rows of 3, pixels) in one text file, the Room
 *  to camera transform [R | t] (3 rows of 4, mm) in another; R must be a rotation. */
VTKXPGEOMETRY_EXPORT ProjectionMatrix ReadPinholeCalibration(const std::string& intrinsicsPath, const std::string& extrinsicsPath);

} // namespace xp

#endif
