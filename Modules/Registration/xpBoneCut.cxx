#include "xpBoneCut.h"

#include "xpError.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>

namespace xp
{

namespace
{

/** A cut face's bone layer holds at least this share of the largest layer along its axis (a box
 *  touches a rounded end in a few voxels) ... */
constexpr double MinCutShare = 0.05;
/** ... and at least this share of the layer CutDepth voxels inwards. */
constexpr double MinCutRatio = 0.6;
constexpr int CutDepth = 3;

} // namespace

std::vector<Eigen::Vector3d> CutFacePoints(const AttenuationVolume& volume)
{
  const Eigen::Vector3i& dims = volume.Dimensions();
  const Eigen::Vector3i& origin = volume.StoredOrigin();
  const Eigen::Vector3i stored = volume.StoredDimensions();
  std::vector<Eigen::Vector3d> points;
  if ((stored.array() <= 0).any())
    return points;
  for (int axis = 0; axis < 3; ++axis)
  {
    // Non-air voxels per layer along this axis (stored box coordinates).
    std::vector<long long> layer(stored[axis], 0);
    for (int k = 0; k < stored[2]; ++k)
      for (int j = 0; j < stored[1]; ++j)
        for (int i = 0; i < stored[0]; ++i)
          if (volume.StoredAt(i, j, k) > 0.0f)
            ++layer[std::array<int, 3>{ i, j, k }[axis]];
    const long long largest = *std::max_element(layer.begin(), layer.end());
    for (int side = 0; side < 2; ++side)
    {
      // The bone's last layer towards this face, and the one a few voxels inwards: a rounded end
      // closes towards the face (the metacarpal's base: 158 voxels after 601 three layers in), a
      // cut leaves its cross-section as it was (the radius's shaft: 552 after 646).
      // Only where the bone reaches the volume's own face: a flat part inside the box is anatomy.
      const int at = side == 0 ? 0 : stored[axis] - 1;
      const int inwards = side == 0 ? std::min(CutDepth, stored[axis] - 1) : std::max(0, stored[axis] - 1 - CutDepth);
      const bool onFace = side == 0 ? origin[axis] == 0 : origin[axis] + stored[axis] == dims[axis];
      if (!onFace || largest == 0 || layer[at] < MinCutShare * largest || layer[at] < MinCutRatio * layer[inwards])
        continue;
      for (int k = 0; k < stored[2]; ++k)
        for (int j = 0; j < stored[1]; ++j)
          for (int i = 0; i < stored[0]; ++i)
          {
            const Eigen::Vector3i index(i, j, k);
            if (index[axis] == at && volume.StoredAt(i, j, k) > 0.0f)
              points.push_back(volume.IndexToCT() * (origin + index).cast<double>());
          }
    }
  }
  return points;
}

void LeaveOutAroundPoints(uint8_t* mask, const XRayView& view, const std::vector<Eigen::Vector3d>& points,
  const Eigen::Isometry3d& ctToRoom, double radiusMM)
{
  if (points.empty())
    return;
  cv::Mat wrapped(view.Rows(), view.Columns(), CV_8U, mask);
  const int radius = std::max(1, static_cast<int>(std::lround(radiusMM / std::min(view.pixelSpacing[0], view.pixelSpacing[1]))));
  for (const Eigen::Vector3d& point : points)
  {
    const Eigen::Vector2d at = view.Project(ctToRoom * point);
    if (std::isfinite(at.x()) && std::isfinite(at.y()) && std::abs(at.x()) < 1e6 && std::abs(at.y()) < 1e6)
      cv::circle(wrapped, cv::Point(static_cast<int>(std::lround(at.x())), static_cast<int>(std::lround(at.y()))), radius,
        cv::Scalar(0), cv::FILLED);
  }
}

void LeaveOutAroundPoints(std::vector<uint8_t>& mask, const XRayView& view, const std::vector<Eigen::Vector3d>& points,
  const Eigen::Isometry3d& ctToRoom, double radiusMM)
{
  const size_t pixels = static_cast<size_t>(view.Columns()) * view.Rows();
  if (mask.empty())
    mask.assign(pixels, 1);
  if (mask.size() != pixels)
    throw InputError("view " + view.name, "the mask does not match the panel");
  LeaveOutAroundPoints(mask.data(), view, points, ctToRoom, radiusMM);
}

} // namespace xp
