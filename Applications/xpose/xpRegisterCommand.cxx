#include "xpCommands.h"
#include "xpRegistrationInputs.h"

#include "xpBodyMask.h"

#include "vtkXPDRRFilter.h"
#include "vtkXPStereoRegistrationFilter.h"

#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpGlobalSearch.h"
#include "xpDICOMXRay.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpImageGeometry.h"
#include "xpRegistrationRecord.h"
#include "xpDICOMArchive.h"
#include "xpRTImage.h"
#include "xpXRayGeometryTags.h"
#include "xpSpatialRegistration.h"

#include <vtkCallbackCommand.h>
#include <vtkCommand.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>
#include <sys/stat.h>
#include <sstream>

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

/** A float map in [0, 1] as 8-bit grey. */
vtkSmartPointer<vtkImageData> EntropyAsGrey(vtkImageData* map)
{
  auto grey = vtkSmartPointer<vtkImageData>::New();
  grey->CopyStructure(map);
  grey->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  const auto* in = static_cast<const float*>(map->GetScalarPointer());
  auto* out = static_cast<uint8_t*>(grey->GetScalarPointer());
  for (vtkIdType i = 0; i < map->GetNumberOfPoints(); ++i)
    out[i] = static_cast<uint8_t>(std::lround(255.0 * std::clamp(in[i], 0.0f, 1.0f)));
  return grey;
}

} // namespace

int RegistrationShrinkFactor(const std::vector<XRayView>& panels, const std::string& size)
{
  if (size.empty())
    return 1;
  const auto [columns, rows] = ParseSize(size, "--size");
  const int factor = panels[0].Columns() / columns;
  for (const XRayView& panel : panels)
  {
    if (factor < 1 || panel.Columns() != columns * factor || panel.Rows() != rows * factor)
    {
      throw InputError("--size", size + " must divide imager " + panel.name + "'s " + std::to_string(panel.Columns()) + "x" +
          std::to_string(panel.Rows()) + " pixels by a whole number");
    }
  }
  return factor;
}

RegistrationInputs LoadRegistrationInputs(const RegisterOptions& options)
{
  RegistrationInputs inputs;
  inputs.setup = MakeDRRSetup(options.ct, options.series, options.voxelSize, options.geometry, options.isocenterInCT, options.muWater,
    "trilinear", 0.0);
  if (options.removeTable)
  {
    // The CT's table is not the treatment couch: render from the body alone.
    inputs.setup.ct.image = BodyOnly(inputs.setup.ct.image, {}, &inputs.tableVoxelsRemoved);
    inputs.setup.filter->SetInputData(inputs.setup.ct.image);
  }
  const DRRSetup& setup = inputs.setup;
  ValidateStereoGeometry(setup.geometry, options.geometry);
  const std::vector<XRayView>& panels = setup.geometry.views;
  if (options.xrays.size() != panels.size())
  {
    throw InputError("--xray", "the geometry has " + std::to_string(panels.size()) + " imagers; give one X-ray each, in order (got " +
        std::to_string(options.xrays.size()) + ")");
  }
  if (!options.rois.empty() && options.rois.size() != panels.size())
  {
    throw InputError("--roi", "give one ROI per X-ray, in the same order");
  }
  inputs.shrinkFactor = RegistrationShrinkFactor(panels, options.size);
  std::vector<vtkImageData*> xrays, rois;
  for (size_t v = 0; v < panels.size(); ++v)
  {
    inputs.xrays.push_back(ReadXRayImage(options.xrays[v]));
    xrays.push_back(inputs.xrays.back());
    if (!options.rois.empty())
    {
      inputs.rois.push_back(ReadMaskPNG(options.rois[v], panels[v].Columns(), panels[v].Rows()));
      rois.push_back(inputs.rois.back());
    }
  }
  // An image intensifier's black corners are no anatomy: its disc joins the ROI.
  bool anyField = false;
  for (size_t v = 0; v < panels.size(); ++v)
  {
    inputs.fields.push_back(FindCircularField(RowsTopFirst<uint16_t>(xrays[v]), panels[v].Columns(), panels[v].Rows()));
    anyField = anyField || inputs.fields.back().found;
  }
  if (anyField)
  {
    for (size_t v = 0; v < panels.size(); ++v)
    {
      std::vector<uint8_t> roi = rois.empty() ? std::vector<uint8_t>(static_cast<size_t>(panels[v].Columns()) * panels[v].Rows(), 1)
                                              : RowsTopFirst<uint8_t>(rois[v]);
      const CircularField& field = inputs.fields[v];
      for (size_t i = 0; field.found && i < roi.size(); ++i)
        roi[i] &= field.mask[i];
      if (static_cast<size_t>(v) < inputs.rois.size())
        inputs.rois[v] = ImageFromRowsTopFirst(roi, panels[v].Columns(), panels[v].Rows());
      else
        inputs.rois.push_back(ImageFromRowsTopFirst(roi, panels[v].Columns(), panels[v].Rows()));
    }
    rois.clear();
    for (const auto& roi : inputs.rois)
      rois.push_back(roi);
  }
  // The registration filter's own checks, here before any work and naming the files.
  inputs.views = vtkXPStereoRegistrationFilter::PrepareViews(setup.geometry, xrays, rois, inputs.shrinkFactor, options.xrays);
  vtkImageData* ct = setup.ct.image;
  inputs.isoInCT = setup.patient.IsocenterInCT(ImageCenter(ct));
  inputs.planned = setup.patient.PlannedCTToRoom(ImageCenter(ct));
  return inputs;
}

