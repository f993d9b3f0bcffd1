#include "xpRegistrationSession.h"

#include "vtkXPStereoRegistrationFilter.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"

#include <chrono>
#include <filesystem>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

} // namespace

RegistrationSession::RegistrationSession(const RegistrationSources& sources)
  : Given(sources)
  , Registration(vtkSmartPointer<vtkXPStereoRegistrationFilter>::New())
{
  const Clock::time_point start = Clock::now();
  this->Read = ReadRegistrationInputs(sources);
  this->SecondsToRead = Since(start);
  this->SetUpFilter();
}

RegistrationSession::RegistrationSession(
  vtkImageData* ct, const PatientSetup& patient, const StereoGeometry& geometry, double muWater)
  : Registration(vtkSmartPointer<vtkXPStereoRegistrationFilter>::New())
{
  this->Given.muWater = muWater;
  this->Read.setup.ct.image = ct;
  this->Read.setup.geometry = geometry;
  this->Read.setup.patient = patient;
  this->Read.isoInCT = patient.IsocenterInCT(ImageCenter(ct));
  this->Read.planned = patient.PlannedCTToRoom(ImageCenter(ct));
  this->Read.couch = geometry.couch.value_or(CouchDescription{});
  this->Read.targetInCT = this->Read.isoInCT;
  this->SetUpFilter();
}

void RegistrationSession::SetUpFilter()
{
  vtkXPStereoRegistrationFilter* registration = this->Registration;
  registration->SetCTData(this->Read.setup.ct.image);
  registration->SetGeometry(this->Read.setup.geometry);
  registration->SetPatientSetup(this->Read.setup.patient);
  registration->SetMuWater(this->Given.muWater);
  registration->SetShrinkFactor(this->Read.shrinkFactor);
  // Read from files, the views were prepared and checked with the rest (ReadRegistrationInputs);
  // a session on images in memory gets them with SetXRays.
  this->GiveXRaysToFilter();
}

void RegistrationSession::ReadXRays(const std::vector<std::string>& xrays)
{
  if (!this->FromFiles())
    throw InputError("--xray", "a session on images in memory takes its X-rays with SetXRays");
  const Clock::time_point start = Clock::now();
  RegistrationSources sources = this->Given;
  sources.xrays = xrays;
  ReadXRayInputs(sources, this->Read);
  this->Given = sources;
  this->SecondsToRead = Since(start);
  this->SetUpFilter(); // the panels may be binned otherwise than the last X-rays'
}

void RegistrationSession::SetXRays(
  const std::vector<vtkSmartPointer<vtkImageData>>& xrays, const std::vector<vtkSmartPointer<vtkImageData>>& rois)
{
  // The views as the filter will see them, checked now: Inputs() stays the X-rays' own.
  std::vector<vtkImageData*> images(xrays.begin(), xrays.end()), masks(rois.begin(), rois.end());
  this->Read.views = vtkXPStereoRegistrationFilter::PrepareViews(
    this->Read.setup.geometry, images, masks, this->Read.shrinkFactor, this->Given.xrays);
  this->Read.xrays = xrays;
  this->Read.rois = rois;
  this->GiveXRaysToFilter();
}

void RegistrationSession::GiveXRaysToFilter()
{
  this->Registration->RemoveAllXRaysAndROIs();
  for (vtkImageData* xray : this->Read.xrays)
    this->Registration->AddXRayData(xray);
  for (vtkImageData* roi : this->Read.rois)
    this->Registration->AddROIData(roi);
}

RegistrationSession::~RegistrationSession() = default;

std::vector<GlobalCandidate> RegistrationSession::FindStarts() const
{
  const RegistrationInputs& inputs = this->Read;
  const std::unique_ptr<AttenuationVolume> volume = MakeAttenuationVolume(inputs.setup.ct.image, this->Given.muWater);
  std::vector<GlobalCandidate> candidates = FindGlobalStarts(*volume, inputs.planned, inputs.setup.geometry.isocenter,
    inputs.planned * ImageCenter(inputs.setup.ct.image), inputs.views);
  if (candidates.empty())
    throw InputError("--global-search", "no orientation of the volume matches both X-rays: give --initial-pose");
  return candidates;
}

const RegistrationRecord& RegistrationSession::Run(const StereoRegistrationSettings& settings)
{
  const Clock::time_point start = Clock::now();
  if (settings.chooseTable && this->Given.removeTable)
    throw InputError("--choose-table", "chooses between the CT with its table and the body alone; --remove-table takes the "
                                       "body alone already: give one of them");
  this->RunSettings = settings;
  this->Registration->SetSettings(settings);
  this->Registration->Update();
  const StereoRegistrationResult& result = this->Registration->GetResult();
  if (!result.failures.empty() && result.failures.front().code == GateCode::InvalidInput)
    throw InputError("registration", result.failures.front().message);
  std::vector<std::string> viewNames;
  for (const XRayView& view : this->Read.setup.geometry.views)
    viewNames.push_back(view.name);
  this->Recorded = MakeRegistrationRecord(result, viewNames);
  this->Recorded.readSeconds = this->SecondsToRead;
  this->Recorded.totalSeconds = this->SecondsToRead + Since(start);
  if (this->FromFiles())
  {
    this->Recorded.inputs = RecordedInputs(this->Given, settings.entropyMask);
    // The X-rays chose the body alone: the report renders its DRRs from it too.
    this->Recorded.inputs->removeTable |= result.table && !result.table->keptTable;
  }
  this->Recorded.volumeToRoom =
    MisalignedCTToRoom(this->Read.planned, result.misalignment, this->Read.setup.patient.roomIsocenter);
  this->Recorded.volumeCenter = ImageCenter(this->Read.setup.ct.image);
  if (result.ok) // a couch motion only for a result the couch may be moved by
  {
    const Eigen::Vector3d& isocenter = this->Read.setup.patient.roomIsocenter;
    this->Recorded.couch = PlanCouchMotion(result.misalignment, isocenter, this->Read.planned * this->Read.targetInCT,
      this->Read.couch, this->Read.actionLevels);
    this->Recorded.targetInCT = this->Read.targetInCT;
    this->Recorded.actionLevels = this->Read.actionLevels;
  }
  return this->Recorded;
}

vtkXPStereoRegistrationFilter* RegistrationSession::Filter() const
{
  return this->Registration;
}

const StereoRegistrationResult& RegistrationSession::Result() const
{
  return this->Registration->GetResult();
}

RegistrationRecordInputs RecordedInputs(const RegistrationSources& sources, bool entropyMask)
{
  const auto absolute = [](const std::string& path) { return std::filesystem::absolute(path).lexically_normal().string(); };
  RegistrationRecordInputs in;
  static_cast<RegistrationFiles&>(in) = sources; // the files and options as given, then the paths made absolute
  in.ct = absolute(in.ct);
  in.geometry = absolute(in.geometry);
  for (std::string& xray : in.xrays)
  {
    in.xrayMD5.push_back(FileMD5(xray));
    xray = absolute(xray);
  }
  for (std::string& roi : in.rois)
    roi = absolute(roi);
  in.entropyMask = entropyMask;
  return in;
}

} // namespace xp
