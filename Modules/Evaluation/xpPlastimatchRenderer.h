/**
 * @file xpPlastimatchRenderer.h
 * @brief Line integrals of a CT from `plastimatch drr` (Debian's plastimatch, exact Siddon): X-ray
 *        images from a renderer the project did not write, for `xpose evaluate --scenario
 *        plastimatch`.
 *
 * The CT is written once as a MetaImage in its own voxel frame (index x spacing, no direction),
 * and each view's source and panel are carried into that frame through the misaligned set-up, so
 * the CT itself is never resampled: plastimatch sees the patient exactly where the pose puts it.
 */
#ifndef xpPlastimatchRenderer_h
#define xpPlastimatchRenderer_h

#include "vtkXPEvaluationModule.h"

#include "xpPose.h"
#include "xpXRayView.h"

#include <Eigen/Geometry>

#include <string>
#include <vector>

class vtkImageData;

namespace xp
{

class VTKXPEVALUATION_EXPORT PlastimatchRenderer
{
public:
  /** Throws xp::InputError when plastimatch is not installed or the CT cannot be written. */
  PlastimatchRenderer(vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomIsocenter);
  ~PlastimatchRenderer();
  PlastimatchRenderer(const PlastimatchRenderer&) = delete;
  PlastimatchRenderer& operator=(const PlastimatchRenderer&) = delete;

  /** plastimatch's line integrals (mu in 1/mm times mm, from its own HU -> attenuation; water
   *  0.0218 / mm) of one view at a misalignment,
   *  row 0 at the top, view.Columns() per row. Throws xp::Error when plastimatch fails. */
  std::vector<float> LineIntegrals(const XRayView& view, const Pose& misalignment) const;

  /** Whether `plastimatch` is on the PATH. */
  static bool Available();

private:
  std::string Folder;
  Eigen::Affine3d VoxelFrameToCT; ///< the written file's frame (index x spacing) -> CT mm
  Eigen::Isometry3d Planned;
  Eigen::Vector3d Isocenter;
};

/** Reads a PFM file (grey, "Pf"): rows as stored (PFM's first row is the image's bottom). */
VTKXPEVALUATION_EXPORT std::vector<float> ReadPFM(const std::string& path, int& columns, int& rows);

} // namespace xp

#endif
