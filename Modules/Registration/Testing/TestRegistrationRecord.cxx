// result.json: what is written is read back whole, and a damaged record is refused with the
// file and the field named.
#include "xpError.h"
#include "xpRegistrationRecord.h"

#include <gtest/gtest.h>
#include <algorithm>
#include <cmath>
#include <vtk_jsoncpp.h>

#include <fstream>
#include <limits>
#include <regex>
#include <set>
#include <sstream>

namespace
{

xp::RegistrationRecord FailedRecord()
{
  xp::StereoRegistrationResult result;
  result.ok = false;
  result.misalignment = xp::Pose::Parse("1.25,-2.5,0.125,0.5,-0.25,1", "pose");
  result.correction = result.misalignment.Inverse();
  result.mutualInformation = { 0.61, 0.57 };
  result.explained = { 0.21, 0.12 };
  result.uncovered = { 0.0, 0.03 };
  result.viewResidualMM = { 0.02, 0.4 };
  result.validFraction = { 0.45, 0.5 };
  result.xraySmoothingPixels = { 0.71, 0.0 };
  result.xrayRankNoise = { 38.5, 12.25 };
  result.endFaces.resize(2);
  result.endFaces[1].excess[0] = 0.25;
  result.endFaces[1].facesToLeaveOut = xp::FirstSliceFace;
  result.objective = 0.7;
  result.failures = { { xp::GateCode::LowExplained, 1, "view right: the final DRR explains 0.120" } };
  result.drrCount = 1234;
  result.searchRenderStride = { 2, 2 };
  result.fineRenderStride = { 1, 3 };
  result.finePlaneSteps = { { 2, 2, 1 } };
  result.evaluations = 600;
  result.stages = { { "coarse search", 0, 1.5 }, { "fine", 400, 2.25 } };
  result.stages[1].evaluations = 150;
  result.stages[1].modelEvaluations = 420;
  result.stages[1].imageDivisor = 1;
  result.stages[0].imageDivisor = 2;
  result.stages[0].kind = xp::StageKind::Search;
  result.stages[1].kind = xp::StageKind::Refinement;
  result.stages[1].secondEnd = true;
  xp::StereoRegistrationSettings linearized;
  linearized.linearizedRefinement = true;
  result.schedule = xp::MakeSchedule(linearized, true, true, false);
  result.prealignment.iterations = 3;
  result.prealignment.drrs = 40;
  result.objectiveTrace = { 0.1, 0.3, 0.7 };
  xp::RegistrationRecord record = xp::MakeRegistrationRecord(result, { "left", "right" });
  record.totalSeconds = 4.5;
  return record;
}

} // namespace

