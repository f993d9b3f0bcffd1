#include "xpRegistrationRecord.h"

#include "xpError.h"
#include "xpValueText.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <cmath>
#include <functional>
#include <iterator>
#include <limits>
#include <fstream>
#include <memory>
#include <sstream>

namespace xp
{

namespace
{

/** The pose's axes as the record names them (`uncertainty`, `held_out_leads`). */
const char* const axes[6] = { "tx_mm", "ty_mm", "tz_mm", "pitch_deg", "roll_deg", "yaw_deg" };

Json::Value PoseValue(const Pose& pose)
{
  Json::Value value(Json::objectValue);
  Json::Value& t = value["translation_mm"] = Json::Value(Json::arrayValue);
  for (int a = 0; a < 3; ++a)
    t.append(pose.translation[a]);
  value["rotation_deg"]["pitch"] = pose.pitch;
  value["rotation_deg"]["roll"] = pose.roll;
  value["rotation_deg"]["yaw"] = pose.yaw;
  return value;
}

Json::Value PerView(const std::vector<std::string>& names, const std::vector<double>& values)
{
  Json::Value value(Json::objectValue);
  for (size_t v = 0; v < names.size() && v < values.size(); ++v)
    value[names[v]] = values[v];
  return value;
}

template <typename T>
Json::Value List(const std::vector<T>& items)
{
  Json::Value value(Json::arrayValue);
  for (const T& item : items)
    value.append(item);
  return value;
}

Json::Value PointValue(const Eigen::Vector3d& point)
{
  Json::Value value(Json::arrayValue);
  for (int a = 0; a < 3; ++a)
    value.append(point[a]);
  return value;
}

/** result.json's `couch`: the couch motion of an ok result in the terms of `correction`. */
Json::Value CouchValue(const CouchMotion& c, const ActionLevels& levels, const Eigen::Vector3d& targetInCT)
{
  Json::Value value = PoseValue(c.motion); // translation_mm and rotation_deg, as every pose of the record
  value["couch"] = CouchMotionsName(c.couch.motions);
  value["motions"] = List(CouchMotionList(c.couch.motions));
  value["rotation_limit_deg"] = std::isfinite(c.couch.pitchRollLimitDegrees) ? Json::Value(c.couch.pitchRollLimitDegrees)
                                                                               : Json::Value(Json::nullValue);
  value["rotation_center"] = PointValue(c.rotationCenter);
  value["target_ct"] = PointValue(targetInCT);
  value["target_room"] = PointValue(c.target);
  value["uncorrected_rotation_deg"] = PoseValue(c.uncorrected)["rotation_deg"];
  value["uncorrected_translation_mm"] = PointValue(c.uncorrected.translation);
  value["uncorrected_mm_at_50"] = c.uncorrectedAt50MM;
  value["uncorrected_mm_at_100"] = c.uncorrectedAt100MM;
  value["limited_by"] = List(c.limitedBy);
  value["action"] = CouchActionName(c.action);
  value["action_reason"] = c.actionReason;
  const auto limit = [](double v) { return std::isfinite(v) ? Json::Value(v) : Json::Value(Json::nullValue); };
  value["action_levels"]["mm"] = levels.actionMM;
  value["action_levels"]["deg"] = levels.actionDegrees;
  value["action_levels"]["max_uncorrected_mm"] = limit(levels.maxUncorrectedMM);
  value["action_levels"]["max_uncorrected_deg"] = limit(levels.maxUncorrectedDegrees);
  return value;
}

/** result.json's `inputs`. */
Json::Value InputsValue(const RegistrationRecordInputs& in)
{
  Json::Value inputs(Json::objectValue);
  inputs["ct"] = in.ct;
  inputs["series"] = in.series;
  inputs["voxel_size"] = in.voxelSize ? PointText(*in.voxelSize) : "";
  inputs["geometry"] = in.geometry;
  inputs["xrays"] = List(in.xrays);
  inputs["xray_md5"] = List(in.xrayMD5);
  inputs["rois"] = List(in.rois);
  inputs["size"] = in.size ? SizeText(*in.size) : "";
  inputs["iso_ct"] = in.isocenterInCT ? PointText(*in.isocenterInCT) : "";
  inputs["mu_water"] = in.muWater;
  inputs["entropy_mask"] = in.entropyMask;
  inputs["remove_table"] = in.removeTable;
  return inputs;
}

/** result.json's `convergence`: each stage's span of the objective's trace, and the trace. */
Json::Value ConvergenceValue(const RegistrationRecord& r)
{
  Json::Value convergence(Json::objectValue);
  Json::Value& stages = convergence["stages"] = Json::Value(Json::arrayValue);
  for (const RegistrationStage& stage : r.stages)
  {
    Json::Value item(Json::objectValue);
    item["name"] = stage.name;
    item["first_evaluation"] = stage.firstEvaluation;
    item["evaluations"] = stage.evaluations;
    if (stage.modelEvaluations > 0)
      item["model_evaluations"] = stage.modelEvaluations;
    item["image_divisor"] = stage.imageDivisor;
    item["kind"] = StageKindName(stage.kind);
    if (stage.secondEnd)
      item["second_end"] = true;
    item["seconds"] = stage.seconds;
    stages.append(item);
  }
  convergence["objective"] = List(r.objectiveTrace);
  return convergence;
}

/** result.json's `schedule`: the stages as scheduled, with each search's optimiser. */
Json::Value ScheduleValue(const RegistrationSchedule& s)
{
  Json::Value schedule(Json::arrayValue);
  for (const ScheduledStage& stage : s.stages)
  {
    Json::Value item(Json::objectValue);
    item["kind"] = StageKindName(stage.kind);
    item["name"] = stage.name;
    item["image_divisor"] = stage.imageDivisor;
    if (stage.kind == StageKind::Search)
      item["track"] = stage.track;
    if (stage.kind == StageKind::Search || stage.kind == StageKind::Refinement)
      item["stops_at_first_track_end"] = stage.stopAtFirstEnd;
    if (stage.kind == StageKind::Search && stage.joinsFirstTrack)
      item["joins_first_track"] = true;
    if (stage.kind == StageKind::Refinement)
      item["linearized"] = stage.linearized;
    if (stage.kind == StageKind::Search)
      item["high_pass_mm"] = stage.highPassMM;
    if (stage.kind == StageKind::Search || stage.kind == StageKind::Refinement || stage.kind == StageKind::Restarts)
    {
      const PoseOptimizerSettings& o = stage.optimizer;
      Json::Value& optimizer = item["optimizer"];
      optimizer["method"] = PoseOptimizerMethodName(o.method);
      optimizer["step_mm"] = o.initialStepMM;
      optimizer["step_deg"] = o.initialStepDegrees;
      optimizer["tolerance_mm"] = o.toleranceMM;
      optimizer["tolerance_deg"] = o.toleranceDegrees;
      optimizer["max_evaluations"] = o.maxEvaluations;
      optimizer["restarts"] = o.maxRestarts;
    }
    if (stage.rounds > 0)
      item["rounds"] = stage.rounds;
    if (stage.kind == StageKind::Polish)
    {
      item["stop_mm"] = stage.optimizer.toleranceMM;
      item["stop_deg"] = stage.optimizer.toleranceDegrees;
    }
    schedule.append(item);
  }
  return schedule;
}

/** A parsed record with errors that name the file and the field. */
class Fields
{
public:
  Fields(const Json::Value& root, const std::string& origin) : Root(root), Origin(origin) {}

