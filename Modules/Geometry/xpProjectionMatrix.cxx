#include "xpProjectionMatrix.h"

#include "xpError.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <sstream>

namespace xp
{

ProjectionMatrix ProjectionMatrixOf(const XRayView& view)
{
  // K [R | -R C] with the principal point where the source's perpendicular meets the panel.
  const Eigen::Vector3d towardsPanel = -view.NormalTowardsSource();
  const double distance = view.SourceToPanelDistance();
  Eigen::Matrix3d rotation;
  rotation.row(0) = view.rowDirection.transpose();
  rotation.row(1) = view.columnDirection.transpose();
  rotation.row(2) = towardsPanel.transpose();
  const Eigen::Vector3d foot = view.source + distance * towardsPanel;
  const Eigen::Vector3d offset = foot - view.detectorCenter;
  Eigen::Matrix3d intrinsics = Eigen::Matrix3d::Identity();
  intrinsics(0, 0) = distance / view.pixelSpacing[0];
  intrinsics(1, 1) = distance / view.pixelSpacing[1];
  intrinsics(0, 2) = offset.dot(view.rowDirection) / view.pixelSpacing[0] + 0.5 * (view.size[0] - 1);
  intrinsics(1, 2) = offset.dot(view.columnDirection) / view.pixelSpacing[1] + 0.5 * (view.size[1] - 1);
  ProjectionMatrix projection;
  projection.leftCols<3>() = intrinsics * rotation;
  projection.col(3) = -intrinsics * rotation * view.source;
  return projection;
}

XRayView ViewFromProjectionMatrix(const ProjectionMatrix& projection, const Eigen::Vector2d& pixelSpacing,
  const Eigen::Vector2i& size, const Eigen::Vector3d& pointInFront, const std::string& name, const std::string& origin)
{
  if (!projection.allFinite())
    throw InputError(origin, "the projection matrix holds a value that is not a finite number");
  if (!(pixelSpacing.minCoeff() > 0.0 && size.minCoeff() > 0))
    throw InputError(origin, "pixel spacing and size must be positive");
  Eigen::Matrix3d m = projection.leftCols<3>();
  Eigen::Vector3d p4 = projection.col(3);
  if (!(std::abs(m.determinant()) > 1e-12 * std::pow(m.norm(), 3)))
    throw InputError(origin, "the projection matrix's left 3x3 block is singular: not a perspective projection");
  // Scale: the third row a unit vector, and the point in front of the source at positive depth
  // (P is defined up to a scale of either sign).
  const double depth = m.row(2).dot(pointInFront) + p4[2];
  if (!(std::abs(depth) > 0.0))
    throw InputError(origin, "the isocentre lies in the source's plane: it has no projection");
  const double scale = (depth > 0.0 ? 1.0 : -1.0) / m.row(2).norm();
  m *= scale;
  p4 *= scale;
  // RQ decomposition M = K R by Gram-Schmidt from the last row up: R's third row is M's, the
  // second is M's second less its part along the third, and so on.
  const Eigen::Vector3d r3 = m.row(2).transpose();
  const double cy = m.row(1).dot(r3.transpose());
  Eigen::Vector3d r2 = m.row(1).transpose() - cy * r3;
  const double fy = r2.norm();
  r2 /= fy;
  const double cx = m.row(0).dot(r3.transpose()), skew = m.row(0).dot(r2.transpose());
  Eigen::Vector3d r1 = m.row(0).transpose() - cx * r3 - skew * r2;
  const double fx = r1.norm();
  r1 /= fx;
  if (!(std::abs(std::atan2(skew, fx)) * 180.0 / M_PI <= 0.01))
    throw InputError(origin, "the projection matrix is skewed: its panel's rows and columns are not at right angles");
  const double fromX = fx * pixelSpacing[0], fromY = fy * pixelSpacing[1];
  if (!(std::abs(fromX - fromY) <= 1e-3 * std::max(fromX, fromY)))
    throw InputError(origin, "the focal lengths' ratio (" + std::to_string(fx / fy) +
        ") disagrees with the pixel spacing's (" + std::to_string(pixelSpacing[1] / pixelSpacing[0]) + ")");
  const double distance = 0.5 * (fromX + fromY);
  XRayView view;
  view.name = name;
  view.source = -m.inverse() * p4;
  view.rowDirection = r1;
  view.columnDirection = r2;
  view.pixelSpacing = pixelSpacing;
  view.size = size;
  // The principal point (cx, cy) is where the perpendicular from the source meets the panel.
  const Eigen::Vector3d foot = view.source + distance * r3;
  view.detectorCenter = foot + (0.5 * (size[0] - 1) - cx) * pixelSpacing[0] * r1 + (0.5 * (size[1] - 1) - cy) * pixelSpacing[1] * r2;
  return view;
}

namespace
{

/** `word` as a finite number; throws xp::InputError naming the file and the line otherwise. */
double FiniteNumber(const std::string& word, const std::string& path, int line)
{
  size_t used = 0;
  double value = 0.0;
  try
  {
    value = std::stod(word, &used);
  }
  catch (const std::exception&)
  {
  }
  if (used != word.size() || !std::isfinite(value))
    throw InputError(path, "line " + std::to_string(line) + ": '" + word + "' is not a finite number");
  return value;
}

/** `count` numbers from a text file, '#' starting a comment. */
std::vector<double> ReadNumbers(const std::string& path, size_t count, const std::string& what)
{
  std::ifstream in(path);
  if (!in)
    throw InputError(path, "cannot open the " + what + " file");
  std::vector<double> values;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
  {
    std::istringstream words(line.substr(0, line.find('#')));
    for (std::string word; words >> word;)
      values.push_back(FiniteNumber(word, path, number));
  }
  if (values.size() != count)
    throw InputError(path, "holds " + std::to_string(values.size()) + " numbers; " + what + " has " + std::to_string(count));
  return values;
}

} // namespace

ProjectionMatrix ReadProjectionMatrix(const std::string& path)
{
  const std::vector<double> values = ReadNumbers(path, 12, "a projection matrix (3 rows of 4)");
  ProjectionMatrix projection;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      projection(r, c) = values[static_cast<size_t>(r) * 4 + c];
  return projection;
}

ProjectionMatrix ReadPinholeCalibration(const std::string& intrinsicsPath, const std::string& extrinsicsPath)
{
  const std::vector<double> k = ReadNumbers(intrinsicsPath, 9, "an intrinsics matrix K (3 rows of 3)");
  Eigen::Matrix3d intrinsics;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
      intrinsics(r, c) = k[static_cast<size_t>(r) * 3 + c];
  const ProjectionMatrix pose = ReadProjectionMatrix(extrinsicsPath);
  const Eigen::Matrix3d rotation = pose.leftCols<3>();
  if (!((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6 && rotation.determinant() > 0.0))
    throw InputError(extrinsicsPath, "the rotation R of [R | t] is not a rotation (orthonormal, determinant 1, within 1e-6)");
  return intrinsics * pose;
}

ProjectionMatrix CameraCalibration::Projection() const
{
  ProjectionMatrix pose;
  pose << this->rotation, this->translation;
  return this->intrinsics * pose;
}

Eigen::Vector2d CameraCalibration::PixelSpacing(double spacingMM) const
{
  return Eigen::Vector2d(spacingMM, spacingMM * this->intrinsics(0, 0) / this->intrinsics(1, 1));
}

CameraCalibration ReadCameraCalibration(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw InputError(path, "cannot open the camera calibration file");
  const std::vector<std::pair<std::string, size_t>> sections{ { "image size", 2 }, { "camera matrix", 9 },
    { "rotation", 9 }, { "translation", 3 } };
  std::vector<std::vector<double>> numbers(sections.size());
  int current = -1;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number)
  {
    std::string lower;
    for (char c : line)
      lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const size_t first = lower.find_first_not_of(" \t\r");
    if (first == std::string::npos)
      continue;
    if (std::isalpha(static_cast<unsigned char>(lower[first])))
    {
      current = -1;
      for (size_t k = 0; k < sections.size(); ++k)
        if (lower.compare(first, sections[k].first.size(), sections[k].first) == 0)
          current = static_cast<int>(k);
      if (current < 0)
        throw InputError(path, "line " + std::to_string(number) + ": unknown section '" + line +
            "' (expected image size, camera matrix, rotation, translation)");
      continue;
    }
    if (current < 0)
      throw InputError(path, "line " + std::to_string(number) + ": numbers before any section heading");
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream words(line);
    for (std::string word; words >> word;)
      numbers[static_cast<size_t>(current)].push_back(FiniteNumber(word, path, number));
  }
  for (size_t k = 0; k < sections.size(); ++k)
    if (numbers[k].size() != sections[k].second)
      throw InputError(path, sections[k].first + ": " + std::to_string(numbers[k].size()) + " numbers, expected " +
          std::to_string(sections[k].second));
  CameraCalibration calibration;
  calibration.size = Eigen::Vector2i(static_cast<int>(numbers[0][0]), static_cast<int>(numbers[0][1]));
  if (calibration.size.minCoeff() < 1 || calibration.size.maxCoeff() > 16384 || numbers[0][0] != calibration.size[0] ||
    numbers[0][1] != calibration.size[1])
    throw InputError(path, "image size: expected two whole numbers from 1 to 16384");
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c)
    {
      calibration.intrinsics(r, c) = numbers[1][static_cast<size_t>(r) * 3 + c];
      calibration.rotation(r, c) = numbers[2][static_cast<size_t>(r) * 3 + c];
    }
  calibration.translation = Eigen::Vector3d(numbers[3][0], numbers[3][1], numbers[3][2]);
  const Eigen::Matrix3d& rotation = calibration.rotation;
  if (!((rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <= 1e-6 && rotation.determinant() > 0.0))
    throw InputError(path, "rotation: not a rotation (orthonormal, determinant 1, within 1e-6)");
  if (!(calibration.intrinsics(0, 0) > 0.0 && calibration.intrinsics(1, 1) > 0.0))
    throw InputError(path, "camera matrix: the focal lengths (first two diagonal entries) must be positive");
  return calibration;
}

Eigen::Vector3d ClosestApproach(const std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>& lines, double* gapMM)
{
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Vector3d right = Eigen::Vector3d::Zero();
  for (const auto& [point, direction] : lines)
  {
    const Eigen::Vector3d d = direction.normalized();
    const Eigen::Matrix3d across = Eigen::Matrix3d::Identity() - d * d.transpose();
    normal += across;
    right += across * point;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(normal);
  if (lines.size() < 2 || !(eigen.eigenvalues().minCoeff() > 1e-9 * lines.size()))
    throw InputError("central rays", "the imagers' central rays are parallel: they do not meet anywhere");
  const Eigen::Vector3d closest = normal.ldlt().solve(right);
  if (gapMM)
  {
    *gapMM = 0.0;
    if (lines.size() == 2)
    {
      const Eigen::Vector3d n = lines[0].second.cross(lines[1].second).normalized();
      *gapMM = std::abs(n.dot(lines[1].first - lines[0].first));
    }
  }
  return closest;
}

} // namespace xp
