#include "xpImageGeometry.h"

#include <vtkImageData.h>
#include <vtkMatrix4x4.h>

namespace xp
{

Eigen::Affine3d IndexToPhysical(vtkImageData* image)
{
  Eigen::Affine3d transform = Eigen::Affine3d::Identity();
  vtkMatrix4x4* m = image->GetIndexToPhysicalMatrix();
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      transform.matrix()(r, c) = m->GetElement(r, c);
    }
  }
  // VTK's matrix maps structured indices, which start at the extent's first value.
  int extent[6];
  image->GetExtent(extent);
  return transform * Eigen::Translation3d(extent[0], extent[2], extent[4]);
}

Eigen::Vector3d ImageCenter(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  return IndexToPhysical(image) * (0.5 * Eigen::Vector3d(dims[0] - 1, dims[1] - 1, dims[2] - 1));
}

} // namespace xp