TEST(RegistrationRecord, RoundTripsEveryField)
{
  xp::RegistrationRecord written = FailedRecord();
  xp::RegistrationRecordInputs& in = written.inputs.emplace();
  in.ct = "/data/ct";
  in.xrays = { "/data/a.png", "/data/b.png" };
  in.xrayMD5 = { "0123", "4567" };
  in.muWater = 0.0193;
  in.removeTable = true;
  written.halvesApartMM = { 0.125, 1.5 };
  written.xrayCorrelation = { -0.75, 0.5 };
  written.restartsApartMM = 0.3;
  written.restartsApartDegrees = 0.2;
  for (size_t i = 0; i < written.peakLeads.size(); ++i)
    written.peakLeads[i] = 0.01 * static_cast<double>(i + 1);
  xp::TableChoice& table = written.table.emplace();
  table.tableCM3 = 1285.5;
  table.withTable = 6.125;
  table.bodyOnly = 6.5;
  table.keptTable = false;
  const xp::RegistrationRecord read = xp::ParseRegistrationRecord(xp::RegistrationRecordJSON(written), "result.json");
  EXPECT_FALSE(read.ok);
  ASSERT_TRUE(read.table.has_value());
  EXPECT_DOUBLE_EQ(read.table->tableCM3, 1285.5);
  EXPECT_DOUBLE_EQ(read.table->withTable, 6.125) << "each CT's objective under its own name";
  EXPECT_DOUBLE_EQ(read.table->bodyOnly, 6.5);
  EXPECT_FALSE(read.table->keptTable);
  // A table of negative volume, or rendered from something else, is a damaged record.
  for (const auto& [from, to] : { std::make_pair("\"found_cm3\" : 1285.5", "\"found_cm3\" : -1"),
         std::make_pair("\"rendered_from\" : \"body_only\"", "\"rendered_from\" : \"couch\"") })
  {
    std::string text = xp::RegistrationRecordJSON(written);
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, std::string(from).size(), to);
    try
    {
      xp::ParseRegistrationRecord(text, "damaged.json");
      ADD_FAILURE() << to << " was accepted";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("table."), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(read.halvesApartMM, written.halvesApartMM) << "each view's halves under its own name";
  EXPECT_EQ(read.xrayCorrelation, written.xrayCorrelation);
  EXPECT_EQ(read.peakLeads, written.peakLeads) << "each lead under its axis and side";
  // The turned neighbours not measured (the default): their axes left out, read back as NaN; a
  // translated axis left out is a damaged record.
  xp::RegistrationRecord translatedOnly = written;
  for (size_t i = 6; i < translatedOnly.peakLeads.size(); ++i)
    translatedOnly.peakLeads[i] = std::numeric_limits<double>::quiet_NaN();
  const std::string translatedText = xp::RegistrationRecordJSON(translatedOnly);
  const xp::RegistrationRecord readTranslated = xp::ParseRegistrationRecord(translatedText, "result.json");
  for (size_t i = 0; i < 12; ++i)
  {
    if (i < 6)
      EXPECT_DOUBLE_EQ(readTranslated.peakLeads[i], written.peakLeads[i]) << i;
    else
      EXPECT_TRUE(std::isnan(readTranslated.peakLeads[i])) << i << ": " << readTranslated.peakLeads[i];
  }
  Json::Value translatedRoot;
  std::istringstream(translatedText) >> translatedRoot;
  EXPECT_EQ(translatedRoot["held_out_leads"].getMemberNames(), (std::vector<std::string>{ "tx_mm", "ty_mm", "tz_mm" }))
    << "the measured axes only";
  {
    Json::Value damaged = translatedRoot;
    damaged["held_out_leads"].removeMember("tz_mm");
    std::ostringstream text;
    text << damaged;
    EXPECT_THROW(xp::ParseRegistrationRecord(text.str(), "damaged.json"), xp::InputError);
  }
  EXPECT_DOUBLE_EQ(read.restartsApartMM, 0.3);
  EXPECT_DOUBLE_EQ(read.restartsApartDegrees, 0.2);
  EXPECT_EQ(read.viewNames, written.viewNames) << "the views keep the geometry's order, not the alphabet's";
  EXPECT_LT((read.misalignment.translation - written.misalignment.translation).norm(), 1e-9);
  EXPECT_DOUBLE_EQ(read.misalignment.yaw, 1.0);
  EXPECT_NEAR(read.correction.pitch, written.correction.pitch, 1e-9); // 10 significant digits
  EXPECT_EQ(read.explained, written.explained);
  EXPECT_EQ(read.viewResidualMM, written.viewResidualMM);
  EXPECT_EQ(read.xraySmoothingPixels, written.xraySmoothingPixels);
  EXPECT_EQ(read.xrayRankNoise, written.xrayRankNoise);
  ASSERT_EQ(read.endFaces.size(), 2u);
  EXPECT_EQ(read.endFaces[0].facesToLeaveOut, 0);
  EXPECT_EQ(read.endFaces[1].facesToLeaveOut, xp::FirstSliceFace) << "the right face, not the other";
  EXPECT_DOUBLE_EQ(read.endFaces[1].excess[0], 0.25);
  ASSERT_EQ(read.failures.size(), 1u);
  EXPECT_EQ(read.failures[0].code, xp::GateCode::LowExplained);
  EXPECT_EQ(read.failures[0].view, 1);
  EXPECT_EQ(read.Reasons(), written.Reasons());
  EXPECT_EQ(read.drrCount, 1234);
  EXPECT_EQ(read.searchRenderStride.columns, 2);
  EXPECT_EQ(read.searchRenderStride.rows, 2);
  EXPECT_EQ(read.fineRenderStride.columns, 1) << "columns and rows not swapped";
  EXPECT_EQ(read.fineRenderStride.rows, 3);
  EXPECT_EQ(read.finePlaneSteps, (std::array<int, 3>{ { 2, 2, 1 } })) << "the axes not swapped";
  EXPECT_DOUBLE_EQ(read.totalSeconds, 4.5);
  ASSERT_EQ(read.stages.size(), 2u);
  EXPECT_EQ(read.stages[1].firstEvaluation, 400);
  EXPECT_EQ(read.stages[1].evaluations, 150);
  EXPECT_EQ(read.stages[1].modelEvaluations, 420);
  EXPECT_EQ(read.stages[0].modelEvaluations, 0) << "a search renders every evaluation";
  EXPECT_EQ(read.stages[0].kind, xp::StageKind::Search);
  EXPECT_EQ(read.stages[1].kind, xp::StageKind::Refinement);
  EXPECT_FALSE(read.stages[0].secondEnd);
  EXPECT_TRUE(read.stages[1].secondEnd);
  EXPECT_EQ(read.stages[0].imageDivisor, 2);
  EXPECT_EQ(read.prealignIterations, 3);
  EXPECT_EQ(read.prealignDRRs, 40);
  ASSERT_EQ(read.schedule.stages.size(), written.schedule.stages.size());
  for (size_t s = 0; s < read.schedule.stages.size(); ++s)
  {
    const xp::ScheduledStage &a = read.schedule.stages[s], &b = written.schedule.stages[s];
    EXPECT_EQ(a.kind, b.kind) << b.name;
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.imageDivisor, b.imageDivisor) << b.name;
    EXPECT_EQ(a.track, b.track) << b.name;
    EXPECT_EQ(a.stopAtFirstEnd, b.stopAtFirstEnd) << b.name;
    EXPECT_EQ(a.joinsFirstTrack, b.joinsFirstTrack) << b.name;
    EXPECT_EQ(a.linearized, b.linearized) << b.name;
    EXPECT_EQ(a.linearized, b.kind == xp::StageKind::Refinement) << b.name << ": the refinement's setting read back";
    EXPECT_EQ(a.rounds, b.rounds) << b.name;
    if (b.kind == xp::StageKind::Search || b.kind == xp::StageKind::Refinement)
    {
      EXPECT_DOUBLE_EQ(a.optimizer.toleranceMM, b.optimizer.toleranceMM) << b.name;
      EXPECT_DOUBLE_EQ(a.optimizer.initialStepDegrees, b.optimizer.initialStepDegrees) << b.name;
      EXPECT_EQ(a.optimizer.maxEvaluations, b.optimizer.maxEvaluations) << b.name;
    }
    if (b.kind == xp::StageKind::Polish)
    {
      EXPECT_GT(b.optimizer.toleranceMM, 0.0) << "the polish stops on its moves";
      EXPECT_DOUBLE_EQ(a.optimizer.toleranceMM, b.optimizer.toleranceMM) << b.name;
      EXPECT_DOUBLE_EQ(a.optimizer.toleranceDegrees, b.optimizer.toleranceDegrees) << b.name;
    }
  }
  EXPECT_EQ(std::count_if(read.schedule.stages.begin(), read.schedule.stages.end(),
              [](const xp::ScheduledStage& stage) { return stage.joinsFirstTrack; }),
    1)
    << "the second search's quarter-size stage joins the first track, read back";
  EXPECT_EQ(read.objectiveTrace, written.objectiveTrace);
  ASSERT_TRUE(read.inputs.has_value());
  EXPECT_EQ(read.inputs->xrays, in.xrays);
  EXPECT_TRUE(read.inputs->removeTable);
  const xp::RegistrationRecord plain = xp::ParseRegistrationRecord(xp::RegistrationRecordJSON(FailedRecord()), "r");
  EXPECT_FALSE(plain.inputs.has_value());
  EXPECT_TRUE(plain.halvesApartMM.empty()) << "no halves measured, none read";
  EXPECT_FALSE(plain.table.has_value()) << "no choice asked for, none read";
  EXPECT_LT(plain.restartsApartMM, 0.0) << "not a bone: no restarts";
}

