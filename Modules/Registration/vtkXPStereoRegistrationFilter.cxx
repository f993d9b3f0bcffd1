#include "vtkXPStereoRegistrationFilter.h"

#include "vtkXPDRRFilter.h"
#include "xpBodyMask.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpCatchErrors.h"
#include "xpImageRows.h"
#include "xpRegistrationRecord.h"

#include <vtkCommand.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkDataArray.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <chrono>
#include <cmath>
#include <optional>

vtkStandardNewMacro(vtkXPStereoRegistrationFilter);

namespace
{
enum InputPort
{
  CTPort = 0,
  XRayPort = 1,
  ROIPort = 2
};
} // namespace

vtkXPStereoRegistrationFilter::vtkXPStereoRegistrationFilter()
{
  this->SetNumberOfInputPorts(3);
  this->SetNumberOfOutputPorts(0);
}

vtkXPStereoRegistrationFilter::~vtkXPStereoRegistrationFilter() = default;

void vtkXPStereoRegistrationFilter::RemoveAllXRaysAndROIs()
{
  this->SetInputConnection(XRayPort, nullptr);
  this->SetInputConnection(ROIPort, nullptr);
}

void vtkXPStereoRegistrationFilter::SetGeometry(const xp::StereoGeometry& geometry)
{
  this->Geometry = geometry;
  this->SetNumberOfOutputPorts(3 * static_cast<int>(geometry.views.size()));
  this->Modified();
}

void vtkXPStereoRegistrationFilter::SetPatientSetup(const xp::PatientSetup& setup)
{
  if (setup != this->Setup)
  {
    this->Setup = setup;
    this->Modified();
  }
}

void vtkXPStereoRegistrationFilter::SetSettings(const xp::StereoRegistrationSettings& settings)
{
  this->Settings = settings;
  this->Modified();
}

bool vtkXPStereoRegistrationFilter::ReadGeometry(const char* path)
{
  return xp::CatchErrors(this, this->LastError, [&]
    {
      const xp::StereoGeometry geometry = xp::ReadStereoGeometry(path ? path : "");
      xp::ValidateStereoGeometry(geometry, path);
      this->SetGeometry(geometry);
      xp::PatientSetup setup = this->Setup;
      setup.roomIsocenter = geometry.isocenter;
      this->SetPatientSetup(setup);
    });
}

bool vtkXPStereoRegistrationFilter::SetPatientPosition(const char* dicomPatientPosition)
{
  return xp::CatchErrors(this, this->LastError, [&]
    {
      xp::PatientSetup setup = this->Setup;
      setup.position = xp::ParsePatientPosition(dicomPatientPosition ? dicomPatientPosition : "", "patient position");
      this->SetPatientSetup(setup);
    });
}

void vtkXPStereoRegistrationFilter::SetIsocenterInCT(double x, double y, double z)
{
  xp::PatientSetup setup = this->Setup;
  setup.isocenterInCT = Eigen::Vector3d(x, y, z);
  this->SetPatientSetup(setup);
}

void vtkXPStereoRegistrationFilter::SetEntropyMask(bool on)
{
  if (on != this->Settings.entropyMask)
  {
    this->Settings.entropyMask = on;
    this->Modified();
  }
}

void vtkXPStereoRegistrationFilter::SetChooseTable(bool on)
{
  if (on != this->Settings.chooseTable)
  {
    this->Settings.chooseTable = on;
    this->Modified();
  }
}

void vtkXPStereoRegistrationFilter::SetResult(xp::StereoRegistrationResult result)
{
  this->Result = std::move(result);
  const std::array<double, 6> misalignment = this->Result.misalignment.Parameters();
  const std::array<double, 6> correction = this->Result.correction.Parameters();
  std::copy(misalignment.begin(), misalignment.end(), this->MisalignmentParameters);
  std::copy(correction.begin(), correction.end(), this->CorrectionParameters);
}

void vtkXPStereoRegistrationFilter::Refused(const std::string& message)
{
  xp::StereoRegistrationResult refused;
  refused.failures.push_back({ xp::GateCode::InvalidInput, -1, message });
  this->SetResult(std::move(refused));
}

std::string vtkXPStereoRegistrationFilter::GetResultJSON() const
{
  std::vector<std::string> names;
  for (const xp::XRayView& view : this->Geometry.views)
    names.push_back(view.name);
  return xp::RegistrationRecordJSON(xp::MakeRegistrationRecord(this->Result, names));
}

