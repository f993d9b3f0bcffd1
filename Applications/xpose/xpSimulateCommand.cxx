#include "xpCommands.h"
#include "xpXRaySimulator.h"

#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpPose.h"
#include "xpStereoGeometry.h"
#include "xpVolumeIO.h"

#include <cstdio>
#include <fstream>
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
  XRaySimulation simulation;
  simulation.noise = options.noise;
  simulation.kvContrast = options.kvContrast;
  simulation.addObjects = options.addObjects;
  const StereoGeometry geometry = ReadStereoGeometry(options.geometry);
  const CTVolume ct = ReadCTVolume(options.ct, options.series);
  const Eigen::Vector3d isoInCT =
    options.isocenterInCT.empty() ? ImageCenter(ct.image) : ParsePoint(options.isocenterInCT, "--iso-ct");
  XRaySimulator simulator(
    ct.image, ParsePatientPosition(ct.patientPosition, options.ct), isoInCT, geometry.isocenter, simulation);

  std::mt19937 random(options.seed);
  StagedOutputDirectory output(options.outputDirectory);
  for (const XRayView& panel : geometry.views)
  {
    const XRayView view = size.first > 0 ? panel.Resampled(size.first, size.second) : panel;
    const std::vector<uint16_t> xray = simulator.Simulate(view, pose, random);
    WritePNG(ImageFromRowsTopFirst(xray, view.Columns(), view.Rows()), output.Path("xray_" + view.name + ".png"));
    std::printf("view %s: %dx%d simulated\n", view.name.c_str(), view.Columns(), view.Rows());
  }
  std::ofstream truth(output.Path("truth.json"));
  truth << "{\n  \"misalignment\": " << JsonPose(pose) << ",\n  \"correction\": " << JsonPose(pose.Inverse())
        << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
        << ",\n  \"ct\": \"" << options.ct << "\",\n  \"geometry\": \"" << options.geometry << "\""
        << ",\n  \"size\": \"" << (options.size.empty() ? "panel" : options.size) << "\""
        << ",\n  \"noise\": " << options.noise << ",\n  \"kv_contrast\": " << (options.kvContrast ? "true" : "false")
        << ",\n  \"add_objects\": " << (options.addObjects ? "true" : "false") << ",\n  \"seed\": " << options.seed
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
