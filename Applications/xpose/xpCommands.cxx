#include "xpCommands.h"

#include "xpDICOMSeriesWriter.h"
#include "xpError.h"
#include "xpHeadPhantom.h"
#include "xpImageIO.h"
#include "xpPose.h"

#include <vtkSMPTools.h>

#include <chrono>
#include <cstdio>
#include <dirent.h>
#include <iostream>
#include <new>

namespace xp
{

int GuardedRun(const std::string& command, const std::function<int()>& body)
{
  try
  {
    return body();
  }
  catch (const InputError& e)
  {
    std::cerr << "xpose " << command << ": error: " << e.what() << std::endl;
    return ExitBadInput;
  }
  catch (const std::bad_alloc&)
  {
    // Readers bound what they allocate; this is the last resort for what no check foresaw.
    std::cerr << "xpose " << command << ": failed: not enough memory for these inputs" << std::endl;
    return ExitFailure;
  }
  catch (const std::exception& e)
  {
    std::cerr << "xpose " << command << ": failed: " << e.what() << std::endl;
    return ExitFailure;
  }
}

std::string JsonPose(const Pose& p)
{
  char text[256];
  std::snprintf(text, sizeof(text),
    "{\"translation_mm\": [%.6f, %.6f, %.6f], \"rotation_deg\": {\"pitch\": %.6f, \"roll\": %.6f, \"yaw\": %.6f}}",
    p.translation[0], p.translation[1], p.translation[2], p.pitch, p.roll, p.yaw);
  return text;
}

void UseThreads(int threads)
{
  if (threads < 0)
  {
    throw InputError("--threads", "must be 0 (all cores) or more");
  }
  vtkSMPTools::Initialize(threads);
}

ComputeDevice UseDevice(const std::string& device)
{
  const ComputeDeviceChoice choice = ChooseComputeDevice(device);
  if (!choice.note.empty())
    std::printf("device: %s\n", choice.note.c_str());
  else if (choice.device != ComputeDevice::CPU)
    std::printf("device: %s\n", choice.description.c_str());
  return choice.device;
}

int RunPhantom(const PhantomOptions& options)
{
  CheckLimit(options.spacing, 0.25, 10.0, "--spacing");
  if (DIR* existing = opendir(options.outputDirectory.c_str()))
  {
    int entries = 0;
    while (dirent* entry = readdir(existing))
    {
      entries += entry->d_name[0] != '.';
    }
    closedir(existing);
    if (entries > 0)
    {
      throw InputError(options.outputDirectory, "output folder is not empty; a CT series needs a folder of its own");
    }
  }
  const auto start = std::chrono::steady_clock::now();
  const CTVolumeData phantom = MakeHeadPhantom(options.spacing);
  StagedOutputDirectory out(options.outputDirectory);
  CTSeriesWriteOptions write;
  write.seriesDescription = "xpose head phantom";
  for (const std::string& path : WriteCTSeries(phantom, out.StagingFolder(), write))
  {
    out.Track(path.substr(path.find_last_of('/') + 1));
  }
  out.Commit();
  std::printf("head phantom: %d x %d x %d voxels of %.2f mm, HFS, written to %s in %.2f s\n", phantom.dimensions[0],
    phantom.dimensions[1], phantom.dimensions[2], options.spacing, options.outputDirectory.c_str(),
    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  return ExitOk;
}

} // namespace xp
