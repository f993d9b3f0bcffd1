/**
 * @file xpRoomScene.h
 * @brief The treatment room in 3D: both sources and panels, the beams' central rays and edges,
 *        the isocentre, and the CT's bone at the planned pose and at the estimated pose.
 */
#ifndef xpRoomScene_h
#define xpRoomScene_h

#include "vtkXPReportingModule.h"

#include "xpPose.h"
#include "xpStereoGeometry.h"

#include <vtkImageData.h>
#include <vtkPolyData.h>
#include <vtkSmartPointer.h>

namespace xp
{

class VTKXPREPORTING_EXPORT RoomScene
{
public:
  explicit RoomScene(const StereoGeometry& geometry);

  /**
   * The bone surface of a CT (HU, any scalar type) at `boneHU`, from a copy shrunk to at most
   * about 128 voxels a side, placed in the Room by `plannedCTToRoom` (Coordinates.md).
   */
  void SetCT(vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom, double boneHU = 200.0);
  /** The pose found: the bone is drawn at the planned pose (grey, translucent) and moved by this. */
  void SetMisalignment(const Pose& misalignment) { this->Misalignment = misalignment; }

  /** The bone surface in Room coordinates at the planned pose (empty before SetCT). */
  vtkPolyData* GetBoneSurface() const { return this->Bone; }

  /**
   * Renders the scene off-screen (RGB, row 0 at the top, as displayed) with a legend. Needs an
   * X display: call VirtualDisplay::Ensure() first.
   */
  vtkSmartPointer<vtkImageData> Render(int width, int height) const;

private:
  StereoGeometry Geometry;
  vtkSmartPointer<vtkPolyData> Bone;
  Pose Misalignment;
};

} // namespace xp

#endif
