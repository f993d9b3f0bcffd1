#include "xpCommands.h"
#include "xpModelXRaySimulator.h"
#include "xpXRayPhysics.h"

#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpPose.h"
#include "xpStereoGeometry.h"
#include "xpVolumeIO.h"

#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <sstream>
#include <random>

namespace xp
{

namespace
{

/** The simulator of --preset, ready to render the X-ray of a view at `pose`. */
struct XRaySource
{
  std::function<std::vector<uint16_t>(const XRayView&, std::mt19937&)> render;
  std::string model; ///< the simulator's settings, as JSON (truth.json's "model")
};

XRaySource MakeXRaySource(const SimulateOptions& options, vtkImageData* ct, const PatientSetup& patient,
  const Eigen::Vector3d& roomIsocenter, const Pose& pose)
{
  XRaySource source;
  if (options.preset == "clinical")
  {
    XRayPhysicsSettings settings = XRayPhysicsSettings::Clinical();
    for (const std::string& effect : options.without)
      SwitchOff(settings, effect, "--without");
    auto physics = std::make_shared<XRayPhysicsSimulator>(ct, patient.PlannedCTToRoom(ImageCenter(ct)), roomIsocenter, settings);
    source.render = [physics, pose](const XRayView& view, std::mt19937& random) { return physics->Simulate(view, pose, random); };
    source.model = settings.Describe();
    return source;
  }
  XRaySimulation simulation;
  simulation.noise = options.noise;
  simulation.kvContrast = options.kvContrast;
  simulation.addObjects = options.addObjects;
  auto ownModel = std::make_shared<XRaySimulator>(ct, patient, simulation);
  source.render = [ownModel, pose](const XRayView& view, std::mt19937& random) { return ownModel->Simulate(view, pose, random); };
  std::ostringstream text;
  text << "{ \"noise\": " << options.noise << ", \"kv_contrast\": " << (options.kvContrast ? "true" : "false")
       << ", \"add_objects\": " << (options.addObjects ? "true" : "false") << " }";
  source.model = text.str();
  return source;
}

} // namespace

int RunSimulate(const SimulateOptions& options)
{
  UseThreads(options.threads);
  CheckLimit(options.noise, 0.0, 1000.0, "--noise");
  const Pose pose = Pose::Parse(options.pose, "--pose");
  std::pair<int, int> size{ 0, 0 };
  if (!options.size.empty())
  {
    size = ParseSize(options.size, "--size");
  }
  const bool clinical = options.preset == "clinical";
  if (!clinical && options.preset != "model")
  {
    throw InputError("--preset", "expected model or clinical, got '" + options.preset + "'");
  }
  if (clinical && (options.noise > 0.0 || options.kvContrast || options.addObjects))
  {
    throw InputError("--preset clinical", "models noise, bone contrast and the couch itself; --noise, --kv-contrast "
                                          "and --add-objects belong to --preset model");
  }
  if (!clinical && !options.without.empty())
  {
    throw InputError("--without", "switches off effects of --preset clinical");
  }
  const StereoGeometry geometry = ReadStereoGeometry(options.geometry);
  const CTVolume ct = ReadCTVolume(options.ct, options.series);
  PatientSetup patient{ ParsePatientPosition(ct.patientPosition, options.ct), std::nullopt, geometry.isocenter };
  if (!options.isocenterInCT.empty())
    patient.isocenterInCT = ParsePoint(options.isocenterInCT, "--iso-ct");
  const XRaySource source = MakeXRaySource(options, ct.image, patient, geometry.isocenter, pose);
  std::mt19937 random(options.seed);
  StagedOutputDirectory output(options.outputDirectory);
  for (const XRayView& panel : geometry.views)
  {
    const XRayView view = size.first > 0 ? panel.Resampled(size.first, size.second) : panel;
    const std::vector<uint16_t> xray = source.render(view, random);
    WritePNG(ImageFromRowsTopFirst(xray, view.Columns(), view.Rows()), output.Path("xray_" + view.name + ".png"));
    std::printf("view %s: %dx%d simulated\n", view.name.c_str(), view.Columns(), view.Rows());
  }
  std::ofstream truth(output.Path("truth.json"));
  truth << "{\n  \"misalignment\": " << JsonPose(pose) << ",\n  \"correction\": " << JsonPose(pose.Inverse())
        << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
        << ",\n  \"ct\": \"" << options.ct << "\",\n  \"geometry\": \"" << options.geometry << "\""
        << ",\n  \"size\": \"" << (options.size.empty() ? "panel" : options.size) << "\""
        << ",\n  \"preset\": \"" << options.preset << "\",\n  \"model\": " << source.model << ",\n  \"seed\": " << options.seed
        << "\n}\n";
  truth.close();
  if (!truth)
  {
    throw Error(options.outputDirectory, "cannot write truth.json");
  }
  output.Commit();
  std::printf("misalignment %s; wrote xray_NAME.png and truth.json to %s\n", pose.ToString().c_str(),
    options.outputDirectory.c_str());
  return ExitOk;
}

} // namespace xp
