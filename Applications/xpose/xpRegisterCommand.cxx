#include "xpCommands.h"
#include "xpBodyMask.h"

#include "vtkXPStereoRegistrationFilter.h"
#include "xpDICOMArchive.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpRegistrationArchive.h"
#include "xpRegistrationSession.h"
#include "xpRegistrationWriters.h"
#include "xpVolumeIO.h"
#include "xpXRayGeometryTags.h"

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkNew.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <optional>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Since(Clock::time_point start)
{
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/** Prints each stage of the registration as it begins, from the filter's progress events. */
class StageLogger
{
public:
  explicit StageLogger(vtkXPStereoRegistrationFilter* filter)
  {
    this->Callback->SetClientData(&this->LastStage);
    this->Callback->SetCallback([](vtkObject* caller, unsigned long, void* clientData, void*)
      {
        auto* last = static_cast<std::string*>(clientData);
        const char* stage = static_cast<vtkAlgorithm*>(caller)->GetProgressText();
        if (stage && *last != stage)
        {
          *last = stage;
          if (*last != "done")
            std::printf("  %s...\n", stage);
          std::fflush(stdout);
        }
      });
    filter->AddObserver(vtkCommand::ProgressEvent, this->Callback);
  }

private:
  vtkNew<vtkCallbackCommand> Callback;
  std::string LastStage;
};

/** A TIFF volume has no planned set-up to start from: the global search finds the start. */
bool UsesGlobalSearch(const RegisterOptions& options)
{
  return options.globalSearch || (options.initialPose.empty() && IsTIFFVolumePath(options.ct));
}

/** The start of a registration that has none (xpGlobalSearch.h): the best candidate. */
Pose FoundStart(const RegistrationSession& session)
{
  const Clock::time_point start = Clock::now();
  const std::vector<GlobalCandidate> candidates = session.FindStarts();
  for (const GlobalCandidate& candidate : candidates)
    std::printf("  candidate %s: correlation %.3f\n", candidate.pose.ToString().c_str(), candidate.score);
  std::printf("global search: start %s (%.2f s)\n", candidates.front().pose.ToString().c_str(), Since(start));
  return candidates.front().pose;
}

/** What the registration found at each stage, after the filter has run. */
void PrintStages(const StereoRegistrationResult& result, const std::vector<RegistrationView>& views)
{
  if (result.table && result.table->tableCM3 > 0.0)
    std::printf("table: %.0f cm3 outside the body; where the body alone pre-aligned, the X-rays' edges match the CT %s "
                "(high-passed objective %.4f) better than %s (%.4f): registered %s\n",
      result.table->tableCM3, result.table->keptTable ? "with it" : "without it",
      result.table->keptTable ? result.table->withTable : result.table->bodyOnly,
      result.table->keptTable ? "the body alone" : "with it", result.table->keptTable ? result.table->bodyOnly : result.table->withTable,
      result.table->keptTable ? "with the table" : "the body alone");
  else if (result.table && result.boneOnly)
    std::printf("table: none to choose, the volume is a bone's: registered as given\n");
  else if (result.table)
    std::printf("table: nothing outside the body denser than %.0f HU: the CT registered as given\n", BodyMaskSettings{}.tableHU);
  std::printf("pre-alignment: %s, %d iterations (%.2f s)\nmasks: valid fraction", result.prealignment.pose.ToString().c_str(),
    result.prealignment.iterations, result.prealignSeconds);
  for (size_t v = 0; v < views.size(); ++v)
    std::printf(" %s %.3f", views[v].view.name.c_str(), result.validFraction[v]);
  std::printf(" (%.2f s)\n", result.maskSeconds);
  for (size_t v = 0; v < result.endFaces.size() && v < views.size(); ++v)
  {
    // Which of the CT's ends the X-ray shows anatomy beyond, and so whose rays were left out.
    const EndFaceEvidence& faces = result.endFaces[v];
    const auto named = [&](int f) { return (faces.facesToLeaveOut >> f) & 1 ? "left out" : "kept"; };
    std::printf("CT end faces, view %s: rays beyond the first slice %s (excess %.3f), beyond the last %s (excess %.3f)\n",
      views[v].view.name.c_str(), named(0), faces.excess[0], named(1), faces.excess[1]);
  }
  if (result.boneOnly)
    std::printf("bone: %lld voxels on the faces where the crop cut it%s\n", result.cutFaceVoxels,
      result.cutFaceVoxels > 0 ? " (their shadow left out)" : "");
  std::printf("fine 6-DOF: %s, %d evaluations (%.2f s)\n", result.misalignment.ToString().c_str(), result.evaluations,
    result.fineSeconds);
  for (size_t v = 0; v < result.edgeDistanceMM.size() && v < views.size(); ++v)
    std::printf("edges, view %s: the DRR's lie %.2f mm from the X-ray's (%.2f mm with the DRR moved 3 mm)\n",
      views[v].view.name.c_str(), result.edgeDistanceMM[v], result.edgeDistanceShiftedMM[v]);
}

/** The CT series the DICOM output refers to, checked before any work. */
std::optional<CTSeriesInfo> DICOMOutputCT(const RegisterOptions& options)
{
  if (options.dicomOutputDirectory.empty())
    return std::nullopt;
  StagedOutputDirectory::CheckWritable(options.dicomOutputDirectory);
  return DICOMSeriesForOutput(options.ct, options.series, "--dicom-out");
}

/** Warns where an X-ray's own geometry tags (an RT Image's, a DX's) disagree with --geometry,
 *  naming the tag and both values: the geometry file stays the source of truth, but a mismatch
 *  usually means the wrong file or a moved imager. A DX without Patient Position lay as the CT. */
void WarnOfGeometryTags(const RegisterOptions& options, const DRRSetup& setup)
{
  const StereoGeometry& geometry = setup.geometry;
  for (size_t v = 0; v < options.xrays.size() && v < geometry.views.size(); ++v)
    for (const std::string& difference :
      XRayTagDisagreements(options.xrays[v], geometry.views[v], geometry.isocenter, ToString(setup.patient.position)))
      std::fprintf(stderr, "xpose register: warning: %s: %s\n", options.xrays[v].c_str(), difference.c_str());
}

/** --pacs: the options that register the CT series and the X-rays fetched from the archive
 *  into OUT/pacs-inputs, and write the DICOM results to be stored back. */
RegisterOptions FetchFromArchive(const RegisterOptions& options, const DICOMArchive& archive)
{
  if (!options.ct.empty() || !options.xrays.empty())
    throw InputError("--pacs", "takes the CT and the X-rays from the archive: leave out --ct and --xray");
  if (options.study.empty() == options.ctSeries.empty())
    throw InputError("--pacs", "give the study (--study UID) or the CT series (--ct-series UID), one of them");
  if (options.xrayInstances.empty())
    throw InputError("--xray-instance", "give the X-rays' SOP Instance UIDs, one per imager in order");
  StagedOutputDirectory::CheckWritable(options.outputDirectory);
  archive.CheckReachable();
  const std::string folder = options.outputDirectory + "/pacs-inputs";
  const ArchivedInputs fetched =
    FetchRegistrationInputs(archive, options.study, options.ctSeries, options.xrayInstances, folder);
  RegisterOptions local = options;
  local.pacs.clear();
  local.pacsCredentials.clear();
  local.ct = fetched.ctFolder;
  local.series = fetched.ctSeries;
  local.xrays = fetched.xrays;
  if (local.dicomOutputDirectory.empty())
    local.dicomOutputDirectory = options.outputDirectory + "/dicom";
  std::printf("pacs: CT series %s and %zu X-rays fetched from %s into %s\n", fetched.ctSeries.c_str(), local.xrays.size(),
    archive.Address().c_str(), folder.c_str());
  return local;
}

void PrintResult(const RegistrationRecord& record, const std::string& outputDirectory)
{
  std::printf("\n%s\nmisalignment:  %s\n6-DOF correction: %s\n(IEC 61217 fixed, R = Rz(yaw) Ry(roll) Rx(pitch); move "
              "the couch only when status is ok)\n",
    record.ok ? "status: ok" : "status: FAILED", record.misalignment.ToString().c_str(), record.correction.ToString().c_str());
  if (record.couch)
    std::printf("%s\n  action: %s\n", record.couch->Describe().c_str(), record.couch->actionReason.c_str());
  std::printf("DRRs: %lld, evaluations: %d, total %.2f s; result.json in %s\n", record.drrCount, record.evaluations,
    record.totalSeconds, outputDirectory.c_str());
  for (const std::string& reason : record.Reasons())
    std::printf("  reason: %s\n", reason.c_str());
}

} // namespace