// An ok result's couch block: written and read back, each figure in its place; refused on a
// failed result, which the couch must not be moved by.
TEST(RegistrationRecord, RoundTripsTheCouchMotion)
{
  xp::RegistrationRecord written = FailedRecord();
  written.ok = true;
  written.failures.clear();
  xp::CouchDescription couch;
  couch.motions = xp::CouchMotions::SixDOF;
  couch.pitchRollLimitDegrees = 1.0;
  couch.rotationCenter = Eigen::Vector3d(0, -300, -250);
  written.actionLevels.actionMM = 1.0;
  written.actionLevels.maxUncorrectedDegrees = 3.0;
  written.couch = xp::PlanCouchMotion(xp::Pose::Parse("2,-1,3,2,-1.5,1", "pose"), Eigen::Vector3d::Zero(),
    Eigen::Vector3d(10, 20, -5), couch, written.actionLevels);
  written.targetInCT = Eigen::Vector3d(1.5, -2.5, 3.5);
  const std::string json = xp::RegistrationRecordJSON(written);
  const xp::RegistrationRecord read = xp::ParseRegistrationRecord(json, "result.json");
  ASSERT_TRUE(read.couch.has_value());
  const xp::CouchMotion &a = *read.couch, &b = *written.couch;
  EXPECT_EQ(a.couch.motions, xp::CouchMotions::SixDOF);
  EXPECT_DOUBLE_EQ(a.couch.pitchRollLimitDegrees, 1.0);
  EXPECT_LT((a.motion.translation - b.motion.translation).norm(), 1e-8);
  EXPECT_NEAR(a.motion.pitch, -1.0, 1e-9);
  EXPECT_NEAR(a.motion.roll, 1.0, 1e-9);
  EXPECT_NEAR(a.motion.yaw, b.motion.yaw, 1e-9);
  EXPECT_EQ(a.rotationCenter, Eigen::Vector3d(0, -300, -250));
  EXPECT_EQ(a.target, Eigen::Vector3d(10, 20, -5));
  EXPECT_EQ(read.targetInCT, Eigen::Vector3d(1.5, -2.5, 3.5));
  EXPECT_NEAR(a.uncorrected.pitch, b.uncorrected.pitch, 1e-9);
  EXPECT_NEAR(a.uncorrected.roll, b.uncorrected.roll, 1e-9);
  EXPECT_NEAR(a.uncorrectedAt100MM, b.uncorrectedAt100MM, 1e-9);
  EXPECT_EQ(a.limitedBy, (std::vector<std::string>{ "pitch_limit", "roll_limit" }));
  EXPECT_EQ(a.action, b.action);
  EXPECT_EQ(read.actionLevels.actionMM, 1.0);
  EXPECT_EQ(read.actionLevels.maxUncorrectedDegrees, 3.0);
  EXPECT_TRUE(std::isinf(read.actionLevels.maxUncorrectedMM)) << "none: null in the file";
  // The names, in the file.
  for (const char* name : { "\"motions\"", "\"translation_mm\"", "\"rotation_center\"", "\"uncorrected_rotation_deg\"",
         "\"uncorrected_mm_at_50\"", "\"uncorrected_mm_at_100\"", "\"limited_by\"", "\"action\" : \"move\"" })
    EXPECT_NE(json.find(name), std::string::npos) << name;
  // A limit is a number of at least 0 or null (none); a word or a negative one is a damaged
  // record, refused naming the field, not read as no limit.
  Json::Value root;
  std::istringstream(json) >> root;
  for (const Json::Value& bad : { Json::Value("3"), Json::Value(-1.0), Json::Value(Json::objectValue) })
    for (const char* field : { "rotation_limit_deg", "max_uncorrected_mm" })
    {
      Json::Value damaged = root;
      (std::string(field) == "rotation_limit_deg" ? damaged["couch"][field] : damaged["couch"]["action_levels"][field]) = bad;
      try
      {
        xp::ParseRegistrationRecord(damaged.toStyledString(), "result.json");
        ADD_FAILURE() << field << " = " << bad.toStyledString() << " was read";
      }
      catch (const xp::InputError& e)
      {
        EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      }
    }
  Json::Value unlimited = root;
  unlimited["couch"]["rotation_limit_deg"] = Json::Value(Json::nullValue);
  EXPECT_TRUE(std::isinf(xp::ParseRegistrationRecord(unlimited.toStyledString(), "result.json").couch->couch.pitchRollLimitDegrees));
  // A failed result with a couch block is a damaged record.
  root["status"] = "failed";
  root["failures"].append(Json::Value(Json::objectValue));
  root["failures"][0]["code"] = "low_explained";
  root["failures"][0]["message"] = "m";
  root["failures"][0]["view"] = Json::Value(Json::nullValue);
  EXPECT_THROW(xp::ParseRegistrationRecord(root.toStyledString(), "result.json"), xp::InputError);
}

