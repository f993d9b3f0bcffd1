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
  std::string model;
  std::function<std::vector<uint16_t>(const XRayView&, std::mt19937&)> render;
  std::unique_ptr<XRaySimulator> ownModel;
  std::unique_ptr<XRayPhysicsSimulator> physics;
  if (clinical)
  {
    XRayPhysicsSettings settings = XRayPhysicsSettings::Clinical();
    for (const std::string& effect : options.without)
      SwitchOff(settings, effect, "--without");
    physics = std::make_unique<XRayPhysicsSimulator>(
      ct.image, patient.PlannedCTToRoom(ImageCenter(ct.image)), geometry.isocenter, settings);
    render = [&](const XRayView& view, std::mt19937& random) { return physics->Simulate(view, pose, random); };
    model = settings.Describe();
  }
  else
  {
    XRaySimulation simulation;
    simulation.noise = options.noise;
    simulation.kvContrast = options.kvContrast;
    simulation.addObjects = options.addObjects;
    ownModel = std::make_unique<XRaySimulator>(ct.image, patient, simulation);
    render = [&](const XRayView& view, std::mt19937& random) { return ownModel->Simulate(view, pose, random); };
    std::ostringstream text;
    text << "{ \"noise\": " << options.noise << ", \"kv_contrast\": " << (options.kvContrast ? "true" : "false")
         << ", \"add_objects\": " << (options.addObjects ? "true" : "false") << " }";
    model = text.str();
  }

  std::mt19937 random(options.seed);
  StagedOutputDirectory output(options.outputDirectory);
  for (const XRayView& panel : geometry.views)
  {
    const XRayView view = size.first > 0 ? panel.Resampled(size.first, size.second) : panel;
    const std::vector<uint16_t> xray = render(view, random);
    WritePNG(ImageFromRowsTopFirst(xray, view.Columns(), view.Rows()), output.Path("xray_" + view.name + ".png"));
    std::printf("view %s: %dx%d simulated\n", view.name.c_str(), view.Columns(), view.Rows());
  }
  std::ofstream truth(output.Path("truth.json"));
  truth << "{\n  \"misalignment\": " << JsonPose(pose) << ",\n  \"correction\": " << JsonPose(pose.Inverse())
        << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
        << ",\n  \"ct\": \"" << options.ct << "\",\n  \"geometry\": \"" << options.geometry << "\""
        << ",\n  \"size\": \"" << (options.size.empty() ? "panel" : options.size) << "\""
        << ",\n  \"preset\": \"" << options.preset << "\",\n  \"model\": " << model << ",\n  \"seed\": " << options.seed
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