int RunRegister(const RegisterOptions& options)
{
  // The couch options, checked before anything is fetched or read (the target, against the CT).
  options.couch.levels.Validate();
  ResolveCouch(StereoGeometry{}, options.couch);
  if (!options.pacs.empty())
  {
    const std::unique_ptr<DICOMArchive> opened =
      OpenArchive(options.pacs, ResolveArchiveAccess(options.pacsCredentials, options.caFile), options.aet);
    const DICOMArchive& archive = *opened;
    const RegisterOptions local = FetchFromArchive(options, archive);
    const int code = RunRegister(local);
    const std::vector<std::string> stored = StoreRegistrationDICOM(archive, local.dicomOutputDirectory);
    std::printf("pacs: %zu DICOM objects stored in %s\n", stored.size(), archive.Address().c_str());
    return code;
  }
  if (options.ct.empty() || options.xrays.empty())
    throw InputError(options.ct.empty() ? "--ct" : "--xray", "is required (or --pacs with --study or --ct-series and --xray-instance)");
  return RegisterFiles(options).ok ? ExitOk : ExitRegistrationFailed;
}

RegistrationRecord RegisterFiles(const RegisterOptions& options)
{
  std::unique_ptr<RegistrationSession> session;
  return RegisterFiles(options, session);
}