  const Json::Value& At(const std::string& dottedField) const
  {
    const Json::Value* value = &this->Root;
    std::stringstream parts(dottedField);
    std::string key;
    while (std::getline(parts, key, '.'))
    {
      if (!value->isObject() || !value->isMember(key))
        this->Fail(dottedField, "is missing (was it written by xpose register of this version?)");
      value = &(*value)[key];
    }
    return *value;
  }
  bool Has(const std::string& field) const { return this->Root.isMember(field); }
  double Number(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isNumeric())
      this->Fail(field, "must be a number");
    return value.asDouble();
  }
  std::string Text(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isString())
      this->Fail(field, "must be a string");
    return value.asString();
  }
  bool Bool(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isBool())
      this->Fail(field, "must be true or false");
    return value.asBool();
  }
  std::vector<double> Numbers(const std::string& field) const
  {
    std::vector<double> numbers;
    for (const Json::Value& item : this->Array(field))
    {
      if (!item.isNumeric())
        this->Fail(field, "must list numbers");
      numbers.push_back(item.asDouble());
    }
    return numbers;
  }
  std::vector<std::string> Texts(const std::string& field) const
  {
    std::vector<std::string> texts;
    for (const Json::Value& item : this->Array(field))
    {
      if (!item.isString())
        this->Fail(field, "must list strings");
      texts.push_back(item.asString());
    }
    return texts;
  }
  const Json::Value& Array(const std::string& field) const
  {
    const Json::Value& value = this->At(field);
    if (!value.isArray())
      this->Fail(field, "must be a list");
    return value;
  }
  Pose PoseAt(const std::string& field) const
  {
    const std::vector<double> t = this->Numbers(field + ".translation_mm");
    if (t.size() != 3)
      this->Fail(field + ".translation_mm", "must hold 3 numbers");
    Pose pose;
    pose.translation = Eigen::Vector3d(t[0], t[1], t[2]);
    pose.pitch = this->Number(field + ".rotation_deg.pitch");
    pose.roll = this->Number(field + ".rotation_deg.roll");
    pose.yaw = this->Number(field + ".rotation_deg.yaw");
    return pose;
  }
  std::vector<double> PerViewNumbers(const std::string& field, const std::vector<std::string>& names) const
  {
    std::vector<double> values;
    for (const std::string& name : names)
      values.push_back(this->Number(field + "." + name));
    return values;
  }
  /** The file and the field, as Fail names them: for a parser that throws its own refusal. */
  std::string Where(const std::string& field) const { return this->Origin + ": field '" + field + "'"; }

  [[noreturn]] void Fail(const std::string& field, const std::string& what) const
  {
    throw InputError(this->Origin, "field '" + field + "' " + what);
  }

private:
  const Json::Value& Root;
  std::string Origin;
};

/** result.json's `couch` block (CouchValue's), the target it puts back and the action levels. */
CouchMotion CouchAt(const Fields& f, Eigen::Vector3d& targetInCT, ActionLevels& levels)
{
  CouchMotion c;
  const std::string motions = f.Text("couch.couch");
  if (motions != "6dof" && motions != "4dof")
    f.Fail("couch.couch", "must be 6dof or 4dof");
  c.couch.motions = ParseCouchMotions(motions, "couch.couch");
  // A limit is a number, or null where there is none (CouchValue); anything else is refused.
  const auto limit = [&f](const std::string& field)
  {
    if (f.At(field).isNull())
      return std::numeric_limits<double>::infinity();
    const double value = f.Number(field);
    if (!(std::isfinite(value) && value >= 0.0))
      f.Fail(field, "must be a number of at least 0, or null for none");
    return value;
  };
  c.couch.pitchRollLimitDegrees = limit("couch.rotation_limit_deg");
  const auto point = [&f](const std::string& field)
  {
    const std::vector<double> p = f.Numbers(field);
    if (p.size() != 3)
      f.Fail(field, "must hold 3 numbers");
    return Eigen::Vector3d(p[0], p[1], p[2]);
  };
  const auto angles = [&f](const std::string& field, Pose& pose)
  {
    pose.pitch = f.Number(field + ".pitch");
    pose.roll = f.Number(field + ".roll");
    pose.yaw = f.Number(field + ".yaw");
  };
  c.motion = f.PoseAt("couch"); // translation_mm and rotation_deg, as every pose of the record
  c.rotationCenter = point("couch.rotation_center");
  c.couch.rotationCenter = c.rotationCenter;
  targetInCT = point("couch.target_ct");
  c.target = point("couch.target_room");
  angles("couch.uncorrected_rotation_deg", c.uncorrected);
  c.uncorrected.translation = point("couch.uncorrected_translation_mm");
  c.uncorrectedAt50MM = f.Number("couch.uncorrected_mm_at_50");
  c.uncorrectedAt100MM = f.Number("couch.uncorrected_mm_at_100");
  c.limitedBy = f.Texts("couch.limited_by");
  const std::string action = f.Text("couch.action");
  bool known = false;
  for (CouchAction a : { CouchAction::NoneNeeded, CouchAction::Move, CouchAction::SetUpAgain })
    if (CouchActionName(a) == action)
    {
      c.action = a;
      known = true;
    }
  if (!known)
    f.Fail("couch.action", "must be none_needed, move or set_up_again");
  c.actionReason = f.Text("couch.action_reason");
  levels.actionMM = f.Number("couch.action_levels.mm");
  levels.actionDegrees = f.Number("couch.action_levels.deg");
  levels.maxUncorrectedMM = limit("couch.action_levels.max_uncorrected_mm");
  levels.maxUncorrectedDegrees = limit("couch.action_levels.max_uncorrected_deg");
  return c;
}