TEST(RegistrationRecord, KeepsTheVolumesPlacementAndTheEdgeFigures)
{
  xp::RegistrationRecord written = FailedRecord();
  Eigen::Isometry3d placed = Eigen::Isometry3d::Identity();
  placed.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  placed.pretranslate(Eigen::Vector3d(115.0, -73.5, 12.25));
  written.volumeToRoom = placed;
  written.volumeCenter = Eigen::Vector3d(17.0, 13.5, 40.0);
  written.edgeDistanceMM = { 0.65, 1.3 };
  written.edgeDistanceShiftedMM = { 1.96, 1.46 };
  const xp::RegistrationRecord read = xp::ParseRegistrationRecord(xp::RegistrationRecordJSON(written), "result.json");
  ASSERT_TRUE(read.volumeToRoom.has_value());
  EXPECT_TRUE(read.volumeToRoom->matrix().isApprox(placed.matrix(), 1e-9));
  EXPECT_TRUE(read.volumeCenter.isApprox(written.volumeCenter));
  EXPECT_EQ(read.edgeDistanceMM, written.edgeDistanceMM);
  EXPECT_EQ(read.edgeDistanceShiftedMM, written.edgeDistanceShiftedMM);
  // Older records have neither.
  const xp::RegistrationRecord older = xp::ParseRegistrationRecord(xp::RegistrationRecordJSON(FailedRecord()), "r");
  EXPECT_FALSE(older.volumeToRoom.has_value());
  EXPECT_TRUE(older.edgeDistanceMM.empty());
  // A placement that is no rigid motion is refused, naming the field.
  std::string text = xp::RegistrationRecordJSON(written);
  const size_t at = text.find("\"volume_to_room\"");
  ASSERT_NE(at, std::string::npos);
  const size_t first = text.find_first_of("0123456789-", text.find('[', text.find('[', at) + 1));
  text.insert(first, "2");
  try
  {
    xp::ParseRegistrationRecord(text, "frame.json");
    FAIL() << "a scaled placement was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("volume_to_room"), std::string::npos) << e.what();
  }
}