int vtkXPStereoRegistrationFilter::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port != CTPort)
    info->Set(vtkAlgorithm::INPUT_IS_REPEATABLE(), 1);
  if (port == ROIPort)
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  const int views = this->GetNumberOfOutputPorts() / 3;
  if (inputVector[XRayPort]->GetNumberOfInformationObjects() != views)
  {
    const std::string message = "the geometry has " + std::to_string(views) + " views; connect one X-ray each (got " +
      std::to_string(inputVector[XRayPort]->GetNumberOfInformationObjects()) + ")";
    this->Refused("X-ray inputs: " + message);
    vtkErrorMacro(<< message);
    return 0;
  }
  const int f = this->ShrinkFactor;
  for (int v = 0; v < views; ++v)
  {
    vtkInformation* in = inputVector[XRayPort]->GetInformationObject(v);
    int whole[6];
    double spacing[3], origin[3];
    in->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
    in->Get(vtkDataObject::SPACING(), spacing);
    in->Get(vtkDataObject::ORIGIN(), origin);
    // The registration grid: each pixel the mean of f x f X-ray pixels, centred on them.
    const int shrunk[6] = { 0, (whole[1] - whole[0] + 1) / f - 1, 0, (whole[3] - whole[2] + 1) / f - 1, 0, 0 };
    const double outSpacing[3] = { spacing[0] * f, spacing[1] * f, spacing[2] };
    const double outOrigin[3] = { origin[0] + spacing[0] * (whole[0] + 0.5 * (f - 1)),
      origin[1] + spacing[1] * (whole[2] + 0.5 * (f - 1)), origin[2] };
    for (int kind = 0; kind < 3; ++kind)
    {
      vtkInformation* out = outputVector->GetInformationObject(3 * v + kind);
      out->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), shrunk, 6);
      out->Set(vtkDataObject::SPACING(), outSpacing, 3);
      out->Set(vtkDataObject::ORIGIN(), outOrigin, 3);
      const int type[3] = { VTK_UNSIGNED_SHORT, VTK_UNSIGNED_CHAR, VTK_FLOAT };
      vtkDataObject::SetPointDataActiveScalarInfo(out, type[kind], 1);
    }
  }
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  for (int port = 0; port < this->GetNumberOfInputPorts(); ++port)
  {
    for (int c = 0; c < inputVector[port]->GetNumberOfInformationObjects(); ++c)
    {
      vtkInformation* info = inputVector[port]->GetInformationObject(c);
      int whole[6];
      info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
      info->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
    }
  }
  return 1;
}

void vtkXPStereoRegistrationFilter::CheckXRay(vtkImageData* xray, const xp::XRayView& panel, const std::string& what)
{
  int dims[3];
  xray->GetDimensions(dims);
  if (dims[0] != panel.Columns() || dims[1] != panel.Rows() || dims[2] != 1)
  {
    throw xp::InputError(what, "is " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " pixels, imager " +
        panel.name + " of the geometry has " + std::to_string(panel.Columns()) + "x" + std::to_string(panel.Rows()));
  }
  if (xray->GetScalarType() != VTK_UNSIGNED_SHORT || xray->GetNumberOfScalarComponents() != 1)
  {
    throw xp::InputError(what, "must hold one unsigned 16-bit sample per pixel (any bit depth up to 16)");
  }
}