/** result.json's `inputs`: the files and options a command registered. */
RegistrationRecordInputs InputsAt(const Fields& f, const Json::Value& inputs)
{
  RegistrationRecordInputs in;
  in.ct = f.Text("inputs.ct");
  in.series = f.Text("inputs.series");
  // Each written as its option is given, empty where it was not; voxel_size is absent in records
  // written before TIFF volumes.
  if (inputs.isMember("voxel_size") && !f.Text("inputs.voxel_size").empty())
  {
    in.voxelSize = ParsePoint(f.Text("inputs.voxel_size"), f.Where("inputs.voxel_size"));
    if (!(in.voxelSize->minCoeff() > 0.0))
      f.Fail("inputs.voxel_size", "must be three sizes above 0 mm");
  }
  in.geometry = f.Text("inputs.geometry");
  in.xrays = f.Texts("inputs.xrays");
  in.xrayMD5 = f.Texts("inputs.xray_md5");
  in.rois = f.Texts("inputs.rois");
  if (!f.Text("inputs.size").empty())
    in.size = ParseImageSize(f.Text("inputs.size"), f.Where("inputs.size"));
  if (!f.Text("inputs.iso_ct").empty())
    in.isocenterInCT = ParsePoint(f.Text("inputs.iso_ct"), f.Where("inputs.iso_ct"));
  in.muWater = f.Number("inputs.mu_water");
  in.entropyMask = f.Bool("inputs.entropy_mask");
  in.removeTable = f.Bool("inputs.remove_table");
  if (in.xrayMD5.size() != in.xrays.size())
    f.Fail("inputs.xray_md5", "must hold one MD5 per X-ray");
  return in;
}

/** result.json's `convergence`: each stage's span of the trace, and the trace. */
void ReadConvergence(const Fields& f, RegistrationRecord& r)
{
  for (const Json::Value& stage : f.Array("convergence.stages"))
  {
    if (!stage.isObject() || !stage["name"].isString() || !stage["first_evaluation"].isInt() ||
      !stage["seconds"].isNumeric())
      f.Fail("convergence.stages", "must list {name, first_evaluation, seconds}");
    RegistrationStage read{ stage["name"].asString(), stage["first_evaluation"].asInt(), stage["seconds"].asDouble() };
    read.evaluations = stage["evaluations"].isInt() ? stage["evaluations"].asInt() : 0; // absent before the schedule
    read.imageDivisor = stage["image_divisor"].isInt() ? stage["image_divisor"].asInt() : 0;
    read.modelEvaluations = stage["model_evaluations"].isInt() ? stage["model_evaluations"].asInt() : 0;
    if (stage.isMember("kind")) // absent before the stages recorded it
    {
      const std::optional<StageKind> kind = stage["kind"].isString() ? StageKindNamed(stage["kind"].asString()) : std::nullopt;
      if (!kind)
        f.Fail("convergence.stages", "kind must be a stage kind (pre-alignment, masks, search, refinement, polish, restarts, landscape, gate)");
      read.kind = *kind;
    }
    read.secondEnd = stage["second_end"].isBool() && stage["second_end"].asBool();
    r.stages.push_back(read);
  }
  r.objectiveTrace = f.Numbers("convergence.objective");
}