TEST(RegistrationRecord, WritesEachHeldOutLeadUnderItsAxisAndSide)
{
  xp::StereoRegistrationResult result;
  for (int k = 0; k < 12; ++k)
    result.peakLeads[k] = (k % 2 ? 1.0 : -1.0) * (k + 1) / 100.0; // -0.01, +0.02, ... distinct and signed
  const std::string json = xp::RegistrationRecordJSON(xp::MakeRegistrationRecord(result, { "A", "B" }));
  const std::string compact = [&] {
    std::string s;
    for (char c : json)
      if (c != ' ' && c != '\n')
        s += c;
    return s;
  }();
  EXPECT_NE(compact.find("\"tx_mm\":[-0.01,0.02]"), std::string::npos) << json;
  EXPECT_NE(compact.find("\"roll_deg\":[-0.09,0.1]"), std::string::npos) << json;
  EXPECT_NE(compact.find("\"yaw_deg\":[-0.11,0.12]"), std::string::npos) << json;
}

TEST(RegistrationRecord, ReadsOneStrideForBothAxesFromEarlierRecords)
{
  // Records written before the strides per panel axis hold one number for rows and columns.
  xp::RegistrationRecord written = FailedRecord();
  written.fineRenderStride = { 1, 2 };
  const std::string current = xp::RegistrationRecordJSON(written);
  Json::Value root;
  std::istringstream(current) >> root;
  ASSERT_EQ(root["render_strides"]["fine"]["rows"].asInt(), 2);
  root["render_strides"]["search"] = 1;
  root["render_strides"]["fine"] = 2;
  const xp::RegistrationRecord read = xp::ParseRegistrationRecord(Json::writeString(Json::StreamWriterBuilder(), root), "old.json");
  EXPECT_EQ(read.searchRenderStride, (xp::RenderStride{ 1, 1 }));
  EXPECT_EQ(read.fineRenderStride, (xp::RenderStride{ 2, 2 }));
}