namespace
{

/** A TIFF volume has no planned set-up to start from: the global search finds the start. */
bool UsesGlobalSearch(const RegisterOptions& options)
{
  return options.globalSearch || (options.initialPose.empty() && IsTIFFVolumePath(options.ct));
}

/** The start of a registration that has none (xpGlobalSearch.h): the best candidate. */
Pose FoundStart(const RegistrationInputs& inputs, const RegisterOptions& options)
{
  const Clock::time_point start = Clock::now();
  const std::unique_ptr<AttenuationVolume> volume = MakeAttenuationVolume(inputs.setup.ct.image, options.muWater);
  const std::vector<GlobalCandidate> candidates = FindGlobalStarts(*volume, inputs.planned, inputs.setup.geometry.isocenter,
    inputs.planned * ImageCenter(inputs.setup.ct.image), inputs.views);
  if (candidates.empty())
    throw InputError("--global-search", "no orientation of the volume matches both X-rays: give --initial-pose");
  for (const GlobalCandidate& candidate : candidates)
    std::printf("  candidate %s: correlation %.3f\n", candidate.pose.ToString().c_str(), candidate.score);
  std::printf("global search: start %s (%.2f s)\n", candidates.front().pose.ToString().c_str(), Since(start));
  return candidates.front().pose;
}

/** What the registration found at each stage, after the filter has run. */
void PrintStages(const StereoRegistrationResult& result, const std::vector<RegistrationView>& views)
{
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

/** What `xpose report` needs to rebuild the pictures: the inputs, with absolute paths. */
RegistrationRecordInputs RecordedInputs(const RegisterOptions& options)
{
  const auto absolute = [](const std::string& path) { return std::filesystem::absolute(path).lexically_normal().string(); };
  RegistrationRecordInputs in;
  in.ct = absolute(options.ct);
  in.series = options.series;
  in.voxelSize = options.voxelSize;
  in.geometry = absolute(options.geometry);
  for (const std::string& xray : options.xrays)
  {
    in.xrays.push_back(absolute(xray));
    in.xrayMD5.push_back(FileMD5(xray));
  }
  for (const std::string& roi : options.rois)
    in.rois.push_back(absolute(roi));
  in.size = options.size;
  in.isocenterInCT = options.isocenterInCT;
  in.muWater = options.muWater;
  in.entropyMask = options.settings.entropyMask;
  in.removeTable = options.removeTable;
  return in;
}

/** The filter's outputs on the registration grid (DRRs, masks, entropy maps per view), then
 *  result.json, all in one staged folder that replaces an earlier run's. */
void WriteOutputs(vtkXPStereoRegistrationFilter* registration, const RegistrationRecord& record,
  const std::vector<RegistrationView>& views, const RegisterOptions& options)
{
  StagedOutputDirectory output(options.outputDirectory);
  for (size_t v = 0; v < views.size(); ++v)
  {
    const int port = 3 * static_cast<int>(v);
    const std::string& name = views[v].view.name;
    WritePNG(registration->GetOutput(port + 1), output.Path("mask_" + name + ".png"));
    WritePNG(registration->GetOutput(port), output.Path("drr_" + name + ".png"));
    if (options.settings.entropyMask)
      WritePNG(EntropyAsGrey(registration->GetOutput(port + 2)), output.Path("entropy_" + name + ".png"));
  }
  // The record last: a folder with a result.json holds that run's complete output.
  std::ofstream recordFile(output.Path("result.json"));
  recordFile << RegistrationRecordJSON(record);
  recordFile.close();
  if (!recordFile)
  {
    throw Error(options.outputDirectory + "/result.json", "cannot be written");
  }
  output.ReplaceEarlier({ "drr_*.png", "mask_*.png", "entropy_*.png" });
  output.Commit();
}

/** The CT series the DICOM output refers to, checked before any work. */
std::optional<CTSeriesInfo> DICOMOutputCT(const RegisterOptions& options)
{
  if (options.dicomOutputDirectory.empty())
    return std::nullopt;
  StagedOutputDirectory::CheckWritable(options.dicomOutputDirectory);
  return DICOMSeriesForOutput(options.ct, options.series, "--dicom-out");
}

/**
 * DICOM output: reg.dcm, the estimated misalignment in the CT's coordinates from its Frame of
 * Reference (none for a failed result), the DRRs at the planned set-up as RT Images, whole
 * panels, the references a viewer shows beside the X-rays, and with --report its summary as a
 * Secondary Capture.
 */
void WriteDICOMResult(const CTSeriesInfo& ct, const StereoRegistrationResult& result, const RegistrationInputs& inputs,
  const RegisterOptions& options)
{
  const std::string& directory = options.dicomOutputDirectory;
  StagedOutputDirectory output(directory);
  const DRRSetup& setup = inputs.setup;
  const std::string series = NewDICOMUID();
  for (size_t v = 0; v < setup.geometry.views.size(); ++v)
  {
    const XRayView& view = setup.geometry.views[v];
    setup.filter->SetView(view);
    setup.filter->SetMisalignment(Pose{});
    setup.filter->SetInputData(1, nullptr);
    setup.filter->SetOutputSize(0, 0);
    setup.filter->Update();
    WriteRTImageDRR(ct, RTImageOfLastDRR(setup, "DRR by xpose at the planned set-up"), series, static_cast<int>(v) + 1,
      output.Path("drr_" + view.name + ".dcm"));
  }
  std::string written = "the DRRs as RT Images (drr_NAME.dcm)";
  if (result.ok)
  {
    SpatialRegistration registration;
    registration.ctToSession = MisalignmentInCT(inputs.planned, result.misalignment, setup.patient.roomIsocenter);
    registration.contentDescription = "xpose: patient misalignment; table correction = inverse";
    for (const std::string& xray : options.xrays) // DICOM X-rays are the session's images
      if (const std::optional<InstanceReference> reference = ReadInstanceReference(xray))
        registration.sessionImages.push_back(*reference);
    const std::string uid = WriteSpatialRegistration(ct, registration, output.Path("reg.dcm"));
    written += " and the Spatial Registration " + uid + " (reg.dcm)";
  }
  else
  {
    written += "; no Spatial Registration: the registration failed";
  }
  if (!options.reportDirectory.empty())
  {
    // The report's summary picture as a Secondary Capture beside them, for any DICOM viewer.
    WriteSecondaryCapture(ct, options.reportDirectory + "/summary.png",
      std::string("xpose registration report: status ") + (result.ok ? "ok" : "FAILED, do not apply"), output.Path("report.dcm"));
    written += ", the report (report.dcm)";
  }
  output.ReplaceEarlier({ "reg.dcm", "drr_*.dcm", "report.dcm" });
  output.Commit();
  std::printf("DICOM: %s in %s\n", written.c_str(), directory.c_str());
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

/**
 * --pacs: the CT series and the X-rays fetched from the archive into OUT/pacs-inputs (kept, so
 * that `xpose report` can rebuild the pictures), and the options that register them from there.
 */
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
  const std::string series = options.ctSeries.empty() ? archive.CTSeriesOfStudy(options.study) : options.ctSeries;
  RegisterOptions local = options;
  local.pacs.clear();
  local.pacsCredentials.clear();
  const std::string folder = options.outputDirectory + "/pacs-inputs";
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder + "/ct");
  archive.FetchSeries(series, folder + "/ct");
  local.ct = folder + "/ct";
  local.series = series;
  for (size_t v = 0; v < options.xrayInstances.size(); ++v)
  {
    local.xrays.push_back(folder + "/xray_" + std::to_string(v + 1) + ".dcm");
    archive.FetchInstance(options.xrayInstances[v], local.xrays.back());
  }
  if (local.dicomOutputDirectory.empty())
    local.dicomOutputDirectory = options.outputDirectory + "/dicom";
  std::printf("pacs: CT series %s and %zu X-rays fetched from %s into %s\n", series.c_str(), local.xrays.size(),
    archive.Address().c_str(), folder.c_str());
  return local;
}

/**
 * The DICOM results stored in the archive: the RT Image DRRs and the report's Secondary Capture,
 * then the REG (written for an ok result only), last: an archive cannot take an instance back, so
 * the REG that a planning system acts on is stored only when everything it refers to was.
 */
void StoreInArchive(const DICOMArchive& archive, const std::string& dicomDirectory)
{
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dicomDirectory))
    if (entry.path().extension() == ".dcm" && entry.path().filename() != "reg.dcm")
      files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  if (std::filesystem::exists(dicomDirectory + "/reg.dcm"))
    files.push_back(dicomDirectory + "/reg.dcm");
  archive.Store(files);
  std::printf("pacs: %zu DICOM objects stored in %s\n", files.size(), archive.Address().c_str());
}

