/**
 * @file xpRegistrationSources.h
 * @brief Where a registration's inputs come from when they are files, and those inputs read and
 *        checked once: the CT, the geometry, one X-ray per imager, their ROIs.
 *
 * `xpose register`, `track` and `listen` fill RegistrationSources from their options, `report`
 * from a result.json's record, Python from the session's setters. Every refusal is an
 * xp::InputError naming the file or the option, raised before any registration work.
 */
#ifndef xpRegistrationSources_h
#define xpRegistrationSources_h

#include "vtkXPSessionModule.h"

#include "vtkXPDRRFilter.h"
#include "xpAttenuationVolume.h"
#include "xpCTVolume.h"
#include "xpFieldOfView.h"
#include "xpRegistrationRecord.h"
#include "xpStereoGeometry.h"
#include "xpStereoSimilarity.h"

#include <Eigen/Geometry>
#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <array>
#include <string>
#include <vector>

namespace xp
{

/** The treatment couch and target as the options give them (register, track, listen, Python):
 *  each overrides the geometry file's couch (Coordinates.md, "The couch"). */
struct CouchOptions
{
  std::string motions;       ///< --couch 6dof|4dof; empty: the geometry file's (6dof, unlimited, without one)
  std::string rotationLimit; ///< --couch-rotation-limit DEG (pitch and roll, each way); empty: the geometry's
  std::optional<Eigen::Vector3d> target; ///< --target, the CT's LPS mm; none: the planned isocentre
  ActionLevels levels;       ///< --action-level-mm/-deg, --max-uncorrected-mm/-deg
};

/** A registration's input files and how to read them (RegistrationFiles, which result.json's
 *  `inputs` records), and the couch that carries out its result. */
struct RegistrationSources : RegistrationFiles
{
  CouchOptions couch;               ///< the couch that carries out an ok result, and the target
};

/** A CT and geometry read, and one DRR filter placed like the CT (its view set per imager). */
struct DRRSetup
{
  CTVolume ct;
  StereoGeometry geometry;
  PatientSetup patient;
  vtkSmartPointer<vtkXPDRRFilter> filter;
};

/**
 * Reads the geometry and the CT and configures one DRR filter (view set later per imager).
 * `isocenterInCT`: the CT point (LPS mm) at the isocentre, none for the CT centre; `method`
 * trilinear|siddon; `voxelSize` (mm) for a TIFF volume (--voxel-size), else none.
 */
VTKXPSESSION_EXPORT DRRSetup MakeDRRSetup(const std::string& ctPath, const std::string& series,
  const std::optional<Eigen::Vector3d>& voxelSize, const std::string& geometryPath,
  const std::optional<Eigen::Vector3d>& isocenterInCT, double muWater, const std::string& method, double stepSize);

/** What a registration needs, read from its sources and checked. */
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
  long long tableVoxelsRemoved = 0;       ///< with removeTable: voxels outside the body set to air
  /** Per X-ray: the image intensifier's circular field found in it (xpFieldOfView.h), whose
   *  outside is left out of the ROI. */
  std::vector<CircularField> fields;
  /** Per X-ray: the binning of its imager's panel it was read out with ({1, 1}: the whole panel);
   *  setup.geometry's views are then the binned panels (PanelOfXRay). */
  std::vector<std::array<int, 2>> binning;
  std::vector<XRayView> panels;           ///< the geometry's imagers as its file gives them (not binned)
  CouchDescription couch;                 ///< the geometry's couch with the options' overrides
  Eigen::Vector3d targetInCT = Eigen::Vector3d::Zero(); ///< LPS mm: the treatment target (default isoInCT)
  ActionLevels actionLevels;
};

/**
 * The panel an X-ray of imager `panel` was read out on: the panel itself, or the panel binned to
 * the X-ray's size when that divides it by a whole factor per axis (the extent kept, the spacing
 * scaled). Any other size, or a DICOM X-ray whose own pixel spacing disagrees with the binning,
 * throws xp::InputError naming `file` and both sizes (or the tag).
 */
VTKXPSESSION_EXPORT XRayView PanelOfXRay(const XRayView& panel, vtkImageData* xray, const std::string& file,
  const Eigen::Vector3d& isocenter, PatientPosition position);

/** The couch of `geometry` (6dof without limits about the isocentre when it has none) with the
 *  options' overrides; throws xp::InputError naming --couch or --couch-rotation-limit. */
VTKXPSESSION_EXPORT CouchDescription ResolveCouch(const StereoGeometry& geometry, const CouchOptions& options);

/** The treatment target in the CT's LPS mm: `target` or, when none, `isoInCT`; throws
 *  xp::InputError naming --target for a point outside the CT's grid. */
VTKXPSESSION_EXPORT Eigen::Vector3d ResolveTarget(
  const std::optional<Eigen::Vector3d>& target, vtkImageData* ct, const Eigen::Vector3d& isoInCT);

/**
 * The whole factor by which `size` (columns, rows; none = 1) divides every panel; throws
 * xp::InputError naming --size when it does not.
 */
VTKXPSESSION_EXPORT int RegistrationShrinkFactor(const std::vector<XRayView>& panels, const std::optional<Eigen::Vector2i>& size);

/** Reads and checks the CT, geometry, X-rays and ROIs of `sources`; throws xp::InputError naming
 *  the file or option. */
VTKXPSESSION_EXPORT RegistrationInputs ReadRegistrationInputs(const RegistrationSources& sources);

/** The X-ray half of ReadRegistrationInputs: reads and checks the X-rays and ROIs of `sources`
 *  into `inputs`, whose CT and geometry are read (a tracked frame's new X-rays, the CT kept). */
VTKXPSESSION_EXPORT void ReadXRayInputs(const RegistrationSources& sources, RegistrationInputs& inputs);

} // namespace xp

#endif