/** result.json's `schedule`: the stages as scheduled. */
void ReadSchedule(const Fields& f, RegistrationRecord& r)
{
  for (const Json::Value& item : f.Array("schedule"))
  {
    ScheduledStage stage;
    const std::optional<StageKind> kind =
      item.isObject() && item["kind"].isString() ? StageKindNamed(item["kind"].asString()) : std::nullopt;
    if (kind)
      stage.kind = *kind;
    if (!kind || !item["name"].isString() || !item["image_divisor"].isInt())
      f.Fail("schedule", "must list {kind (a stage kind), name, image_divisor, ...}");
    stage.name = item["name"].asString();
    stage.imageDivisor = item["image_divisor"].asInt();
    stage.track = item["track"].isInt() ? item["track"].asInt() : 0;
    stage.stopAtFirstEnd = item["stops_at_first_track_end"].isBool() && item["stops_at_first_track_end"].asBool();
    // Written only when true; records before it ran every stage of the second track.
    stage.joinsFirstTrack = item["joins_first_track"].isBool() && item["joins_first_track"].asBool();
    // Records written before the linearized refinement rendered every evaluation.
    stage.linearized = item["linearized"].isBool() && item["linearized"].asBool();
    // Records written before the searches could high-pass kept the shading.
    stage.highPassMM = item["high_pass_mm"].isNumeric() ? item["high_pass_mm"].asDouble() : 0.0;
    stage.rounds = item["rounds"].isInt() ? item["rounds"].asInt() : 0;
    if (stage.kind == StageKind::Polish)
    {
      // Records written before the polish stopped on its moves ran every round: no stop.
      stage.optimizer.toleranceMM = item["stop_mm"].isNumeric() ? item["stop_mm"].asDouble() : 0.0;
      stage.optimizer.toleranceDegrees = item["stop_deg"].isNumeric() ? item["stop_deg"].asDouble() : 0.0;
    }
    const Json::Value& o = item["optimizer"];
    if (o.isObject())
    {
      if (!o["method"].isString() || !o["step_mm"].isNumeric() || !o["step_deg"].isNumeric() || !o["tolerance_mm"].isNumeric() ||
        !o["tolerance_deg"].isNumeric() || !o["max_evaluations"].isInt() || !o["restarts"].isInt())
        f.Fail("schedule", "an optimizer must hold method, step_mm, step_deg, tolerance_mm, tolerance_deg, max_evaluations, restarts");
      stage.optimizer.method = ParsePoseOptimizerMethod(o["method"].asString(), "schedule.optimizer.method");
      stage.optimizer.initialStepMM = o["step_mm"].asDouble();
      stage.optimizer.initialStepDegrees = o["step_deg"].asDouble();
      stage.optimizer.toleranceMM = o["tolerance_mm"].asDouble();
      stage.optimizer.toleranceDegrees = o["tolerance_deg"].asDouble();
      stage.optimizer.maxEvaluations = o["max_evaluations"].asInt();
      stage.optimizer.maxRestarts = o["restarts"].asInt();
    }
    r.schedule.stages.push_back(stage);
  }
}

/** result.json's `volume_to_room` into `r`. */
void ReadPlacement(const Fields& f, RegistrationRecord& r)
{
  const Json::Value& rows = f.Array("volume_to_room");
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  bool shaped = rows.size() == 4;
  for (Json::ArrayIndex row = 0; shaped && row < 4; ++row)
  {
    shaped = rows[row].isArray() && rows[row].size() == 4;
    for (Json::ArrayIndex column = 0; shaped && column < 4; ++column)
    {
      shaped = rows[row][column].isNumeric();
      if (shaped)
        m(row, column) = rows[row][column].asDouble();
    }
  }
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  if (!shaped || !(rotation.transpose() * rotation).isApprox(Eigen::Matrix3d::Identity(), 1e-6) ||
    !m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
    f.Fail("volume_to_room", "must be a rigid 4x4 matrix (4 rows of 4 numbers)");
  Eigen::Isometry3d placed = Eigen::Isometry3d::Identity();
  placed.matrix() = m;
  r.volumeToRoom = placed;
  f.At("volume_center"); // the two are written together
}

GateCode CodeNamed(const std::string& name, const Fields& fields)
{
  for (GateCode code : { GateCode::InvalidInput, GateCode::NotConverged, GateCode::TranslationTooLarge,
         GateCode::RotationTooLarge, GateCode::AmbiguousPose, GateCode::TooFewPixels, GateCode::LowExplained, GateCode::UncoveredAnatomy,
         GateCode::ViewDisagrees, GateCode::NotDistinct, GateCode::Uncertain, GateCode::HalvesDisagree,
         GateCode::RestartsDisagree })
  {
    if (name == GateCodeName(code))
      return code;
  }
  fields.Fail("failures", "holds an unknown code '" + name + "'");
}


/** One row of the schema: the field, and how it is written and read back. */
struct FieldCodec
{
  RegistrationRecordField field;
  std::function<bool(const RegistrationRecord&)> written; ///< empty: always
  std::function<Json::Value(const RegistrationRecord&)> write;
  std::function<void(const Fields&, RegistrationRecord&)> read; ///< empty: derived from other fields
};

/** A field that is an object of the record's numbers, each under its key. */
FieldCodec NumberObject(const RegistrationRecordField& field, std::vector<std::pair<const char*, double RegistrationRecord::*>> members,
  std::function<bool(const RegistrationRecord&)> written = {})
{
  return { field, std::move(written),
    [members](const RegistrationRecord& r)
    {
      Json::Value value(Json::objectValue);
      for (const auto& [key, member] : members)
        value[key] = r.*member;
      return value;
    },
    [members, name = field.name](const Fields& f, RegistrationRecord& r)
    {
      for (const auto& [key, member] : members)
        r.*member = f.Number(name + "." + key);
    } };
}

/** A field of one of the record's numbers per view, each under its view's name. */
FieldCodec PerViewField(const RegistrationRecordField& field, std::vector<double> RegistrationRecord::*member,
  std::function<bool(const RegistrationRecord&)> written = {})
{
  return { field, std::move(written), [member](const RegistrationRecord& r) { return PerView(r.viewNames, r.*member); },
    [member, name = field.name](const Fields& f, RegistrationRecord& r) { r.*member = f.PerViewNumbers(name, r.viewNames); } };
}

/** Whether a per-view field has a value for at least one named view. */
template <typename T>
bool AnyPerView(const RegistrationRecord& r, const std::vector<T>& values)
{
  return !r.viewNames.empty() && !values.empty();
}

/** result.json's rows, part 1: The answer: the verdict, the poses, the views and the similarity at the result. */
std::vector<FieldCodec> AnswerCodecs()
{
  using R = RegistrationRecord;
  return {
    { { "status", "text", "", "ok: the couch may be moved by the answer; failed: it may not", "always", true },
      {}, [](const R& r) { return Json::Value(r.ok ? "ok" : "failed"); },
      [](const Fields& f, R& r)
      {
        const std::string status = f.Text("status");
        if (status != "ok" && status != "failed")
          f.Fail("status", "must be \"ok\" or \"failed\"");
        r.ok = status == "ok";
      } },
    { { "misalignment", "pose", "mm, deg", "where the patient is, in room terms", "always", true },
      {}, [](const R& r) { return PoseValue(r.misalignment); },
      [](const Fields& f, R& r) { r.misalignment = f.PoseAt("misalignment"); } },
    { { "correction", "pose", "mm, deg", "the 6-DOF correction: the misalignment's inverse", "always", true },
      {}, [](const R& r) { return PoseValue(r.correction); }, [](const Fields& f, R& r) { r.correction = f.PoseAt("correction"); } },
    { { "views", "list of text", "", "the views' names, in order; per-view fields are keyed by them", "always", true },
      {}, [](const R& r) { return List(r.viewNames); }, [](const Fields& f, R& r) { r.viewNames = f.Texts("views"); } },
    { { "convention", "text", "", "the formula of the poses (CorrectionConvention)", "always", false, false },
      {}, [](const R&) { return Json::Value(CorrectionConvention); }, {} },
    { { "initial_pose", "pose", "mm, deg", "where the search started", "always" },
      {}, [](const R& r) { return PoseValue(r.initialPose); },
      [](const Fields& f, R& r) { r.initialPose = f.PoseAt("initial_pose"); } },
    { { "uncertainty", "per axis", "mm, deg", "how far the similarity stays within 5 % of its peak; null: no maximum", "always" },
      {},
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        for (int a = 0; a < 6; ++a)
          value[axes[a]] = std::isfinite(r.uncertainty[a]) ? Json::Value(r.uncertainty[a]) : Json::Value(Json::nullValue);
        return value;
      },
      [](const Fields& f, R& r)
      {
        for (int a = 0; a < 6; ++a)
        {
          const std::string at = std::string("uncertainty.") + axes[a];
          r.uncertainty[a] = f.At(at).isNull() ? std::numeric_limits<double>::infinity() : f.Number(at);
        }
      } },
    { { "similarity", "per view", "", "each view's MI at the result, and `objective` (the sum of squares)", "always", true },
      {},
      [](const R& r)
      {
        Json::Value value = PerView(r.viewNames, r.similarity);
        value["objective"] = r.objective;
        return value;
      },
      [](const Fields& f, R& r)
      {
        r.similarity = f.PerViewNumbers("similarity", r.viewNames);
        r.objective = f.Number("similarity.objective");
      } },
    PerViewField({ "explained_information", "per view", "", "MI / H(X-ray) at the result", "always", true }, &R::explained),
    PerViewField({ "uncovered_fraction", "per view", "", "the valid pixels' share showing attenuation no ray of the CT meets", "always", true },
      &R::uncovered),
    PerViewField({ "view_residual_mm", "per view", "mm", "how far the view's own 2D registration still moves the DRR", "always", true },
      &R::viewResidualMM),
    PerViewField({ "mask_valid_fraction", "per view", "", "the pixels' share the masks keep", "always", true },
      &R::validFraction),
    PerViewField({ "xray_smoothing_px", "per view", "px", "the Gaussian sd each X-ray was smoothed by", "where smoothed" },
      &R::xraySmoothingPixels, [](const R& r) { return !r.xraySmoothingPixels.empty(); }),
    PerViewField({ "xray_rank_noise", "per view", "levels", "each X-ray's noise sd on its ranks (of 4096 levels), which sets its smoothing", "where measured" },
      &R::xrayRankNoise, [](const R& r) { return !r.xrayRankNoise.empty(); }),
  };
}