std::vector<xp::RegistrationView> vtkXPStereoRegistrationFilter::PrepareViews(const xp::StereoGeometry& geometry,
  const std::vector<vtkImageData*>& xrays, const std::vector<vtkImageData*>& rois, int f, const std::vector<std::string>& names)
{
  const std::vector<xp::XRayView>& panels = geometry.views;
  if (xrays.size() != panels.size())
  {
    throw xp::InputError("X-ray inputs", "the geometry has " + std::to_string(panels.size()) + " imagers; give one X-ray each, in order (got " +
        std::to_string(xrays.size()) + ")");
  }
  if (!rois.empty() && rois.size() != panels.size())
  {
    throw xp::InputError("ROI inputs", "give none, or one per X-ray (" + std::to_string(panels.size()) + "), got " +
        std::to_string(rois.size()));
  }
  std::vector<xp::RegistrationView> views;
  std::vector<std::vector<uint16_t>> full; // the X-rays before shrinking, to tell them apart
  for (size_t v = 0; v < panels.size(); ++v)
  {
    const xp::XRayView& panel = panels[v];
    const std::string what = v < names.size() ? names[v] : "X-ray input " + std::to_string(v) + " (imager " + panel.name + ")";
    vtkImageData* xray = xrays[v];
    CheckXRay(xray, panel, what);
    if (panel.Columns() % f != 0 || panel.Rows() % f != 0)
    {
      throw xp::InputError("shrink factor", std::to_string(f) + " does not divide imager " + panel.name + "'s " +
          std::to_string(panel.Columns()) + "x" + std::to_string(panel.Rows()) + " pixels");
    }
    xp::RegistrationView item;
    item.view = panel.Resampled(panel.Columns() / f, panel.Rows() / f);
    item.xray = xp::RowsTopFirst<uint16_t>(xray);
    for (size_t earlier = 0; earlier < full.size(); ++earlier)
    {
      if (full[earlier] == item.xray)
        throw xp::InputError(what, "the X-ray of imager " + panel.name + " is the same image as " +
            (earlier < names.size() ? names[earlier] : "X-ray input " + std::to_string(earlier)) + " (imager " +
            panels[earlier].name + "): each imager needs its own X-ray");
    }
    full.push_back(item.xray);
    if (f > 1)
      item.xray = xp::ShrinkImage(item.xray, panel.Columns(), f);
    if (!rois.empty())
    {
      vtkImageData* roi = rois[v];
      int dims[3];
      roi->GetDimensions(dims);
      if (roi->GetScalarType() != VTK_UNSIGNED_CHAR || dims[0] != panel.Columns() || dims[1] != panel.Rows())
      {
        throw xp::InputError("ROI " + std::to_string(v) + " (imager " + panel.name + ")",
          "must be unsigned char with the X-ray's " + std::to_string(panel.Columns()) + "x" + std::to_string(panel.Rows()) +
            " pixels");
      }
      item.mask = xp::RowsTopFirst<uint8_t>(roi);
      for (uint8_t& m : item.mask)
        m = m ? 1 : 0;
      if (f > 1)
        item.mask = xp::ShrinkMask(item.mask, panel.Columns(), f);
    }
    views.push_back(std::move(item));
  }
  return views;
}

const xp::AttenuationVolume& vtkXPStereoRegistrationFilter::Attenuation(vtkImageData* ct)
{
  if (!this->Volume || ct != this->VolumeSource || ct->GetMTime() != this->VolumeTime || this->MuWater != this->VolumeMuWater)
  {
    this->Volume = xp::MakeAttenuationVolume(ct, this->MuWater);
    this->VolumeSource = ct;
    this->VolumeTime = ct->GetMTime();
    this->VolumeMuWater = this->MuWater;
  }
  return *this->Volume;
}

const xp::AttenuationVolume* vtkXPStereoRegistrationFilter::BodyAttenuation(vtkImageData* ct)
{
  if (ct != this->BodySource || ct->GetMTime() != this->BodyTime || this->MuWater != this->BodyMuWater)
  {
    // The body's voxels flagged, and its volume made from the CT's own HU with the rest as air:
    // no copy of the CT.
    xp::BodyVoxels body;
    try
    {
      body = xp::BodyOf(ct);
    }
    catch (const xp::InputError&)
    {
      body.tableVoxels = 0; // no body to tell a table from (a CT of air, a thin shell): nothing to choose
    }
    const double* spacing = ct->GetSpacing();
    this->TableCM3 = static_cast<double>(body.tableVoxels) * std::abs(spacing[0] * spacing[1] * spacing[2]) / 1000.0;
    this->BodyVolume = body.tableVoxels > 0 ? xp::MakeAttenuationVolume(ct, this->MuWater, &body.inBody) : nullptr;
    this->BodySource = ct;
    this->BodyTime = ct->GetMTime();
    this->BodyMuWater = this->MuWater;
  }
  return this->BodyVolume.get();
}

void vtkXPStereoRegistrationFilter::WriteOutputs(vtkInformationVector* outputVector)
{
  for (size_t v = 0; v < this->Geometry.views.size(); ++v)
  {
    const int port = 3 * static_cast<int>(v);
    const auto allocate = [&](int kind, int type)
    {
      vtkInformation* info = outputVector->GetInformationObject(port + kind);
      vtkImageData* out = vtkImageData::GetData(info);
      int whole[6];
      info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
      out->SetExtent(whole);
      out->AllocateScalars(type, 1);
      return out;
    };
    xp::CopyRowsTopFirst<uint16_t>(this->Result.drrs[v], allocate(0, VTK_UNSIGNED_SHORT));
    xp::CopyRowsTopFirst<uint8_t>(this->Result.masks[v], allocate(1, VTK_UNSIGNED_CHAR), 255);
    vtkImageData* entropy = allocate(2, VTK_FLOAT);
    if (this->Result.entropyMaps.empty())
      entropy->GetPointData()->GetScalars()->Fill(0.0);
    else
      xp::CopyRowsTopFirst<float>(this->Result.entropyMaps[v], entropy);
  }
}

int vtkXPStereoRegistrationFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    xp::ValidateStereoGeometry(this->Geometry, "registration geometry");
    if ((this->Setup.roomIsocenter - this->Geometry.isocenter).norm() > 1e-6)
    {
      throw xp::InputError("patient set-up: room isocentre", "differs from the geometry's isocentre");
    }
    std::vector<vtkImageData*> xrays, rois;
    for (int c = 0; c < inputVector[XRayPort]->GetNumberOfInformationObjects(); ++c)
      xrays.push_back(vtkImageData::GetData(inputVector[XRayPort], c));
    for (int c = 0; c < inputVector[ROIPort]->GetNumberOfInformationObjects(); ++c)
      rois.push_back(vtkImageData::GetData(inputVector[ROIPort], c));
    const std::vector<xp::RegistrationView> views = PrepareViews(this->Geometry, xrays, rois, this->ShrinkFactor);
    vtkImageData* ct = vtkImageData::GetData(inputVector[CTPort]);
    const xp::AttenuationVolume& volume = this->Attenuation(ct);
    const Eigen::Isometry3d planned = this->Setup.PlannedCTToRoom(xp::ImageCenter(ct));
    const xp::RegistrationObserver observer = [this](const xp::RegistrationProgress& progress)
    {
      this->LastObjective = progress.objective;
      if (progress.evaluations > 0)
        this->InvokeEvent(EvaluationEvent);
      this->SetProgressText(progress.stage.c_str());
      this->UpdateProgress(progress.fraction);
    };
    if (!this->Settings.chooseTable)
    {
      this->SetResult(xp::RegisterStereo(volume, planned, this->Geometry.isocenter, views, this->Settings, observer));
    }
    else
    {
      // The CT without its table pre-aligned, then both CTs compared near there on the views'
      // edges (the refinement's high-passed objective): the one whose DRRs match the X-rays better
      // is registered (xp::TableChoice); a tie keeps the body alone, which is what a room shows.
      // The CT with its table is compared where two rounds of the pre-alignment take it from there
      // (a table the X-rays show pulls the body alone's a little off; one they do not show pulls
      // the CT with it away), and is pre-aligned in full only when kept.
      xp::TableChoice choice;
      using Clock = std::chrono::steady_clock;
      const auto since = [](Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); };
      Clock::time_point start = Clock::now();
      // A bone cut out of a CT has no table; its registration matches the bone's shadow alone.
      const bool bone = this->Settings.detectBoneOnly && xp::OuterSurfaceIsBone(volume);
      const xp::AttenuationVolume* body = bone ? nullptr : this->BodyAttenuation(ct);
      choice.seconds = since(start);
      choice.tableCM3 = body ? this->TableCM3 : 0.0;
      std::optional<xp::StereoRegistrationInStages> bodyOnly;
      if (body)
      {
        bodyOnly.emplace(*body, planned, this->Geometry.isocenter, views, this->Settings, observer);
        const xp::PreAlignedCT aligned = bodyOnly->PreAlign();
        choice.bodyOnly = aligned.highPassedObjective;
        start = Clock::now();
        choice.withTable = bodyOnly->HighPassedObjectiveOf(volume, aligned.prealignment.pose, 2);
        choice.seconds += since(start);
        choice.keptTable = choice.withTable > choice.bodyOnly;
      }
      xp::StereoRegistrationResult result;
      if (choice.keptTable)
      {
        xp::StereoRegistrationInStages withTable(volume, planned, this->Geometry.isocenter, views, this->Settings, observer);
        withTable.PreAlign();
        result = withTable.Finish();
      }
      else
        result = bodyOnly->Finish();
      result.table = choice;
      this->SetResult(std::move(result));
    }
    this->WriteOutputs(outputVector);
  }
  catch (const xp::Error& e)
  {
    this->Refused(e.what());
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPStereoRegistrationFilter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Geometry: " << this->Geometry.name << " (" << this->Geometry.views.size() << " views)\n";
  os << indent << "PatientSetup: " << this->Setup.Describe() << "\n";
  os << indent << "MuWater: " << this->MuWater << "\n";
  os << indent << "ShrinkFactor: " << this->ShrinkFactor << "\n";
  os << indent << "EntropyMask: " << this->Settings.entropyMask << ", bins " << this->Settings.bins
     << ", max evaluations " << this->Settings.maxEvaluations << "\n";
  os << indent << "Result: " << (this->Result.ok ? "ok" : "failed or not run") << ", " << this->Result.misalignment.ToString() << "\n";
}
