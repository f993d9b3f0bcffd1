#include "xpRegistrationSources.h"

#include "vtkXPStereoRegistrationFilter.h"
#include "xpBodyMask.h"
#include "xpDICOMXRay.h"
#include "xpXRayGeometryTags.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpSessionOptions.h"
#include "xpVolumeIO.h"

#include <algorithm>
#include <cstdio>
#include <limits>

namespace xp
{

DRRSetup MakeDRRSetup(const std::string& ctPath, const std::string& series, const std::optional<Eigen::Vector3d>& voxelSize,
  const std::string& geometryPath, const std::optional<Eigen::Vector3d>& isocenterInCT, double muWater, const std::string& method,
  double stepSize)
{
  if (method != "trilinear" && method != "siddon")
  {
    throw InputError("--method", "expected trilinear or siddon, got '" + method + "'");
  }
  if (!(muWater > 0.0 && muWater < 1.0))
  {
    throw InputError("--mu-water", "must be between 0 and 1 per mm");
  }
  if (stepSize != 0.0)
  {
    CheckLimit(stepSize, 0.01, 100.0, "--step");
  }
  DRRSetup setup;
  setup.geometry = ReadStereoGeometry(geometryPath); // geometry first: cheap to check
  setup.ct = ReadCTVolume(ctPath, series,
    voxelSize ? std::array<double, 3>{ (*voxelSize)[0], (*voxelSize)[1], (*voxelSize)[2] } : std::array<double, 3>{});
  // Steps far below a voxel add nothing but time (1e-9 mm ran without end): bound the work.
  double spacing[3];
  setup.ct.image->GetSpacing(spacing);
  const double voxel = std::min({ spacing[0], spacing[1], spacing[2] });
  if (stepSize != 0.0 && stepSize < voxel / 16.0)
  {
    throw InputError("--step", std::to_string(stepSize) + " mm is finer than 1/16 of the smallest voxel (" +
        std::to_string(voxel) + " mm): it would multiply the time and change nothing");
  }
  setup.filter = vtkSmartPointer<vtkXPDRRFilter>::New();
  setup.filter->SetInputData(setup.ct.image);
  setup.patient.position = ParsePatientPosition(setup.ct.patientPosition, ctPath);
  setup.patient.roomIsocenter = setup.geometry.isocenter;
  setup.patient.isocenterInCT = isocenterInCT;
  setup.filter->SetPatientSetup(setup.patient);
  setup.filter->SetMuWater(muWater);
  setup.filter->SetMethod(method == "siddon" ? 1 : 0);
  setup.filter->SetStepSize(stepSize);
  return setup;
}

int RegistrationShrinkFactor(const std::vector<XRayView>& panels, const std::optional<Eigen::Vector2i>& size)
{
  if (!size)
    return 1;
  const int columns = (*size)[0], rows = (*size)[1];
  const int factor = panels[0].Columns() / columns;
  for (const XRayView& panel : panels)
  {
    if (factor < 1 || panel.Columns() != columns * factor || panel.Rows() != rows * factor)
    {
      throw InputError("--size", SizeText(*size) + " must divide imager " + panel.name + "'s " + std::to_string(panel.Columns()) + "x" +
          std::to_string(panel.Rows()) + " pixels by a whole number");
    }
  }
  return factor;
}

RegistrationInputs ReadRegistrationInputs(const RegistrationSources& sources)
{
  // The couch options' own words, before any file is read (the target needs the CT).
  sources.couch.levels.Validate();
  ResolveCouch(StereoGeometry{}, sources.couch);
  RegistrationInputs inputs;
  inputs.setup = MakeDRRSetup(sources.ct, sources.series, sources.voxelSize, sources.geometry, sources.isocenterInCT, sources.muWater,
    "trilinear", 0.0);
  if (sources.removeTable)
  {
    // The CT's table is not the treatment couch: render from the body alone.
    inputs.setup.ct.image = BodyOnly(inputs.setup.ct.image, {}, &inputs.tableVoxelsRemoved);
    inputs.setup.filter->SetInputData(inputs.setup.ct.image);
  }
  ValidateStereoGeometry(inputs.setup.geometry, sources.geometry);
  inputs.panels = inputs.setup.geometry.views;
  ReadXRayInputs(sources, inputs);
  vtkImageData* ct = inputs.setup.ct.image;
  inputs.isoInCT = inputs.setup.patient.IsocenterInCT(ImageCenter(ct));
  inputs.planned = inputs.setup.patient.PlannedCTToRoom(ImageCenter(ct));
  inputs.couch = ResolveCouch(inputs.setup.geometry, sources.couch);
  inputs.targetInCT = ResolveTarget(sources.couch.target, ct, inputs.isoInCT);
  inputs.actionLevels = sources.couch.levels;
  return inputs;
}

void ReadXRayInputs(const RegistrationSources& sources, RegistrationInputs& inputs)
{
  // Each X-ray's panel is found anew from the imager's own (a later frame may be binned otherwise).
  inputs.setup.geometry.views = inputs.panels;
  inputs.xrays.clear();
  inputs.rois.clear();
  inputs.binning.clear();
  inputs.fields.clear();
  if (sources.xrays.size() != inputs.setup.geometry.views.size())
  {
    throw InputError("--xray", "the geometry has " + std::to_string(inputs.setup.geometry.views.size()) +
        " imagers; give one X-ray each, in order (got " + std::to_string(sources.xrays.size()) + ")");
  }
  if (!sources.rois.empty() && sources.rois.size() != inputs.setup.geometry.views.size())
  {
    throw InputError("--roi", "give one ROI per X-ray, in the same order");
  }
  // --size must divide the whole panels (then binned ones too, checked below): refused before
  // any X-ray is read.
  RegistrationShrinkFactor(inputs.setup.geometry.views, sources.size);
  // Each X-ray's own panel: the imager's, or the imager's read out binned (xpose's own RT Images
  // at --size, a room's 2x2 readout), whose pixels the registration then works in.
  std::vector<vtkImageData*> xrays, rois;
  for (size_t v = 0; v < sources.xrays.size(); ++v)
  {
    inputs.xrays.push_back(ReadXRayImage(sources.xrays[v]));
    xrays.push_back(inputs.xrays.back());
    XRayView& panel = inputs.setup.geometry.views[v];
    const std::array<int, 2> whole{ panel.Columns(), panel.Rows() };
    panel = PanelOfXRay(panel, xrays[v], sources.xrays[v], inputs.setup.geometry.isocenter, inputs.setup.patient.position);
    inputs.binning.push_back({ whole[0] / panel.Columns(), whole[1] / panel.Rows() });
  }
  const DRRSetup& setup = inputs.setup;
  const std::vector<XRayView>& panels = setup.geometry.views;
  inputs.shrinkFactor = RegistrationShrinkFactor(panels, sources.size);
  for (size_t v = 0; v < panels.size() && !sources.rois.empty(); ++v)
  {
    inputs.rois.push_back(ReadMaskPNG(sources.rois[v], panels[v].Columns(), panels[v].Rows()));
    rois.push_back(inputs.rois.back());
  }
  // An image intensifier's black corners are no anatomy: its disc joins the ROI.
  bool anyField = false;
  for (size_t v = 0; v < panels.size(); ++v)
  {
    inputs.fields.push_back(FindCircularField(RowsTopFirst<uint16_t>(xrays[v]), panels[v].Columns(), panels[v].Rows()));
    anyField = anyField || inputs.fields.back().found;
  }
  if (anyField)
  {
    for (size_t v = 0; v < panels.size(); ++v)
    {
      std::vector<uint8_t> roi = rois.empty() ? std::vector<uint8_t>(static_cast<size_t>(panels[v].Columns()) * panels[v].Rows(), 1)
                                              : RowsTopFirst<uint8_t>(rois[v]);
      const CircularField& field = inputs.fields[v];
      for (size_t i = 0; field.found && i < roi.size(); ++i)
        roi[i] &= field.mask[i];
      if (static_cast<size_t>(v) < inputs.rois.size())
        inputs.rois[v] = ImageFromRowsTopFirst(roi, panels[v].Columns(), panels[v].Rows());
      else
        inputs.rois.push_back(ImageFromRowsTopFirst(roi, panels[v].Columns(), panels[v].Rows()));
    }
    rois.clear();
    for (const auto& roi : inputs.rois)
      rois.push_back(roi);
  }
  // The registration filter's own checks, here before any work and naming the files.
  inputs.views = vtkXPStereoRegistrationFilter::PrepareViews(setup.geometry, xrays, rois, inputs.shrinkFactor, sources.xrays);
}

XRayView PanelOfXRay(const XRayView& panel, vtkImageData* xray, const std::string& file, const Eigen::Vector3d& isocenter,
  PatientPosition position)
{
  int dims[3];
  xray->GetDimensions(dims);
  if (dims[0] == panel.Columns() && dims[1] == panel.Rows())
    return panel;
  const std::optional<XRayView> binned = panel.Binned(dims[0], dims[1]);
  if (!binned)
    throw InputError(file, "is " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " pixels; imager " + panel.name +
        " of the geometry has " + std::to_string(panel.Columns()) + "x" + std::to_string(panel.Rows()) +
        ": an X-ray must have its panel's size or divide it by a whole factor per axis (read out binned)");
  // A DICOM X-ray's own pixel spacing decides between binning and another panel: it must agree.
  for (const std::string& difference : XRayTagDisagreements(file, *binned, isocenter, ToString(position), XRayTagSubset::PixelSpacing))
    throw InputError(file, "read as imager " + panel.name + "'s panel binned " + std::to_string(panel.Columns() / dims[0]) + "x" +
        std::to_string(panel.Rows() / dims[1]) + ", but its tags disagree: " + difference);
  return *binned;
}

CouchDescription ResolveCouch(const StereoGeometry& geometry, const CouchOptions& options)
{
  CouchDescription couch = geometry.couch.value_or(CouchDescription{});
  if (!options.motions.empty())
    couch.motions = ParseCouchMotions(options.motions, "--couch");
  if (!options.rotationLimit.empty())
  {
    size_t used = 0;
    double limit = std::numeric_limits<double>::quiet_NaN();
    try
    {
      limit = std::stod(options.rotationLimit, &used);
    }
    catch (const std::exception&)
    {
      used = 0;
    }
    if (used != options.rotationLimit.size() || !(limit >= 0.0 && limit <= 180.0))
      throw InputError("--couch-rotation-limit", "expected degrees from 0 to 180 (pitch and roll, each way), got '" +
          options.rotationLimit + "'");
    couch.pitchRollLimitDegrees = limit;
  }
  couch.Validate("--couch-rotation-limit");
  return couch;
}

Eigen::Vector3d ResolveTarget(const std::optional<Eigen::Vector3d>& given, vtkImageData* ct, const Eigen::Vector3d& isoInCT)
{
  if (!given)
    return isoInCT;
  const Eigen::Vector3d& target = *given;
  // Inside the CT's grid: the voxels' centres span it, half a voxel more each way.
  const Eigen::Vector3d index = IndexToPhysical(ct).inverse() * target;
  int dimensions[3];
  ct->GetDimensions(dimensions);
  for (int axis = 0; axis < 3; ++axis)
    if (!(index[axis] >= -0.5 && index[axis] <= dimensions[axis] - 0.5))
    {
      char where[160];
      std::snprintf(where, sizeof where, "(%.1f, %.1f, %.1f) mm is outside the CT (index %.1f, %.1f, %.1f of %dx%dx%d)",
        target[0], target[1], target[2], index[0], index[1], index[2], dimensions[0], dimensions[1], dimensions[2]);
      throw InputError("--target", where);
    }
  return target;
}

} // namespace xp