RegistrationRecord RegisterFiles(const RegisterOptions& options, std::unique_ptr<RegistrationSession>& kept)
{
  const Clock::time_point start = Clock::now();
  UseThreads(options.threads);
  const ComputeDevice device = UseDevice(options.device);
  // The settings, checked and completed from the options once, before the CT is read.
  CheckRegistrationSettings(options.settings);
  StereoRegistrationSettings settings = options.settings;
  settings.device = device;
  SetOptimizers(options.optimizer, settings, "--optimizer");
  if (!options.initialPose.empty())
    settings.initialPose = Pose::Parse(options.initialPose, "--initial-pose");
  // Output folders are checked before the work, not after it: a registration whose result
  // cannot be written must not run for seconds and then fail.
  StagedOutputDirectory::CheckWritable(options.outputDirectory);
  if (!options.reportDirectory.empty())
    StagedOutputDirectory::CheckWritable(options.reportDirectory);
  // Every input is read and checked before any work.
  const std::optional<CTSeriesInfo> dicomCT = DICOMOutputCT(options);
  const bool ctRead = kept != nullptr;
  if (ctRead)
    kept->ReadXRays(options.xrays);
  else
    kept = std::make_unique<RegistrationSession>(options);
  RegistrationSession& session = *kept;
  const RegistrationInputs& inputs = session.Inputs();
  if (dicomCT)
    CheckRTImageViews(inputs.setup.geometry, "--dicom-out");
  WarnOfGeometryTags(options, inputs.setup);
  const double readSeconds = Since(start);
  std::printf("read: CT %s%s, %zu X-rays, registering at %dx%d per view (%.2f s)\n", options.ct.c_str(),
    ctRead ? " (kept as first read)" : "", inputs.views.size(), inputs.views[0].view.Columns(), inputs.views[0].view.Rows(), readSeconds);
  if (options.removeTable)
    std::printf("table: %lld voxels outside the body set to air (--remove-table)\n", inputs.tableVoxelsRemoved);
  else if (!options.settings.chooseTable)
    std::printf("table: the CT rendered as it is, anything outside the body included (--keep-table)\n");
  for (size_t v = 0; v < inputs.binning.size(); ++v)
    if (inputs.binning[v][0] > 1 || inputs.binning[v][1] > 1)
      std::printf("view %s: the X-ray is the panel read out binned %dx%d (%dx%d pixels of %.3f x %.3f mm)\n",
        inputs.views[v].view.name.c_str(), inputs.binning[v][0], inputs.binning[v][1], inputs.setup.geometry.views[v].Columns(),
        inputs.setup.geometry.views[v].Rows(), inputs.setup.geometry.views[v].pixelSpacing[0],
        inputs.setup.geometry.views[v].pixelSpacing[1]);
  for (size_t v = 0; v < inputs.fields.size(); ++v)
    if (inputs.fields[v].found)
      std::printf("view %s: an image intensifier's circular field, centre (%.0f, %.0f) px, radius %.0f px: its outside is "
                  "left out\n", inputs.views[v].view.name.c_str(), inputs.fields[v].center[0], inputs.fields[v].center[1],
        inputs.fields[v].radius);

  if (options.initialPose.empty() && UsesGlobalSearch(options))
    settings.initialPose = FoundStart(session);
  const StageLogger logger(session.Filter());
  session.Run(settings);
  const StereoRegistrationResult& result = session.Result();
  PrintStages(result, inputs.views);
  // The command's own clock: its checks of options and outputs count too.
  session.SetTimes(readSeconds, Since(start));
  WriteRegistrationFolder(session, options.outputDirectory);
  PrintResult(session.Record(), options.outputDirectory);
  if (!options.reportDirectory.empty())
    WriteReportOf(session.Record(), inputs, options.outputDirectory, options.reportDirectory);
  if (dicomCT)
  {
    const std::string summary = options.reportDirectory.empty() ? "" : options.reportDirectory + "/summary.png";
    const std::string written = WriteDICOMRegistration(session, *dicomCT, options.dicomOutputDirectory, summary);
    std::printf("DICOM: %s in %s\n", written.c_str(), options.dicomOutputDirectory.c_str());
  }
  return session.Record();
}

} // namespace xp
