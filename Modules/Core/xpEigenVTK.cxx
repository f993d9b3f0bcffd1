#include "xpEigenVTK.h"

#include <vtkMatrix4x4.h>

namespace xp
{

void ToVTK(const Eigen::Isometry3d& transform, vtkMatrix4x4* matrix)
{
  const Eigen::Matrix4d& m = transform.matrix();
  for (int r = 0; r < 4; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      matrix->SetElement(r, c, m(r, c));
    }
  }
}

Eigen::Isometry3d FromVTK(const vtkMatrix4x4* matrix)
{
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 4; ++c)
    {
      transform.matrix()(r, c) = matrix->GetElement(r, c);
    }
  }
  return transform;
}

} // namespace xp
