// xpose listen: a DICOM storage node in a treatment room. The imaging system sends the planning
// CT and each X-ray pair; when a study goes quiet, its new pair is registered as `register`
// would, and an ok result's REG is sent on.
#include "xpCommands.h"

#include "xpArchiveAccess.h"
#include "xpDIMSEArchive.h"
#include "xpError.h"
#include "xpRegistrationRecord.h"
#include "xpStereoGeometry.h"
#include "xpStorageNode.h"
#include "xpXRayGeometryTags.h"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>
#include <set>

namespace xp
{

namespace
{

std::atomic<bool> StopRequested{ false };

extern "C" void RequestStop(int)
{
  StopRequested = true;
}

void LogLine(const std::string& line)
{
  char stamp[32];
  const std::time_t now = std::time(nullptr);
  std::strftime(stamp, sizeof(stamp), "%Y-%m-%dT%H:%M:%S", std::localtime(&now));
  std::printf("%s %s\n", stamp, line.c_str());
  std::fflush(stdout);
}

bool IsXRayClass(const std::string& sopClass)
{
  return sopClass == "1.2.840.10008.5.1.4.1.1.481.1"      // RT Image
    || sopClass == "1.2.840.10008.5.1.4.1.1.1.1"          // DX for presentation
    || sopClass == "1.2.840.10008.5.1.4.1.1.1.1.1"        // DX for processing
    || sopClass == "1.2.840.10008.5.1.4.1.1.1"            // CR
    || sopClass == "1.2.840.10008.5.1.4.1.1.12.1";        // XA
}

/** The registrations of one node: which X-rays each study has used, and how many pairs. */
class StudyRegistrar
{
public:
  explicit StudyRegistrar(const ListenOptions& options)
    : Options(options)
    , Geometry(ReadStereoGeometry(options.registration.geometry))
  {
  }

  void operator()(const std::string& studyUID, const std::vector<ReceivedInstance>& instances)
  {
    std::map<std::string, std::vector<const ReceivedInstance*>> ctSeries;
    for (const ReceivedInstance& instance : instances)
      if (instance.sopClassUID == "1.2.840.10008.5.1.4.1.1.2")
        ctSeries[instance.seriesUID].push_back(&instance);
    if (ctSeries.size() != 1)
    {
      LogLine("study " + studyUID + ": " + std::to_string(ctSeries.size()) + " CT series; waiting for one");
      return;
    }
    const ReceivedInstance& anyCT = *ctSeries.begin()->second.front();
    std::set<std::string>& used = this->Used[studyUID];
    // Each new X-ray to the one imager its geometry tags describe; the latest wins an imager.
    std::vector<const ReceivedInstance*> pair(this->Geometry.views.size(), nullptr);
    bool anyNew = false;
    for (const ReceivedInstance& instance : instances)
    {
      if (!IsXRayClass(instance.sopClassUID) || used.count(instance.sopInstanceUID))
        continue;
      anyNew = true;
      std::vector<size_t> matches;
      try
      {
        const XRayView own = ReadXRayViewFromTags(instance.path, this->Geometry.isocenter, anyCT.patientPosition);
        // An imager's panel as this X-ray was read out: whole, or binned to its size.
        for (size_t v = 0; v < this->Geometry.views.size(); ++v)
          if (const std::optional<XRayView> panel = this->Geometry.views[v].Binned(own.Columns(), own.Rows()))
            if (XRayTagDisagreements(instance.path, *panel, this->Geometry.isocenter, anyCT.patientPosition).empty())
              matches.push_back(v);
      }
      catch (const Error& e)
      {
        LogLine("study " + studyUID + ": X-ray " + instance.sopInstanceUID + " cannot be assigned: " + e.what());
        continue;
      }
      if (matches.size() != 1)
      {
        LogLine("study " + studyUID + ": X-ray " + instance.sopInstanceUID + " matches " + std::to_string(matches.size()) +
          " of the geometry's imagers; not registered");
        continue;
      }
      pair[matches.front()] = &instance;
    }
    if (!anyNew)
      return;
    for (size_t v = 0; v < pair.size(); ++v)
      if (!pair[v])
      {
        LogLine("study " + studyUID + ": no new X-ray for imager " + this->Geometry.views[v].name + " yet; waiting");
        return;
      }
    int& count = this->Registrations[studyUID];
    ++count;
    RegisterOptions registration = this->Options.registration;
    const std::string out = this->Options.outputDirectory + "/" + studyUID + (count > 1 ? "/" + std::to_string(count) : "");
    registration.ct = std::filesystem::path(anyCT.path).parent_path().string();
    registration.series = anyCT.seriesUID;
    registration.xrays.clear();
    for (const ReceivedInstance* xray : pair)
    {
      registration.xrays.push_back(xray->path);
      used.insert(xray->sopInstanceUID);
    }
    registration.outputDirectory = out;
    registration.reportDirectory = out + "/report";
    registration.dicomOutputDirectory = out + "/dicom";
    LogLine("study " + studyUID + ": registering pair " + std::to_string(count) + " into " + out);
    std::string couch;
    const int code = GuardedRun("listen",
      [&]
      {
        const RegistrationRecord record = RegisterFiles(registration);
        if (record.couch)
          couch = "; couch " + record.couch->Summary();
        return record.ok ? ExitOk : ExitRegistrationFailed;
      });
    LogLine("study " + studyUID + ": pair " + std::to_string(count) +
      (code == ExitOk ? " ok" : code == ExitRegistrationFailed ? " FAILED (do not apply)" : " not registered (error above)") +
      couch);
    if (code == ExitOk && !this->Options.forward.empty())
    {
      const DIMSEArchive destination(this->Options.forward, this->Options.aet, ArchiveAccess());
      destination.Store({ out + "/dicom/reg.dcm" });
      LogLine("study " + studyUID + ": REG of pair " + std::to_string(count) + " sent to " + this->Options.forward);
    }
  }

private:
  const ListenOptions& Options;
  StereoGeometry Geometry;
  std::map<std::string, std::set<std::string>> Used;
  std::map<std::string, int> Registrations;
};

} // namespace

int RunListen(const ListenOptions& options)
{
  if (!options.forward.empty())
    DIMSEArchive(options.forward, options.aet, ArchiveAccess()); // checked before serving
  if (options.outputDirectory.empty())
    throw InputError("--out-dir", "is required");
  CheckRegistrationSettings(options.registration.settings);
  options.registration.couch.levels.Validate();
  ResolveCouch(ReadStereoGeometry(options.registration.geometry), options.registration.couch);
  UseDevice(options.registration.device); // checked before serving, not at the first study
  StudyRegistrar registrar(options);
  StorageNodeSettings settings;
  settings.port = options.port;
  settings.aeTitle = options.aet;
  settings.allowedCallers = options.allowAET;
  settings.directory = options.outputDirectory;
  settings.settleSeconds = options.settle;
  StorageNode node(settings, std::ref(registrar), LogLine);
  StopRequested = false;
  std::signal(SIGTERM, RequestStop);
  std::signal(SIGINT, RequestStop);
  LogLine("listening on port " + std::to_string(options.port) + " as " + options.aet);
  node.Serve(StopRequested);
  LogLine("stopped");
  return ExitOk;
}

} // namespace xp
