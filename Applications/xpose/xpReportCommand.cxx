#include "xpCommands.h"
#include "xpRegistrationInputs.h"

#include "xpEntropyMask.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpReport.h"
#include "xpRoomScene.h"

#include <vtkImageData.h>
#include <vtk_jsoncpp.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

/** result.json, with errors that name the file and the field. */
class ResultFile
{
public:
  explicit ResultFile(const std::string& path)
    : Path(path)
  {
    std::ifstream in(path);
    if (!in)
      throw InputError(path, "cannot be read");
    Json::CharReaderBuilder builder;
    std::string errors;
    if (!Json::parseFromStream(builder, in, &this->Root, &errors) || !this->Root.isObject())
      throw InputError(path, "is not valid JSON: " + errors);
  }

  const Json::Value& At(const std::string& dottedField) const
  {
    const Json::Value* value = &this->Root;
    std::stringstream parts(dottedField);
    std::string key;
    while (std::getline(parts, key, '.'))
    {
      if (!value->isObject() || !value->isMember(key))
        throw InputError(this->Path, "field '" + dottedField + "' is missing (was it written by xpose register of this version?)");
      value = &(*value)[key];
    }
    return *value;
  }
  double Number(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isNumeric())
      throw InputError(this->Path, "field '" + field + "' must be a number");
    return value.asDouble();
  }
  std::string Text(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isString())
      throw InputError(this->Path, "field '" + field + "' must be a string");
    return value.asString();
  }
  bool Bool(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isBool())
      throw InputError(this->Path, "field '" + field + "' must be true or false");
    return value.asBool();
  }
  std::vector<double> Numbers(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isArray())
      throw InputError(this->Path, "field '" + field + "' must list numbers");
    std::vector<double> numbers;
    for (const Json::Value& item : value)
    {
      if (!item.isNumeric())
        throw InputError(this->Path, "field '" + field + "' must list numbers");
      numbers.push_back(item.asDouble());
    }
    return numbers;
  }
  std::vector<std::string> Texts(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isArray())
      throw InputError(this->Path, "field '" + field + "' must list strings");
    std::vector<std::string> texts;
    for (const Json::Value& item : value)
    {
      if (!item.isString())
        throw InputError(this->Path, "field '" + field + "' must list strings");
      texts.push_back(item.asString());
    }
    return texts;
  }
  Pose PoseAt(const std::string& field) const
  {
    const std::vector<double> t = this->Numbers(field + ".translation_mm");
    if (t.size() != 3)
      throw InputError(this->Path, "field '" + field + ".translation_mm' must hold 3 numbers");
    Pose pose;
    pose.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    pose.pitch = this->Number(field + ".rotation_deg.pitch");
    pose.roll = this->Number(field + ".rotation_deg.roll");
    pose.yaw = this->Number(field + ".rotation_deg.yaw");
    return pose;
  }

  std::string Path;
  Json::Value Root;
};

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
  const ResultFile result(options.result);
  const std::string resultFolder = std::filesystem::path(options.result).parent_path().string();
  const std::string directory =
    options.outputDirectory.empty() ? (resultFolder.empty() ? std::string("report") : resultFolder + "/report") : options.outputDirectory;

  RegisterOptions inputsOf;
  inputsOf.ct = result.Text("inputs.ct");
  inputsOf.series = result.Text("inputs.series");
  inputsOf.geometry = result.Text("inputs.geometry");
  inputsOf.xrays = result.Texts("inputs.xrays");
  inputsOf.rois = result.Texts("inputs.rois");
  inputsOf.size = result.Text("inputs.size");
  inputsOf.isocenterInCT = result.Text("inputs.iso_ct");
  inputsOf.muWater = result.Number("inputs.mu_water");
  const bool entropyMask = result.Bool("inputs.entropy_mask");
  inputsOf.removeTable = result.Bool("inputs.remove_table");
  // The report shows the registered X-rays: a file changed since (or replaced) is refused.
  const std::vector<std::string> md5 = result.Texts("inputs.xray_md5");
  if (md5.size() != inputsOf.xrays.size())
    throw InputError(options.result, "field 'inputs.xray_md5' must hold one MD5 per X-ray");
  for (size_t v = 0; v < md5.size(); ++v)
  {
    if (FileMD5(inputsOf.xrays[v]) != md5[v])
      throw InputError(inputsOf.xrays[v], "differs from the X-ray that was registered (MD5 " + md5[v] +
          " in " + options.result + "): the report would show other images than the result is based on");
  }
  RegistrationInputs inputs = LoadRegistrationInputs(inputsOf);

  ReportContent content;
  content.ok = result.Text("status") == "ok";
  content.reasons = result.Texts("reasons");
  content.misalignment = result.PoseAt("misalignment");
  content.correction = result.PoseAt("correction");
  content.convention = result.Text("convention");
  content.objective = result.Number("similarity.objective");
  content.drrCount = static_cast<long long>(result.Number("drr_count"));
  content.evaluations = static_cast<int>(result.Number("evaluations"));
  for (const char* stage : { "read", "prealign", "mask", "fine", "total" })
    content.seconds.emplace_back(stage, result.Number(std::string("timing_s.") + stage));
  content.trace = result.Numbers("convergence.objective");
  const Json::Value& stages = result.At("convergence.stages");
  for (Json::ArrayIndex n = 0; stages.isArray() && n < stages.size(); ++n)
  {
    const Json::Value& stage = stages[n];
    if (!stage.isObject() || !stage["name"].isString() || !stage["first_evaluation"].isInt())
      throw InputError(options.result, "field 'convergence.stages' must list {name, first_evaluation}");
    content.stages.emplace_back(stage["name"].asString(), stage["first_evaluation"].asInt());
  }
  content.title = "CT " + inputsOf.ct + "; X-rays";
  for (const std::string& xray : inputsOf.xrays)
    content.title += " " + xray;

  vtkXPDRRFilter* drr = inputs.setup.filter;
  for (const RegistrationView& item : inputs.views)
  {
    const XRayView& view = item.view;
    ReportView v;
    v.name = view.name;
    v.columns = view.Columns();
    v.rows = view.Rows();
    v.xray = item.xray;
    v.roi = item.mask;
    v.mask = RowsTopFirst<uint8_t>(ReadMaskPNG(resultFolder + "/mask_" + view.name + ".png", v.columns, v.rows));
    if (entropyMask) // the same computation as the registration's, from the same X-ray and ROI
      v.entropy = ComputeEntropyMask(v.xray.data(), v.columns, v.rows, v.roi.empty() ? nullptr : v.roi.data()).entropy;
    v.drrStart = RenderDRR(drr, view, Pose{});
    v.drrFinal = RenderDRR(drr, view, content.misalignment);
    v.similarity = result.Number("similarity." + view.name);
    v.explained = result.Number("explained_information." + view.name);
    v.validFraction = result.Number("mask_valid_fraction." + view.name);
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