/** result.json's rows, part 2: How the images were used: the CT's end faces, the renders, the evaluations and the times. */
std::vector<FieldCodec> RunCodecs()
{
  using R = RegistrationRecord;
  return {
    { { "ct_end_faces", "per view", "", "anatomy beyond each end slice of the CT, and whether those rays were left out",
        "with the coverage mask" },
      [](const R& r) { return AnyPerView(r, r.endFaces); },
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        for (size_t v = 0; v < r.viewNames.size() && v < r.endFaces.size(); ++v)
        {
          Json::Value& faces = value[r.viewNames[v]];
          faces["excess_first_slice"] = r.endFaces[v].excess[0];
          faces["excess_last_slice"] = r.endFaces[v].excess[1];
          faces["left_out_first_slice"] = (r.endFaces[v].facesToLeaveOut & FirstSliceFace) != 0;
          faces["left_out_last_slice"] = (r.endFaces[v].facesToLeaveOut & LastSliceFace) != 0;
        }
        return value;
      },
      [](const Fields& f, R& r)
      {
        for (const std::string& name : r.viewNames)
        {
          const std::string at = "ct_end_faces." + name + ".";
          EndFaceEvidence faces;
          faces.excess[0] = f.Number(at + "excess_first_slice");
          faces.excess[1] = f.Number(at + "excess_last_slice");
          faces.facesToLeaveOut = static_cast<uint8_t>((f.Bool(at + "left_out_first_slice") ? FirstSliceFace : 0) |
            (f.Bool(at + "left_out_last_slice") ? LastSliceFace : 0));
          r.endFaces.push_back(faces);
        }
      } },
    { { "drr_count", "integer", "", "DRR pairs rendered", "always", true },
      {}, [](const R& r) { return Json::Value(static_cast<Json::Int64>(r.drrCount)); },
      [](const Fields& f, R& r) { r.drrCount = static_cast<long long>(f.Number("drr_count")); } },
    { { "device", "text", "", "where the rays were cast: cpu, or cuda (the GPU's name)", "always" },
      {}, [](const R& r) { return Json::Value(r.device); }, [](const Fields& f, R& r) { r.device = f.Text("device"); } },
    { { "render_strides", "object", "px", "rays cast on every n-th pixel of rows and columns, `search` and `fine`", "always" },
      {},
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        for (const auto& [name, stride] : { std::make_pair("search", r.searchRenderStride), std::make_pair("fine", r.fineRenderStride) })
        {
          value[name]["columns"] = stride.columns;
          value[name]["rows"] = stride.rows;
        }
        return value;
      },
      [](const Fields& f, R& r)
      {
        // A stride the registration could not have used (SetRenderStride takes 1 to 8) marks a damaged record.
        const auto step = [&f](const std::string& at)
        {
          const double value = f.Number(at);
          if (value != std::floor(value) || value < 1 || value > 8)
            f.Fail(at, "must be a whole number from 1 to 8");
          return static_cast<int>(value);
        };
        const auto read = [&f, &step](const std::string& at)
        {
          if (f.At(at).isNumeric()) // one number for both axes before the strides per axis
            return RenderStride{ step(at), step(at) };
          return RenderStride{ step(at + ".columns"), step(at + ".rows") };
        };
        r.searchRenderStride = read("render_strides.search");
        r.fineRenderStride = read("render_strides.fine");
      } },
    { { "fine_plane_steps", "array", "planes",
        "the refinement's rays sample every n-th voxel plane along their dominant axis, per CT index axis (i, j, k)", "always" },
      {},
      [](const R& r)
      {
        Json::Value value(Json::arrayValue);
        for (const int step : r.finePlaneSteps)
          value.append(step);
        return value;
      },
      [](const Fields& f, R& r)
      {
        const Json::Value& steps = f.At("fine_plane_steps");
        if (!steps.isArray() || steps.size() != 3)
          f.Fail("fine_plane_steps", "must be three whole numbers from 1 to 4");
        for (Json::ArrayIndex a = 0; a < 3; ++a)
        {
          const std::string at = "fine_plane_steps[" + std::to_string(a) + "]";
          const double value = steps[a].isNumeric() ? steps[a].asDouble() : 0.0;
          if (value != std::floor(value) || value < 1 || value > 4)
            f.Fail(at, "must be a whole number from 1 to 4");
          r.finePlaneSteps[a] = static_cast<int>(value);
        }
      } },
    { { "evaluations", "integer", "", "stereo similarity evaluations at every size, the landscape's and the gate's included", "always",
        true },
      {}, [](const R& r) { return Json::Value(r.evaluations); },
      [](const Fields& f, R& r) { r.evaluations = static_cast<int>(f.Number("evaluations")); } },
    NumberObject({ "timing_s", "object", "s", "`read`, `prealign`, `mask`, `fine`, `total`", "always", true },
      { { "read", &R::readSeconds }, { "prealign", &R::prealignSeconds }, { "mask", &R::maskSeconds }, { "fine", &R::fineSeconds },
        { "total", &R::totalSeconds } }),
    NumberObject({ "search_disagreement", "object", "mm, deg", "how far apart the two searches ended, and their objectives' ratio",
                   "always", true },
      { { "mm", &R::searchApartMM }, { "degrees", &R::searchApartDegrees }, { "objective_ratio", &R::searchObjectiveRatio } }),
  };
}