TEST(RegistrationRecord, RefusesARenderStrideNoRegistrationUses)
{
  const std::string current = xp::RegistrationRecordJSON(FailedRecord());
  for (const Json::Value& bad : { Json::Value(0), Json::Value(9), Json::Value(1.5), Json::Value(-2) })
  {
    Json::Value root;
    std::istringstream(current) >> root;
    root["render_strides"]["fine"]["rows"] = bad;
    try
    {
      xp::ParseRegistrationRecord(Json::writeString(Json::StreamWriterBuilder(), root), "run/result.json");
      ADD_FAILURE() << "a fine stride of " << bad.asDouble() << " rows was accepted";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("render_strides.fine.rows"), std::string::npos) << e.what();
    }
  }
  // The same for the single number of earlier records.
  Json::Value root;
  std::istringstream(current) >> root;
  root["render_strides"]["search"] = 0;
  EXPECT_THROW(xp::ParseRegistrationRecord(Json::writeString(Json::StreamWriterBuilder(), root), "old.json"), xp::InputError);
}

TEST(RegistrationRecord, PlaneStepsReadBackAndEarlierRecordsSampledEveryPlane)
{
  xp::RegistrationRecord written = FailedRecord();
  written.finePlaneSteps = { { 2, 1, 2 } };
  const std::string current = xp::RegistrationRecordJSON(written);
  Json::Value root;
  std::istringstream(current) >> root;
  ASSERT_EQ(root["fine_plane_steps"].size(), 3u);
  EXPECT_EQ(root["fine_plane_steps"][1].asInt(), 1);
  root.removeMember("fine_plane_steps"); // written before the refinement skipped planes
  EXPECT_EQ(xp::ParseRegistrationRecord(Json::writeString(Json::StreamWriterBuilder(), root), "old.json").finePlaneSteps,
    (std::array<int, 3>{ { 1, 1, 1 } }));
  for (const Json::Value& bad : { Json::Value(0), Json::Value(5), Json::Value(1.5), Json::Value("2") })
  {
    std::istringstream(current) >> root;
    root["fine_plane_steps"][2] = bad;
    try
    {
      xp::ParseRegistrationRecord(Json::writeString(Json::StreamWriterBuilder(), root), "run/result.json");
      ADD_FAILURE() << "a plane step of " << bad << " was accepted";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("fine_plane_steps[2]"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("run/result.json"), std::string::npos) << e.what();
    }
  }
}

