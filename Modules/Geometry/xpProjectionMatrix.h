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
#include <utility>
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

/**
 * A camera calibration as XMALab exports it ("MayaCam 2.0"): sections headed `image size`
 * (columns,rows), `camera matrix` (K, 3 rows, pixels), `rotation` (R, 3 rows) and `translation`
 * (t, mm), numbers separated by commas or spaces; x_camera = R X + t for a Room point X, and
 * pixel (u, v) = K x_camera / z (v counting rows downward, OpenCV's convention).
 */
struct VTKXPGEOMETRY_EXPORT CameraCalibration
{
  Eigen::Vector2i size = Eigen::Vector2i::Zero(); ///< columns, rows
  Eigen::Matrix3d intrinsics = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  ProjectionMatrix Projection() const;
  Eigen::Vector3d Source() const { return -this->rotation.transpose() * this->translation; }
  /** The optical axis: the direction from the source through the principal point. */
  Eigen::Vector3d Axis() const { return this->rotation.row(2).transpose(); }
  /** Pixel spacing (columns, rows) that makes both focal lengths one source-to-panel distance:
   *  `spacingMM` between columns, scaled by fx / fy between rows. */
  Eigen::Vector2d PixelSpacing(double spacingMM) const;
};

/** Reads a CameraCalibration; throws xp::InputError naming the file and the section that is
 *  missing, holds another count of numbers, or a rotation that is not one (1e-6). */
VTKXPGEOMETRY_EXPORT CameraCalibration ReadCameraCalibration(const std::string& path);

/** The point closest to every line (point, direction) in the least-squares sense, and for two
 *  lines the distance between them at their closest approach (0 for more lines). Throws
 *  xp::InputError when the lines are parallel. */
VTKXPGEOMETRY_EXPORT Eigen::Vector3d ClosestApproach(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& lines,
  double* gapMM = nullptr);

} // namespace xp

#endif