/** result.json's rows, part 3: The gate's evidence around the result: the held-out leads, the halves, the edges. */
std::vector<FieldCodec> EvidenceCodecs()
{
  using R = RegistrationRecord;
  return {
    { { "peak_margin", "number", "", "the result's least lead over its held-out neighbours", "always" },
      {}, [](const R& r) { return Json::Value(r.peakMargin); }, [](const Fields& f, R& r) { r.peakMargin = f.Number("peak_margin"); } },
    { { "held_out_leads", "per axis", "",
        "each held-out neighbour's lead, [at -step, at +step]; the measured axes only (pitch, roll and yaw with --held-out-turns)",
        "always" },
      {},
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        for (int a = 0; a < 6; ++a)
        {
          if (std::isnan(r.peakLeads[2 * a]) && std::isnan(r.peakLeads[2 * a + 1]))
            continue; // not measured
          value[axes[a]].append(r.peakLeads[2 * a]);
          value[axes[a]].append(r.peakLeads[2 * a + 1]);
        }
        return value;
      },
      [](const Fields& f, R& r)
      {
        for (int a = 0; a < 6; ++a)
        {
          const std::string at = std::string("held_out_leads.") + axes[a];
          r.peakLeads[2 * a] = r.peakLeads[2 * a + 1] = std::numeric_limits<double>::quiet_NaN();
          if (a >= 3 && !f.At("held_out_leads").isMember(axes[a]))
            continue; // a turned neighbour not measured
          const std::vector<double> leads = f.Numbers(at);
          if (leads.size() != 2)
            f.Fail(at, "must hold 2 numbers (the neighbours at -step and +step)");
          r.peakLeads[2 * a] = leads[0];
          r.peakLeads[2 * a + 1] = leads[1];
        }
      } },
    { { "halves_apart_mm", "per view", "mm", "how far apart each view's two halves register (empty: not measured)", "always" },
      {}, [](const R& r) { return PerView(r.viewNames, r.halvesApartMM); },
      [](const Fields& f, R& r)
      {
        if (!f.At("halves_apart_mm").empty())
          r.halvesApartMM = f.PerViewNumbers("halves_apart_mm", r.viewNames);
      } },
    { { "xray_polarity", "per view", "", "whether bright meant attenuation or transmission, and the correlation that decided it",
        "where measured" },
      [](const R& r) { return AnyPerView(r, r.xrayCorrelation); },
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        for (size_t v = 0; v < r.viewNames.size() && v < r.xrayCorrelation.size(); ++v)
        {
          value[r.viewNames[v]]["bright_means"] = r.xrayCorrelation[v] < 0.0 ? "attenuation" : "transmission";
          value[r.viewNames[v]]["correlation_with_drr"] = r.xrayCorrelation[v];
        }
        return value;
      },
      [](const Fields& f, R& r)
      {
        for (const std::string& name : r.viewNames)
          r.xrayCorrelation.push_back(f.Number("xray_polarity." + name + ".correlation_with_drr"));
      } },
    // The median distance (mm at the isocentre) from the DRR's edges at the result to the X-ray's,
    // and with the DRR moved 3 mm: what the X-ray's edges alone would give (-1: no edges).
    PerViewField({ "edge_distance_mm", "per view", "mm", "the median distance from the DRR's edges to the X-ray's nearest edge", "where measured" },
      &R::edgeDistanceMM, [](const R& r) { return !r.edgeDistanceMM.empty(); }),
    PerViewField({ "edge_distance_moved_3mm", "per view", "mm", "the same with the DRR moved 3 mm (chance)", "with edge_distance_mm" },
      &R::edgeDistanceShiftedMM, [](const R& r) { return !r.edgeDistanceMM.empty(); }),
  };
}

