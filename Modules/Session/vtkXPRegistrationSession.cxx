#include "vtkXPRegistrationSession.h"

#include "xpError.h"
#include "xpRegistrationSession.h"
#include "xpRegistrationWriters.h"
#include "xpSessionOptions.h"
#include "xpVolumeIO.h"

#include <vtkObjectFactory.h>

vtkStandardNewMacro(vtkXPRegistrationSession);

vtkXPRegistrationSession::vtkXPRegistrationSession()
  : MuWater(xp::WaterAttenuationPerMM)
  , Optimizer(xp::DefaultOptimizers())
{
}

vtkXPRegistrationSession::~vtkXPRegistrationSession() = default;

void vtkXPRegistrationSession::RemoveAllXRayAndROIPaths()
{
  this->XRayPaths.clear();
  this->ROIPaths.clear();
}

void vtkXPRegistrationSession::SetInitialPose(double tx, double ty, double tz, double pitch, double roll, double yaw)
{
  const double pose[6] = { tx, ty, tz, pitch, roll, yaw };
  std::copy(pose, pose + 6, this->InitialPose);
}

int vtkXPRegistrationSession::Run()
{
  this->Session.reset();
  this->LastError.clear();
  try
  {
    xp::RegistrationSources sources;
    sources.ct = this->CTPath;
    sources.series = this->Series;
    // The session's text values, parsed here once (each refusal naming its setter's option).
    if (!this->VoxelSize.empty())
    {
      const std::array<double, 3> voxel = xp::ParseVoxelSize(this->VoxelSize, "--voxel-size");
      sources.voxelSize = Eigen::Vector3d(voxel[0], voxel[1], voxel[2]);
    }
    sources.geometry = this->GeometryPath;
    sources.xrays = this->XRayPaths;
    sources.rois = this->ROIPaths;
    sources.size = xp::ParseSizeIfGiven(this->Size, "--size");
    sources.isocenterInCT = xp::ParsePointIfGiven(this->IsocenterInCT, "--iso-ct");
    sources.muWater = this->MuWater;
    sources.removeTable = this->RemoveTable;
    sources.couch.motions = this->CouchMotions;
    sources.couch.rotationLimit = this->CouchRotationLimit;
    sources.couch.target = xp::ParsePointIfGiven(this->Target, "--target");
    sources.couch.levels.actionMM = this->ActionLevel[0];
    sources.couch.levels.actionDegrees = this->ActionLevel[1];
    sources.couch.levels.maxUncorrectedMM = this->MaxUncorrected[0];
    sources.couch.levels.maxUncorrectedDegrees = this->MaxUncorrected[1];
    // The settings `xpose register` takes when given no option but these.
    xp::StereoRegistrationSettings settings;
    settings.entropyMask = this->EntropyMask;
    settings.device = xp::ChooseComputeDevice(this->Device).device;
    settings.schedule = xp::ParseScheduleChoice(this->Schedule, "--schedule");
    settings.chooseTable = this->ChooseTable;
    xp::SetOptimizers(this->Optimizer, settings, "optimizer");
    xp::CheckRegistrationSettings(settings);
    settings.initialPose = xp::Pose::FromParameters(this->InitialPose);
    auto session = std::make_unique<xp::RegistrationSession>(sources);
    session->Run(settings);
    this->Session = std::move(session);
    return this->Session->Result().ok ? 1 : 0;
  }
  catch (const std::exception& e) // every refusal names its file or option; nothing escapes into Python
  {
    this->LastError = e.what();
    vtkErrorMacro(<< this->LastError);
    return -1;
  }
}

std::string vtkXPRegistrationSession::GetResultJSON() const
{
  return this->Session ? xp::RegistrationRecordJSON(this->Session->Record()) : std::string();
}

bool vtkXPRegistrationSession::WriteResultFolder(const std::string& directory)
{
  if (!this->Session)
  {
    this->LastError = directory + ": no result to write: Run() first";
    return false;
  }
  try
  {
    xp::WriteRegistrationFolder(*this->Session, directory);
    return true;
  }
  catch (const std::exception& e)
  {
    this->LastError = e.what();
    vtkErrorMacro(<< this->LastError);
    return false;
  }
}

void vtkXPRegistrationSession::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "CTPath: " << this->CTPath << "\n" << indent << "GeometryPath: " << this->GeometryPath << "\n";
  for (const std::string& xray : this->XRayPaths)
    os << indent << "XRayPath: " << xray << "\n";
  os << indent << "Size: " << (this->Size.empty() ? "the panels'" : this->Size) << "\n";
  os << indent << "Result: " << (!this->Session ? "none" : this->Session->Result().ok ? "ok" : "failed") << "\n";
}