TEST(RegistrationRecord, AStagesKindIsOneOfTheScheduleKindsOrAbsent)
{
  const std::string current = xp::RegistrationRecordJSON(FailedRecord());
  const auto withStage = [&](const Json::Value* kind)
  {
    Json::Value root;
    std::istringstream(current) >> root;
    Json::Value stage(Json::objectValue);
    stage["name"] = "fine";
    stage["first_evaluation"] = 0;
    stage["evaluations"] = 3;
    stage["seconds"] = 0.5;
    if (kind)
      stage["kind"] = *kind;
    root["convergence"]["stages"].append(stage);
    return Json::writeString(Json::StreamWriterBuilder(), root);
  };
  const Json::Value refinement("refinement");
  const xp::RegistrationRecord read = xp::ParseRegistrationRecord(withStage(&refinement), "run/result.json");
  ASSERT_FALSE(read.stages.empty());
  EXPECT_EQ(read.stages.back().kind, xp::StageKind::Refinement);
  EXPECT_EQ(read.stages.back().evaluations, 3);
  EXPECT_NO_THROW(xp::ParseRegistrationRecord(withStage(nullptr), "old/result.json")) << "records before the stages' kinds";
  for (const Json::Value& bad : { Json::Value("fine"), Json::Value(2), Json::Value(Json::nullValue) })
  {
    try
    {
      xp::ParseRegistrationRecord(withStage(&bad), "run/result.json");
      ADD_FAILURE() << "a stage of kind " << bad.toStyledString() << " was accepted";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("convergence.stages"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("run/result.json"), std::string::npos) << e.what();
    }
  }
}