/** result.json's rows, part 4: Where the volume lies in the room, and what of the CT was rendered. */
std::vector<FieldCodec> PlacementCodecs()
{
  using R = RegistrationRecord;
  return {
    { { "volume_to_room", "4x4 matrix", "mm", "the volume's own coordinates to room mm at the result, by rows",
        "when a command wrote it" },
      [](const R& r) { return r.volumeToRoom.has_value(); },
      [](const R& r)
      {
        Json::Value rows(Json::arrayValue);
        for (int row = 0; row < 4; ++row)
        {
          Json::Value line(Json::arrayValue);
          for (int column = 0; column < 4; ++column)
            line.append(r.volumeToRoom->matrix()(row, column));
          rows.append(line);
        }
        return rows;
      },
      ReadPlacement },
    { { "volume_center", "point", "mm", "the volume's centre in its own coordinates", "with volume_to_room" },
      [](const R& r) { return r.volumeToRoom.has_value(); }, [](const R& r) { return PointValue(r.volumeCenter); },
      [](const Fields& f, R& r)
      {
        const std::vector<double> center = f.Numbers("volume_center");
        if (center.size() != 3)
          f.Fail("volume_center", "must hold 3 numbers");
        r.volumeCenter = Eigen::Vector3d(center[0], center[1], center[2]);
      } },
    NumberObject({ "restarts_apart", "object", "mm, deg", "bones: the farthest of the restarted refinements from the result",
                   "bones only" },
      { { "mm", &R::restartsApartMM }, { "degrees", &R::restartsApartDegrees } }, [](const R& r) { return r.restartsApartMM >= 0.0; }),
    { { "bone_only", "bool", "", "whether the volume was matched as a bone cut out of a CT", "always" },
      {}, [](const R& r) { return Json::Value(r.boneOnly); }, [](const Fields& f, R& r) { r.boneOnly = f.Bool("bone_only"); } },
    { { "table", "object", "cm3", "the CT's table found, each CT's high-passed objective, and which was rendered",
        "where the X-rays chose the table" },
      [](const R& r) { return r.table.has_value(); },
      [](const R& r)
      {
        Json::Value table(Json::objectValue);
        table["found_cm3"] = r.table->tableCM3;
        if (r.table->tableCM3 > 0.0)
        {
          table["high_passed_objective"]["with_table"] = r.table->withTable;
          table["high_passed_objective"]["body_only"] = r.table->bodyOnly;
        }
        table["rendered_from"] = r.table->keptTable ? "ct" : "body_only";
        return table;
      },
      [](const Fields& f, R& r)
      {
        TableChoice& table = r.table.emplace();
        table.tableCM3 = f.Number("table.found_cm3");
        if (!std::isfinite(table.tableCM3) || table.tableCM3 < 0.0)
          f.Fail("table.found_cm3", "must be a number of at least 0");
        if (table.tableCM3 > 0.0)
        {
          table.withTable = f.Number("table.high_passed_objective.with_table");
          table.bodyOnly = f.Number("table.high_passed_objective.body_only");
        }
        const std::string from = f.Text("table.rendered_from");
        if (from != "ct" && from != "body_only")
          f.Fail("table.rendered_from", "must be \"ct\" or \"body_only\"");
        table.keptTable = from == "ct";
      } },
  };
}

/** result.json's rows, part 5: Why it failed, the couch's motion, the inputs, and the run's trace and schedule. */
std::vector<FieldCodec> VerdictCodecs()
{
  using R = RegistrationRecord;
  return {
    { { "failures", "list", "", "why the gate failed: each {code, view, message}; empty exactly when ok", "always", true },
      {},
      [](const R& r)
      {
        Json::Value failures(Json::arrayValue);
        for (const GateFailure& failure : r.failures)
        {
          Json::Value item(Json::objectValue);
          item["code"] = GateCodeName(failure.code);
          item["view"] = failure.view >= 0 && failure.view < static_cast<int>(r.viewNames.size())
            ? Json::Value(r.viewNames[failure.view])
            : Json::Value(Json::nullValue);
          item["message"] = failure.message;
          failures.append(item);
        }
        return failures;
      },
      [](const Fields& f, R& r)
      {
        for (const Json::Value& item : f.Array("failures"))
        {
          if (!item.isObject() || !item["code"].isString() || !item["message"].isString())
            f.Fail("failures", "must list {code, view, message}");
          int view = -1;
          for (size_t v = 0; item["view"].isString() && v < r.viewNames.size(); ++v)
            view = r.viewNames[v] == item["view"].asString() ? static_cast<int>(v) : view;
          r.failures.push_back({ CodeNamed(item["code"].asString(), f), view, item["message"].asString() });
        }
        if (r.ok != r.failures.empty())
          f.Fail("failures", "must be empty exactly when status is ok");
      } },
    { { "reasons", "list of text", "", "the failures' messages alone", "always", false, false },
      {}, [](const R& r) { return List(r.Reasons()); }, {} },
    { { "couch", "object", "mm, deg", "the couch motion that carries out the correction as far as the couch can, and its action",
        "ok results" },
      [](const R& r) { return r.couch.has_value(); }, [](const R& r) { return CouchValue(*r.couch, r.actionLevels, r.targetInCT); },
      [](const Fields& f, R& r)
      {
        if (!r.ok)
          f.Fail("couch", "is given only for an ok result");
        r.couch = CouchAt(f, r.targetInCT, r.actionLevels);
      } },
    { { "inputs", "object", "", "the files and options a command registered, and each X-ray's MD5", "when a command wrote it" },
      [](const R& r) { return r.inputs.has_value(); }, [](const R& r) { return InputsValue(*r.inputs); },
      [](const Fields& f, R& r) { r.inputs = InputsAt(f, f.At("inputs")); } },
    { { "convergence", "object", "s", "the objective at every evaluation, and each stage's span of it", "always", true },
      {}, ConvergenceValue, ReadConvergence },
    { { "prealignment_2d", "object", "", "the pre-alignment's `iterations` and the `drrs` it rendered", "always" },
      {},
      [](const R& r)
      {
        Json::Value value(Json::objectValue);
        value["iterations"] = r.prealignIterations;
        value["drrs"] = static_cast<Json::Int64>(r.prealignDRRs);
        return value;
      },
      [](const Fields& f, R& r)
      {
        r.prealignIterations = static_cast<int>(f.Number("prealignment_2d.iterations"));
        r.prealignDRRs = static_cast<long long>(f.Number("prealignment_2d.drrs"));
      } },
    { { "schedule", "list", "", "the stages as scheduled, in order, each with its optimiser's budget", "always" },
      {}, [](const R& r) { return ScheduleValue(r.schedule); }, ReadSchedule },
  };
}

