#include "xpCommands.h"
#include "xpRegistrationSources.h"

#include "xpError.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpRegistrationRecord.h"
#include "xpReport.h"
#include "xpReportContent.h"
#include "xpRoomScene.h"
#include "xpVirtualDisplay.h"

#include <vtkImageData.h>

#include <cstdio>
#include <memory>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

/** The recorded inputs as the session's sources, each X-ray checked to be the one registered. */
RegistrationSources RecordedSources(const RegistrationRecordInputs& recorded, const std::string& recordPath)
{
  RegistrationSources inputsOf;
  static_cast<RegistrationFiles&>(inputsOf) = recorded;
  for (size_t v = 0; v < inputsOf.xrays.size(); ++v)
  {
    if (FileMD5(inputsOf.xrays[v]) != recorded.xrayMD5[v])
      throw InputError(inputsOf.xrays[v], "differs from the X-ray that was registered (MD5 " + recorded.xrayMD5[v] +
          " in " + recordPath + "): the report would show other images than the result is based on");
  }
  return inputsOf;
}

/**
 * The 3D room scene, rendered on the current X display or on an Xvfb started for it (the
 * command owns the display, not the report); without either, the report says why.
 */
void RenderRoom(const RegistrationInputs& inputs, ReportContent& content)
{
  std::string reason;
  const std::unique_ptr<VirtualDisplay> display = VirtualDisplay::Ensure(reason);
  if (!display)
  {
    content.roomNote = "the 3D scene was not rendered: " + reason;
    std::fprintf(stderr, "xpose report: warning: %s\n", content.roomNote.c_str());
    return;
  }
  RoomScene scene(inputs.setup.geometry);
  scene.SetCT(inputs.setup.ct.image, inputs.planned);
  scene.SetMisalignment(content.misalignment);
  content.room = scene.Render(1200, 600);
}

} // namespace

void WriteReportOf(
  const RegistrationRecord& result, const RegistrationInputs& inputs, const std::string& resultFolder, const std::string& directory)
{
  const std::string origin = resultFolder + "/result.json";
  if (!result.inputs)
    throw InputError(origin, "field 'inputs' is missing: the report needs the files xpose register read");
  const RegistrationRecordInputs& recorded = *result.inputs;
  std::string title = "CT " + recorded.ct + "; X-rays";
  for (const std::string& xray : recorded.xrays)
    title += " " + xray;
  ReportContent content = ReportContentOf(result, title);
  for (size_t index = 0; index < inputs.views.size(); ++index)
  {
    const XRayView& view = inputs.views[index].view;
    if (index >= result.viewNames.size() || result.viewNames[index] != view.name)
      throw InputError(origin, "field 'views' does not list imager " + view.name + " of " + recorded.geometry);
    std::vector<uint8_t> mask =
      RowsTopFirst<uint8_t>(ReadMaskPNG(resultFolder + "/mask_" + view.name + ".png", view.Columns(), view.Rows()));
    content.views.push_back(
      ReportViewOf(result, index, inputs.views[index], std::move(mask), recorded.entropyMask, inputs.setup.filter));
  }
  RenderRoom(inputs, content);
  WriteReport(content, directory);
  std::printf("report: %s/index.html and %s/summary.png\n", directory.c_str(), directory.c_str());
}

int RunReport(const ReportOptions& options)
{
  const RegistrationRecord result = ReadRegistrationRecord(options.result);
  if (!result.inputs)
    throw InputError(options.result, "field 'inputs' is missing: the report needs the files xpose register read");
  const std::string resultFolder = std::filesystem::path(options.result).parent_path().string();
  const std::string directory =
    options.outputDirectory.empty() ? (resultFolder.empty() ? std::string("report") : resultFolder + "/report") : options.outputDirectory;
  // The inputs as recorded, each X-ray checked to be the one registered.
  const RegistrationInputs inputs = ReadRegistrationInputs(RecordedSources(*result.inputs, options.result));
  WriteReportOf(result, inputs, resultFolder.empty() ? "." : resultFolder, directory);
  return ExitOk;
}

} // namespace xp