TEST(RegistrationRecord, ADamagedRecordNamesTheFileAndTheField)
{
  const std::string good = xp::RegistrationRecordJSON(FailedRecord());
  const auto refusal = [](const std::string& text)
  {
    try
    {
      xp::ParseRegistrationRecord(text, "run/result.json");
    }
    catch (const xp::InputError& e)
    {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(refusal("{\"status\": \"ok\"").find("run/result.json"), std::string::npos) << "not JSON";
  EXPECT_NE(refusal("{\"status\": \"ok\"}").find("field 'misalignment"), std::string::npos);
  std::string text = good;
  text.replace(text.find("\"failed\""), 8, "\"maybe\"");
  EXPECT_NE(refusal(text).find("'status'"), std::string::npos) << refusal(text);
  text = good;
  text.replace(text.find("\"low_explained\""), 15, "\"low_mood\"");
  EXPECT_NE(refusal(text).find("unknown code 'low_mood'"), std::string::npos) << refusal(text);
  text = good;
  text.replace(text.find("\"seconds\" : 1.5"), 15, "\"seconds\" : \"x\"");
  EXPECT_NE(refusal(text).find("'convergence.stages'"), std::string::npos) << refusal(text);
  text = good;
  text.replace(text.find("\"failed\""), 8, "\"ok\"");
  EXPECT_NE(refusal(text).find("'failures'"), std::string::npos) << "ok with failures: " << refusal(text);
}

// The user guide's table of result.json's fields names every field a record can hold, and no
// field a record does not write: a field added to the record without its line there, or a line
// left behind by a renamed field, fails here.
namespace
{

/** An ok record with every optional part the schema knows. */
xp::RegistrationRecord Everything()
{
  xp::RegistrationRecord everything = FailedRecord();
  everything.ok = true;
  everything.failures.clear();
  everything.couch.emplace();
  everything.couch->couch.pitchRollLimitDegrees = 3.0;
  everything.couch->limitedBy = { "pitch_limit" };
  everything.table.emplace().tableCM3 = 1200.0;
  everything.table->withTable = 0.25;
  everything.table->bodyOnly = 0.125;
  everything.restartsApartMM = 0.25;
  everything.restartsApartDegrees = 0.1;
  everything.volumeToRoom = Eigen::Isometry3d(Eigen::Translation3d(1.5, -2.0, 0.25));
  everything.volumeCenter = Eigen::Vector3d(10.0, 20.0, -30.0);
  everything.edgeDistanceMM = everything.edgeDistanceShiftedMM = { 0.5, 0.75 };
  everything.xrayCorrelation = { -0.5, 0.25 };
  everything.halvesApartMM = { 0.125, 1.5 };
  everything.uncertainty = { 0.5, 0.25, std::numeric_limits<double>::infinity(), 0.1, 0.2, 0.3 };
  everything.peakMargin = 0.0625;
  everything.peakLeads.fill(0.03125);
  everything.boneOnly = true;
  everything.inputs.emplace().ct = "/data/ct";
  everything.readSeconds = 0.5;
  return everything;
}

std::set<std::string> FieldsWritten(const xp::RegistrationRecord& record)
{
  Json::Value root;
  std::istringstream(xp::RegistrationRecordJSON(record)) >> root;
  std::set<std::string> written;
  for (const std::string& name : root.getMemberNames())
    written.insert(name);
  return written;
}

} // namespace

// The schema is the record: every field it lists is written for a record that has it, nothing
// else is, and what is read back writes the same text again (a field written but not read, or
// read into the wrong place, would not).
TEST(RegistrationRecord, TheSchemaListsWhatIsWrittenAndReadsItAllBack)
{
  const xp::RegistrationRecord everything = Everything();
  std::set<std::string> listed;
  for (const xp::RegistrationRecordField& field : xp::RegistrationRecordSchema())
  {
    EXPECT_TRUE(listed.insert(field.name).second) << "'" << field.name << "' is listed twice";
    EXPECT_FALSE(field.type.empty() || field.meaning.empty() || field.presence.empty()) << field.name;
    EXPECT_TRUE(!field.required || field.presence == "always") << field.name << ": required but not always written";
  }
  EXPECT_EQ(FieldsWritten(everything), listed);
  const std::string text = xp::RegistrationRecordJSON(everything);
  EXPECT_EQ(xp::RegistrationRecordJSON(xp::ParseRegistrationRecord(text, "result.json")), text);
  // A required field's absence is refused by name; an optional one's keeps the default, unless
  // it is written together with another (`volume_center` with `volume_to_room`), when it too is
  // refused by name.
  for (const xp::RegistrationRecordField& field : xp::RegistrationRecordSchema())
  {
    Json::Value root;
    std::istringstream(text) >> root;
    root.removeMember(field.name);
    const std::string without = Json::writeString(Json::StreamWriterBuilder(), root);
    try
    {
      xp::ParseRegistrationRecord(without, "older.json");
      EXPECT_FALSE(field.required) << "a record without '" << field.name << "' was accepted";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_TRUE(field.required || field.presence.rfind("with ", 0) == 0) << e.what();
      EXPECT_NE(std::string(e.what()).find("'" + field.name), std::string::npos) << e.what();
    }
  }
}

TEST(RegistrationRecord, TheUserGuideListsEveryFieldItWrites)
{
  std::set<std::string> written;
  for (const xp::RegistrationRecordField& field : xp::RegistrationRecordSchema())
    written.insert(field.name);

  std::ifstream guide(std::string(XP_SOURCE_DIR) + "/Documentation/UserGuide.md");
  ASSERT_TRUE(guide) << "Documentation/UserGuide.md not found under " << XP_SOURCE_DIR;
  // The table's rows: from the line that starts with the `status` row to the table's end; each
  // row's first cell names one or more fields in backquotes.
  std::set<std::string> listed;
  bool inTable = false;
  for (std::string line; std::getline(guide, line);)
  {
    inTable = inTable ? line.rfind('|', 0) == 0 : line.rfind("| `status` |", 0) == 0;
    if (!inTable)
      continue;
    const std::string cell = line.substr(1, line.find('|', 1) - 1);
    static const std::regex name("`([a-z0-9_]+)`");
    for (auto match = std::sregex_iterator(cell.begin(), cell.end(), name); match != std::sregex_iterator(); ++match)
      listed.insert((*match)[1]);
  }
  ASSERT_FALSE(listed.empty()) << "no `status` row in the user guide's result.json table";
  for (const std::string& field : written)
    EXPECT_TRUE(listed.count(field)) << "result.json writes '" << field << "', which the user guide's table does not list";
  for (const std::string& field : listed)
    EXPECT_TRUE(written.count(field)) << "the user guide lists '" << field << "', which no result.json holds";
}
