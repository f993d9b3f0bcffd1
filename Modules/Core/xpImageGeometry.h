/**
 * @file xpImageGeometry.h
 * @brief Where a vtkImageData's voxels are: the one place that reads origin, spacing,
 *        DirectionMatrix and extent together (stock VTK filters ignore the direction).
 */
#ifndef xpImageGeometry_h
#define xpImageGeometry_h

#include "vtkXPCoreModule.h"

#include <Eigen/Geometry>

class vtkImageData;

namespace xp
{

/** Memory index (i, j, k counted from the first stored voxel) -> physical mm (LPS for a CT). */
VTKXPCORE_EXPORT Eigen::Affine3d IndexToPhysical(vtkImageData* image);

/** Physical position of the centre of the voxel grid. */
VTKXPCORE_EXPORT Eigen::Vector3d ImageCenter(vtkImageData* image);

} // namespace xp

#endif
