/**
 * @file xpGlobalSearch.h
 * @brief Starting poses for a registration that has none: a small bone somewhere in a large
 *        field, in an orientation nobody measured (biplane videoradiography).
 *
 * The volume is turned through a grid of orientations (its slice axis along a near-uniform set
 * of directions, spun about it in the same steps); at each, its DRR in each view is matched over
 * the whole X-ray by normalised cross-correlation over the DRR's shadow and a rim around it, both
 * images high-passed (a limb's shading and an image intensifier's bands go), at about 200 pixels
 * across; both polarities are tried, and the one whose best match scores higher is the X-rays'. The best places of the two views
 * are joined into a 3D position by their rays' closest approach; pairs whose rays pass far
 * apart do not show one object. The best of them are refined on the same correlation, the pose
 * free, and the best-scoring distinct poses are the candidates, best first: the first is the
 * start for the registration, and its gate judges where that ends.
 */
#ifndef xpGlobalSearch_h
#define xpGlobalSearch_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpPose.h"
#include "xpStereoSimilarity.h"

#include <vector>

namespace xp
{

struct GlobalSearchSettings
{
  double angleStepDegrees = 20.0; ///< between neighbouring orientations
  int workingColumns = 200;       ///< the images are shrunk to about this width
  int peaksPerView = 3;           ///< places kept per view and orientation
  double maxRaysApartMM = 10.0;   ///< a pair's rays must pass this close
  int refined = 30;               ///< the grid's best, each refined on the correlation
  int candidates = 5;             ///< distinct refined poses returned
  /** Candidates closer than this (mm and degrees) are one. */
  double distinctMM = 10.0, distinctDegrees = 20.0;
  /** The shadow of the faces where the crop cut the bone, and 5 mm about it, leave the templates
   *  (xpBoneCut.h). */
  bool leaveOutCuts = true;
};

struct GlobalCandidate
{
  Pose pose;               ///< a misalignment, about the isocentre, as StereoRegistrationSettings::initialPose
  double score = 0.0;      ///< mean correlation of the views (at most 1)
  double raysApartMM = 0.0;
};

/**
 * The candidates, best first. `views` hold the X-rays as they came and their ROIs (empty =
 * all); `ctCenterInRoom` is the volume's centre at the planned set-up.
 */
VTKXPREGISTRATION_EXPORT std::vector<GlobalCandidate> FindGlobalStarts(const AttenuationVolume& volume,
  const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& isocenter, const Eigen::Vector3d& ctCenterInRoom,
  const std::vector<RegistrationView>& views, const GlobalSearchSettings& settings = {});

/** Rotations on a near-uniform grid `stepDegrees` apart: a Fibonacci set of directions for the
 *  slice axis, each spun about itself in the same steps. */
VTKXPREGISTRATION_EXPORT std::vector<Eigen::Matrix3d> OrientationGrid(double stepDegrees);

} // namespace xp

#endif
