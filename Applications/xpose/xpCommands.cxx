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

std::pair<int, int> ParseSize(const std::string& text, const std::string& field)
{
  int columns = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &columns, &x, &rows, &extra) != 3 || (x != 'x' && x != 'X') ||
    columns < 1 || rows < 1 || columns > 16384 || rows > 16384)
  {
    throw InputError(field, "expected COLSxROWS such as 512x384, got '" + text + "'");
  }
  return { columns, rows };
}

Eigen::Vector3d ParsePoint(const std::string& text, const std::string& field)
{
  Eigen::Vector3d p;
  char c1 = 0, c2 = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf%c", &p[0], &c1, &p[1], &c2, &p[2], &extra) != 5 || c1 != ',' ||
    c2 != ',' || !p.allFinite())
  {
    throw InputError(field, "expected x,y,z in mm, got '" + text + "'");
  }
  return p;
}

std::string JsonPose(const Pose& p)
{
  char text[256];
  std::snprintf(text, sizeof(text),
    "{\"translation_mm\": [%.6f, %.6f, %.6f], \"rotation_deg\": {\"pitch\": %.6f, \"roll\": %.6f, \"yaw\": %.6f}}",
    p.translation[0], p.translation[1], p.translation[2], p.pitch, p.roll, p.yaw);
  return text;
}

void CheckLimit(double value, double low, double high, const std::string& option)
{
  if (!(value >= low && value <= high))
  {
    char range[96];
    std::snprintf(range, sizeof(range), "must be a number from %g to %g, got %g", low, high, value);
    throw InputError(option, range);
  }
}

void SetOptimizers(const std::string& text, StereoRegistrationSettings& settings, const std::string& option)
{
  const size_t slash = text.find('/');
  settings.optimizer = ParsePoseOptimizerMethod(text.substr(0, slash), option);
  settings.refinementOptimizer = ParsePoseOptimizerMethod(slash == std::string::npos ? text : text.substr(slash + 1), option);
}

void CheckRegistrationSettings(const StereoRegistrationSettings& settings)
{
  CheckLimit(settings.bins, 8, 256, "--bins");
  CheckLimit(settings.maxEvaluations, 10, 100000, "--max-evaluations");
  CheckLimit(settings.fineHighPassMM, 0.0, 500.0, "--high-pass-mm");
  CheckLimit(settings.xraySmoothingPerVoxel, 0.0, 10.0, "--xray-smoothing");
  CheckLimit(settings.fineRenderStride, 0, 8, "--fine-render-stride");
  CheckLimit(settings.searchRenderStride, 0, 8, "--search-render-stride");
  CheckLimit(settings.coverageMarginMM, 0.0, 100.0, "--coverage-margin-mm");
  CheckLimit(settings.coverageMinExcess, 0.0, 1.0, "--coverage-min-excess");
  CheckLimit(settings.maxTranslation, 0.1, 500.0, "--max-translation");
  CheckLimit(settings.maxRotation, 0.1, 180.0, "--max-rotation");
  CheckLimit(settings.minExplained, 0.0, 1.0, "--min-explained");
  CheckLimit(settings.maxViewResidual, 0.01, 100.0, "--max-view-residual");
  CheckLimit(settings.maxUncovered, 0.001, 1.0, "--max-uncovered");
  CheckLimit(settings.maxSearchDisagreementMM, 0.0, 100.0, "--max-search-apart-mm");
  CheckLimit(settings.maxSearchDisagreementDegrees, 0.001, 45.0, "--max-search-apart-deg");
  CheckLimit(settings.maxRefinedApartDegrees, 0.001, 45.0, "--max-refined-apart-deg");
}

void UseThreads(int threads)
{
  if (threads < 0)
  {
    throw InputError("--threads", "must be 0 (all cores) or more");
  }
  vtkSMPTools::Initialize(threads);
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
