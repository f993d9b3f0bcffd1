// The inputs of a registration, read and checked once for `register` and `report` (internal).
#ifndef xpRegistrationInputs_h
#define xpRegistrationInputs_h

#include "xpFieldOfView.h"
#include "xpCommands.h"
#include "xpDRRSetup.h"

#include "xpStereoSimilarity.h"

#include <Eigen/Geometry>
#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <vector>

namespace xp
{

struct RegistrationInputs
{
  DRRSetup setup;                         ///< CT, geometry, and a DRR filter placed like the CT
  std::vector<vtkSmartPointer<vtkImageData>> xrays; ///< as read, the panels' size
  std::vector<vtkSmartPointer<vtkImageData>> rois;  ///< none, or one per X-ray
  int shrinkFactor = 1;                   ///< --size: the panels' pixels per registration pixel
  /** The X-rays and ROIs as the registration filter prepares them (at the registration size). */
  std::vector<RegistrationView> views;
  Eigen::Vector3d isoInCT = Eigen::Vector3d::Zero();
  Eigen::Isometry3d planned = Eigen::Isometry3d::Identity(); ///< CT (LPS) -> Room, planned set-up
  long long tableVoxelsRemoved = 0;       ///< with --remove-table: voxels outside the body set to air
  /** Per X-ray: the image intensifier's circular field found in it (xpFieldOfView.h), whose
   *  outside is left out of the ROI. */
  std::vector<CircularField> fields;
};

/**
 * The whole factor by which `size` ("COLSxROWS", empty = 1) divides every panel; throws
 * xp::InputError naming --size when it does not.
 */
int RegistrationShrinkFactor(const std::vector<XRayView>& panels, const std::string& size);

/** Reads the CT, geometry, X-rays and ROIs of `options`; throws xp::InputError naming the file or option. */
RegistrationInputs LoadRegistrationInputs(const RegisterOptions& options);

} // namespace xp

#endif