/**
 * result.json, field by field, in the order the reader takes them (the status and the views' names
 * before what depends on them). A row says what the field is, when it is written, whether a record
 * without it is refused, and how it is written and read; RegistrationRecordJSON and
 * ParseRegistrationRecord only walk this table: its five parts above, in their order.
 */
const std::vector<FieldCodec>& Codecs()
{
  static const std::vector<FieldCodec> codecs = []
  {
    std::vector<FieldCodec> all;
    for (std::vector<FieldCodec> (*part)() : { AnswerCodecs, RunCodecs, EvidenceCodecs, PlacementCodecs, VerdictCodecs })
    {
      std::vector<FieldCodec> rows = part();
      all.insert(all.end(), std::make_move_iterator(rows.begin()), std::make_move_iterator(rows.end()));
    }
    return all;
  }();
  return codecs;
}

} // namespace

const std::vector<RegistrationRecordField>& RegistrationRecordSchema()
{
  static const std::vector<RegistrationRecordField> schema = []
  {
    std::vector<RegistrationRecordField> fields;
    for (const FieldCodec& codec : Codecs())
      fields.push_back(codec.field);
    return fields;
  }();
  return schema;
}

std::vector<std::string> RegistrationRecord::Reasons() const
{
  return GateMessages(this->failures);
}

RegistrationRecord MakeRegistrationRecord(const StereoRegistrationResult& result, const std::vector<std::string>& viewNames)
{
  RegistrationRecord record;
  record.ok = result.ok;
  record.misalignment = result.misalignment;
  record.initialPose = result.start;
  record.boneOnly = result.boneOnly;
  record.table = result.table;
  record.restartsApartMM = result.restartsApartMM;
  record.restartsApartDegrees = result.restartsApartDegrees;
  record.correction = result.correction;
  record.viewNames = viewNames;
  record.similarity = result.mutualInformation;
  record.explained = result.explained;
  record.uncovered = result.uncovered;
  record.viewResidualMM = result.viewResidualMM;
  record.validFraction = result.validFraction;
  record.xraySmoothingPixels = result.xraySmoothingPixels;
  record.xrayRankNoise = result.xrayRankNoise;
  record.endFaces = result.endFaces;
  record.objective = result.objective;
  record.failures = result.failures;
  record.drrCount = result.drrCount;
  record.device = result.device;
  record.searchRenderStride = result.searchRenderStride;
  record.fineRenderStride = result.fineRenderStride;
  record.finePlaneSteps = result.finePlaneSteps;
  record.evaluations = result.evaluations;
  record.prealignSeconds = result.prealignSeconds;
  record.maskSeconds = result.maskSeconds;
  record.fineSeconds = result.fineSeconds;
  record.searchApartMM = result.searchDisagreementMM;
  record.searchApartDegrees = result.searchDisagreementDegrees;
  record.searchObjectiveRatio = result.searchObjectiveRatio;
  record.uncertainty = result.uncertainty;
  record.xrayCorrelation = result.xrayCorrelation;
  record.halvesApartMM = result.halvesApartMM;
  record.edgeDistanceMM = result.edgeDistanceMM;
  record.edgeDistanceShiftedMM = result.edgeDistanceShiftedMM;
  record.peakMargin = result.peakMargin;
  record.peakLeads = result.peakLeads;
  record.stages = result.stages;
  record.objectiveTrace = result.objectiveTrace;
  record.schedule = result.schedule;
  record.prealignIterations = result.prealignment.iterations;
  record.prealignDRRs = result.prealignment.drrs;
  return record;
}

std::string RegistrationRecordJSON(const RegistrationRecord& r)
{
  Json::Value root(Json::objectValue);
  for (const FieldCodec& codec : Codecs())
    if (!codec.written || codec.written(r))
      root[codec.field.name] = codec.write(r);
  Json::StreamWriterBuilder builder;
  builder["indentation"] = "  ";
  builder["precision"] = 10; // significant digits: micrometres on a metre, no binary noise
  return Json::writeString(builder, root) + "\n";
}

RegistrationRecord ParseRegistrationRecord(const std::string& text, const std::string& origin)
{
  Json::Value root;
  std::string errors;
  const std::unique_ptr<Json::CharReader> reader(Json::CharReaderBuilder().newCharReader());
  if (!reader->parse(text.data(), text.data() + text.size(), &root, &errors) || !root.isObject())
    throw InputError(origin, "is not valid JSON: " + errors);
  const Fields f(root, origin);
  RegistrationRecord r;
  for (const FieldCodec& codec : Codecs())
  {
    if (!codec.read)
      continue;
    if (f.Has(codec.field.name))
      codec.read(f, r);
    else if (codec.field.required)
      f.At(codec.field.name); // refused, naming the field
  }
  return r;
}

RegistrationRecord ReadRegistrationRecord(const std::string& path)
{
  return ParseRegistrationRecord(ReadWholeFile(path), path);
}

} // namespace xp
