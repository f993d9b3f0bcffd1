#include "xpXRayView.h"

#include "xpError.h"

#include <Eigen/Geometry>

namespace xp
{

Eigen::Vector3d XRayView::PixelCenter(double col, double row) const
{
  return this->detectorCenter +
    (col - 0.5 * (this->size[0] - 1)) * this->pixelSpacing[0] * this->rowDirection +
    (row - 0.5 * (this->size[1] - 1)) * this->pixelSpacing[1] * this->columnDirection;
}

Eigen::Vector3d XRayView::NormalTowardsSource() const
{
  Eigen::Vector3d n = this->rowDirection.cross(this->columnDirection).normalized();
  if (n.dot(this->source - this->detectorCenter) < 0.0)
  {
    n = -n;
  }
  return n;
}

double XRayView::SourceToPanelDistance() const
{
  return std::abs(this->NormalTowardsSource().dot(this->source - this->detectorCenter));
}

Eigen::Vector2d XRayView::Project(const Eigen::Vector3d& roomPoint) const
{
  const Eigen::Vector3d n = this->NormalTowardsSource();
  const double sourceHeight = n.dot(this->source - this->detectorCenter);
  const double pointHeight = n.dot(roomPoint - this->detectorCenter);
  // The point must lie strictly between the source plane and the far side of the panel.
  if (!(pointHeight < sourceHeight - 1e-9))
  {
    throw Error("view " + this->name, "point is on or behind the source; it has no projection");
  }
  const double t = sourceHeight / (sourceHeight - pointHeight);
  const Eigen::Vector3d onPanel = this->source + t * (roomPoint - this->source);
  const Eigen::Vector3d d = onPanel - this->detectorCenter;
  return { d.dot(this->rowDirection) / this->pixelSpacing[0] + 0.5 * (this->size[0] - 1),
    d.dot(this->columnDirection) / this->pixelSpacing[1] + 0.5 * (this->size[1] - 1) };
}

Ray XRayView::PixelRay(double col, double row) const
{
  return { this->source, (this->PixelCenter(col, row) - this->source).normalized() };
}

std::optional<XRayView> XRayView::Binned(int columns, int rows) const
{
  if (columns <= 0 || rows <= 0 || columns > this->size[0] || rows > this->size[1] || this->size[0] % columns != 0 ||
    this->size[1] % rows != 0)
    return std::nullopt;
  return this->Resampled(columns, rows);
}

XRayView XRayView::Resampled(int columns, int rows) const
{
  if (columns <= 0 || rows <= 0)
  {
    throw InputError("view " + this->name, "output size must be positive");
  }
  XRayView view = *this;
  view.pixelSpacing[0] = this->pixelSpacing[0] * this->size[0] / columns;
  view.pixelSpacing[1] = this->pixelSpacing[1] * this->size[1] / rows;
  view.size = { columns, rows };
  return view;
}

} // namespace xp