void PrintResult(const StereoRegistrationResult& result, double totalSeconds, const std::string& outputDirectory)
{
  std::printf("\n%s\nmisalignment: %s\ncorrection:   %s\n(IEC 61217 fixed, R = Rz(yaw) Ry(roll) Rx(pitch); apply the "
              "correction to the table only when status is ok)\nDRRs: %lld, evaluations: %d, total %.2f s; result.json in %s\n",
    result.ok ? "status: ok" : "status: FAILED", result.misalignment.ToString().c_str(),
    result.correction.ToString().c_str(), result.drrCount, result.evaluations, totalSeconds, outputDirectory.c_str());
  for (const std::string& reason : result.Reasons())
    std::printf("  reason: %s\n", reason.c_str());
}

} // namespace

int RunRegister(const RegisterOptions& options)
{
  if (!options.pacs.empty())
  {
    const std::unique_ptr<DICOMArchive> opened =
      OpenArchive(options.pacs, ResolveArchiveAccess(options.pacsCredentials, options.caFile), options.aet);
    const DICOMArchive& archive = *opened;
    const RegisterOptions local = FetchFromArchive(options, archive);
    const int code = RunRegister(local);
    StoreInArchive(archive, local.dicomOutputDirectory);
    return code;
  }
  if (options.ct.empty() || options.xrays.empty())
    throw InputError(options.ct.empty() ? "--ct" : "--xray", "is required (or --pacs with --study or --ct-series and --xray-instance)");
  const Clock::time_point start = Clock::now();
  UseThreads(options.threads);
  CheckRegistrationSettings(options.settings);
  StereoRegistrationSettings optimizers;
  SetOptimizers(options.optimizer, optimizers, "--optimizer"); // checked before the CT is read
  if (!options.initialPose.empty())
    Pose::Parse(options.initialPose, "--initial-pose");
  // Output folders are checked before the work, not after it: a registration whose result
  // cannot be written must not run for seconds and then fail.
  StagedOutputDirectory::CheckWritable(options.outputDirectory);
  if (!options.reportDirectory.empty())
    StagedOutputDirectory::CheckWritable(options.reportDirectory);
  // Every input is read and checked before any work.
  const std::optional<CTSeriesInfo> dicomCT = DICOMOutputCT(options);
  const RegistrationInputs inputs = LoadRegistrationInputs(options);
  const DRRSetup& setup = inputs.setup;
  if (dicomCT)
    CheckRTImageViews(setup.geometry, "--dicom-out");
  WarnOfGeometryTags(options, setup);
  const double readSeconds = Since(start);
  std::printf("read: CT %s, %zu X-rays, registering at %dx%d per view (%.2f s)\n", options.ct.c_str(), inputs.views.size(),
    inputs.views[0].view.Columns(), inputs.views[0].view.Rows(), readSeconds);
  if (options.removeTable)
    std::printf("table: %lld voxels outside the body set to air\n", inputs.tableVoxelsRemoved);
  for (size_t v = 0; v < inputs.fields.size(); ++v)
    if (inputs.fields[v].found)
      std::printf("view %s: an image intensifier's circular field, centre (%.0f, %.0f) px, radius %.0f px: its outside is "
                  "left out\n", inputs.views[v].view.name.c_str(), inputs.fields[v].center[0], inputs.fields[v].center[1],
        inputs.fields[v].radius);

  // The method: the registration filter (Modules/Registration).
  vtkNew<vtkXPStereoRegistrationFilter> registration;
  registration->SetCTData(setup.ct.image);
  for (vtkImageData* xray : inputs.xrays)
    registration->AddXRayData(xray);
  for (vtkImageData* roi : inputs.rois)
    registration->AddROIData(roi);
  registration->SetGeometry(setup.geometry);
  registration->SetPatientSetup(setup.patient);
  registration->SetMuWater(options.muWater);
  registration->SetShrinkFactor(inputs.shrinkFactor);
  StereoRegistrationSettings settings = options.settings;
  SetOptimizers(options.optimizer, settings, "--optimizer");
  if (!options.initialPose.empty())
    settings.initialPose = Pose::Parse(options.initialPose, "--initial-pose");
  else if (UsesGlobalSearch(options))
    settings.initialPose = FoundStart(inputs, options);
  registration->SetSettings(settings);
  const StageLogger logger(registration);
  registration->Update();
  const StereoRegistrationResult& result = registration->GetResult();
  if (!result.failures.empty() && result.failures.front().code == GateCode::InvalidInput)
    throw InputError("registration", result.failures.front().message);
  PrintStages(result, inputs.views);

  std::vector<std::string> viewNames;
  for (const RegistrationView& item : inputs.views)
    viewNames.push_back(item.view.name);
  RegistrationRecord record = MakeRegistrationRecord(result, viewNames);
  record.readSeconds = readSeconds;
  record.totalSeconds = Since(start);
  record.inputs = RecordedInputs(options);
  record.volumeToRoom = MisalignedCTToRoom(inputs.planned, result.misalignment, inputs.setup.patient.roomIsocenter);
  record.volumeCenter = ImageCenter(inputs.setup.ct.image);
  WriteOutputs(registration, record, inputs.views, options);
  PrintResult(result, record.totalSeconds, options.outputDirectory);
  if (!options.reportDirectory.empty())
  {
    ReportOptions report;
    report.result = options.outputDirectory + "/result.json";
    report.outputDirectory = options.reportDirectory;
    RunReport(report);
  }
  if (dicomCT)
    WriteDICOMResult(*dicomCT, result, inputs, options);
  return result.ok ? ExitOk : ExitRegistrationFailed;
}

} // namespace xp
