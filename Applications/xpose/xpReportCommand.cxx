#include "xpCommands.h"
#include "xpRegistrationInputs.h"

#include "xpEntropyMask.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpRegistrationRecord.h"
#include "xpReport.h"
#include "xpRoomScene.h"

#include <vtkImageData.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

/** The whole-image 12-bit DRR of `view` at `misalignment`. */
std::vector<uint16_t> RenderDRR(vtkXPDRRFilter* filter, const XRayView& view, const Pose& misalignment)
{
  filter->SetView(view);
  filter->SetMisalignment(misalignment);
  filter->Update();
  return RowsTopFirst<uint16_t>(filter->GetOutput(0));
}

} // namespace

int RunReport(const ReportOptions& options)
{
  const RegistrationRecord result = ReadRegistrationRecord(options.result);
  if (!result.inputs)
    throw InputError(options.result, "field 'inputs' is missing: the report needs the files xpose register read");
  const RegistrationRecordInputs& recorded = *result.inputs;
  const std::string resultFolder = std::filesystem::path(options.result).parent_path().string();
  const std::string directory =
    options.outputDirectory.empty() ? (resultFolder.empty() ? std::string("report") : resultFolder + "/report") : options.outputDirectory;

  RegisterOptions inputsOf;
  inputsOf.ct = recorded.ct;
  inputsOf.series = recorded.series;
  inputsOf.geometry = recorded.geometry;
  inputsOf.xrays = recorded.xrays;
  inputsOf.rois = recorded.rois;
  inputsOf.size = recorded.size;
  inputsOf.isocenterInCT = recorded.isocenterInCT;
  inputsOf.muWater = recorded.muWater;
  inputsOf.removeTable = recorded.removeTable;
  for (size_t v = 0; v < inputsOf.xrays.size(); ++v)
  {
    if (FileMD5(inputsOf.xrays[v]) != recorded.xrayMD5[v])
      throw InputError(inputsOf.xrays[v], "differs from the X-ray that was registered (MD5 " + recorded.xrayMD5[v] +
          " in " + options.result + "): the report would show other images than the result is based on");
  }
  RegistrationInputs inputs = LoadRegistrationInputs(inputsOf);

  ReportContent content;
  content.ok = result.ok;
  content.reasons = result.Reasons();
  content.misalignment = result.misalignment;
  content.correction = result.correction;
  content.convention = CorrectionConvention;
  content.objective = result.objective;
  content.drrCount = result.drrCount;
  content.evaluations = result.evaluations;
  content.seconds = { { "read", result.readSeconds }, { "prealign", result.prealignSeconds }, { "mask", result.maskSeconds },
    { "fine", result.fineSeconds }, { "total", result.totalSeconds } };
  content.trace = result.objectiveTrace;
  for (const RegistrationStage& stage : result.stages)
    content.stages.emplace_back(stage.name, stage.firstEvaluation);
  content.title = "CT " + inputsOf.ct + "; X-rays";
  for (const std::string& xray : inputsOf.xrays)
    content.title += " " + xray;

  vtkXPDRRFilter* drr = inputs.setup.filter;
  for (size_t index = 0; index < inputs.views.size(); ++index)
  {
    const RegistrationView& item = inputs.views[index];
    const XRayView& view = item.view;
    ReportView v;
    v.name = view.name;
    v.columns = view.Columns();
    v.rows = view.Rows();
    v.xray = item.xray;
    v.roi = item.mask;
    v.mask = RowsTopFirst<uint8_t>(ReadMaskPNG(resultFolder + "/mask_" + view.name + ".png", v.columns, v.rows));
    if (recorded.entropyMask) // the same computation as the registration's, from the same X-ray and ROI
      v.entropy = ComputeEntropyMask(v.xray.data(), v.columns, v.rows, v.roi.empty() ? nullptr : v.roi.data()).entropy;
    v.drrStart = RenderDRR(drr, view, Pose{});
    v.drrFinal = RenderDRR(drr, view, content.misalignment);
    if (index >= result.viewNames.size() || result.viewNames[index] != view.name)
      throw InputError(options.result, "field 'views' does not list imager " + view.name + " of " + recorded.geometry);
    v.similarity = result.similarity[index];
    v.explained = result.explained[index];
    v.validFraction = result.validFraction[index];
    content.views.push_back(std::move(v));
  }

  RoomScene scene(inputs.setup.geometry);
  scene.SetCT(inputs.setup.ct.image, inputs.planned);
  scene.SetMisalignment(content.misalignment);
  const std::string warning = WriteReport(content, &scene, directory);
  if (!warning.empty())
    std::fprintf(stderr, "xpose report: warning: %s\n", warning.c_str());
  std::printf("report: %s/index.html and %s/summary.png\n", directory.c_str(), directory.c_str());
  return ExitOk;
}

} // namespace xp
