/**
 * @file xpEigenVTK.h
 * @brief Conversions between Eigen transforms and vtkMatrix4x4 (the only place they meet).
 */
#ifndef xpEigenVTK_h
#define xpEigenVTK_h

#include "vtkXPCoreModule.h"

#include <Eigen/Geometry>

class vtkMatrix4x4;

namespace xp
{

VTKXPCORE_EXPORT void ToVTK(const Eigen::Isometry3d& transform, vtkMatrix4x4* matrix);
VTKXPCORE_EXPORT Eigen::Isometry3d FromVTK(const vtkMatrix4x4* matrix);

} // namespace xp

#endif
