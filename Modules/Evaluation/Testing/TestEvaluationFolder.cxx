#include "xpAccuracyEvaluation.h"
#include "xpError.h"
#include "xpEvaluationFolder.h"
#include "xpEvaluationScenario.h"
#include "xpWholeFile.h"

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>

namespace
{

xp::TrialRecord Row(int trial, const std::string& approach)
{
  xp::TrialRecord r;
  r.trial = trial;
  r.approach = approach;
  r.scenario = "clean";
  r.status = "ok";
  r.mtre = 0.1 * trial;
  r.success = true;
  return r;
}

std::string Text(const std::string& path)
{
  return xp::ReadWholeFile(path);
}

} // namespace

TEST(EvaluationFolder, ResumesWithTheSameSettingsAndRefusesOthers)
{
  ASSERT_EQ(std::system("rm -rf eval-folder"), 0);
  {
    xp::EvaluationFolder folder("eval-folder", "{ \"seed\": 1 }\n");
    EXPECT_TRUE(folder.Records().empty());
    folder.Append(Row(1, "B"));
    folder.Append(Row(2, "B"));
    EXPECT_TRUE(folder.Done(2, "B"));
    EXPECT_FALSE(folder.Done(2, "A"));
  }
  // An interruption in the middle of a row: the row is dropped on resume.
  std::ofstream("eval-folder/trials.csv", std::ios::app) << "3,B,clean,1.0";
  {
    xp::EvaluationFolder folder("eval-folder", "{ \"seed\": 1 }\n");
    ASSERT_EQ(folder.Records().size(), 2u);
    EXPECT_TRUE(folder.Done(1, "B"));
    EXPECT_FALSE(folder.Done(3, "B"));
    folder.Append(Row(3, "B"));
    // Trials beyond this run's count stay in trials.csv but not in the summary.
    EXPECT_EQ(folder.Finish(2, 2.0).size(), 2u);
  }
  EXPECT_NE(Text("eval-folder/summary.json").find("\"all\": {\"trials\": 2,"), std::string::npos) << Text("eval-folder/summary.json");
  EXPECT_EQ(xp::ReadTrialCSV("eval-folder/trials.csv").size(), 3u);
  EXPECT_THROW(xp::EvaluationFolder("eval-folder", "{ \"seed\": 2 }\n"), xp::InputError);
  EXPECT_EQ(Text("eval-folder/evaluation.json"), "{ \"seed\": 1 }\n"); // not overwritten by the refused run
}

TEST(EvaluationFolder, TrialRowsKeepEachHeldOutLeadEdgeFigureAndStageCount)
{
  xp::TrialRecord written = Row(1, "B");
  for (int k = 0; k < 12; ++k)
    written.peakLeads[k] = (k % 2 ? 1.0 : -1.0) * (k + 1) / 100.0;
  written.edgeMM = { 0.25, 1.5 };
  written.edgeMovedMM = { 1.75, -1.0 };
  written.xrayRankNoise = { 38.5, 81.25 };
  written.table = "body_only";
  written.searchEvaluations = 108, written.refinementEvaluations = 67, written.secondEndEvaluations = 5;
  written.polishEvaluations = 13, written.gateEvaluations = 14;
  ASSERT_EQ(std::system("rm -rf eval-leads && mkdir eval-leads"), 0);
  std::ofstream("eval-leads/trials.csv") << xp::TrialCSVHeader() << '\n' << xp::TrialCSVRow(written) << '\n';
  const std::vector<xp::TrialRecord> read = xp::ReadTrialCSV("eval-leads/trials.csv");
  ASSERT_EQ(read.size(), 1u);
  EXPECT_EQ(read[0].peakLeads, written.peakLeads);
  EXPECT_EQ(read[0].edgeMM, written.edgeMM);
  EXPECT_EQ(read[0].edgeMovedMM, written.edgeMovedMM);
  EXPECT_EQ(read[0].xrayRankNoise, written.xrayRankNoise);
  EXPECT_EQ(read[0].table, "body_only");
  EXPECT_EQ(read[0].searchEvaluations, 108);
  EXPECT_EQ(read[0].refinementEvaluations, 67);
  EXPECT_EQ(read[0].secondEndEvaluations, 5);
  EXPECT_EQ(read[0].polishEvaluations, 13);
  EXPECT_EQ(read[0].gateEvaluations, 14);
  // The turned neighbours not measured (NaN) come back as NaN, the translated as written.
  xp::TrialRecord translatedOnly = written;
  for (int k = 6; k < 12; ++k)
    translatedOnly.peakLeads[k] = std::numeric_limits<double>::quiet_NaN();
  std::ofstream("eval-leads/trials.csv") << xp::TrialCSVHeader() << '\n' << xp::TrialCSVRow(translatedOnly) << '\n';
  const std::vector<xp::TrialRecord> again = xp::ReadTrialCSV("eval-leads/trials.csv");
  ASSERT_EQ(again.size(), 1u);
  for (int k = 0; k < 12; ++k)
  {
    if (k < 6)
      EXPECT_EQ(again[0].peakLeads[k], written.peakLeads[k]) << k;
    else
      EXPECT_TRUE(std::isnan(again[0].peakLeads[k])) << k;
  }
  // A lead that is not wholly a number is a damaged row.
  std::string damaged = xp::TrialCSVRow(translatedOnly);
  const size_t at = damaged.find("nan");
  ASSERT_NE(at, std::string::npos);
  damaged.replace(at, 3, "0.5x");
  std::ofstream("eval-leads/trials.csv") << xp::TrialCSVHeader() << '\n' << damaged << '\n';
  EXPECT_ANY_THROW(xp::ReadTrialCSV("eval-leads/trials.csv"));
  EXPECT_EQ(read[0].reasons, written.reasons);
}

TEST(EvaluationScenario, RefusesUnknownScenariosAndEffects)
{
  EXPECT_THROW(xp::EvaluationScenario("foggy", {}, 30.0, true), xp::InputError);
  EXPECT_THROW(xp::EvaluationScenario("noisy", { "scatter" }, 30.0, true), xp::InputError);
  EXPECT_THROW(xp::EvaluationScenario("clinical", { "no-such-effect" }, 30.0, true), xp::InputError);
  const xp::EvaluationScenario clean("clean", {}, 30.0, false);
  EXPECT_EQ(clean.Model().noise, 0.0);
  EXPECT_FALSE(clean.RemovesTable()); // --remove-table takes the table away in every scenario, where asked
  EXPECT_TRUE(xp::EvaluationScenario("plastimatch", {}, 30.0, true).RemovesTable());
  const xp::EvaluationScenario objects("objects", {}, 30.0, true);
  EXPECT_EQ(objects.Model().noise, 30.0);
  EXPECT_TRUE(objects.Model().addObjects);
  const xp::EvaluationScenario clinical("clinical", { "truncation" }, 30.0, true);
  EXPECT_TRUE(clinical.RemovesTable());
  EXPECT_NE(clinical.DescribeXRays().find("\"planning_ct_cut_to\": 1"), std::string::npos) << clinical.DescribeXRays();
}

TEST(EvaluationScenario, TruncatedCTKeepsTheCentralSlicesInPlace)
{
  vtkNew<vtkImageData> ct;
  ct->SetDimensions(2, 2, 10);
  ct->SetOrigin(0.0, 0.0, 100.0);
  ct->SetSpacing(1.0, 1.0, 2.0);
  ct->AllocateScalars(VTK_FLOAT, 1);
  auto* hu = static_cast<float*>(ct->GetScalarPointer());
  for (int i = 0; i < 40; ++i)
    hu[i] = static_cast<float>(i / 4); // slice number
  const xp::EvaluationScenario truncated("truncated", {}, 0.0, true);
  vtkSmartPointer<vtkImageData> cut = truncated.RegistrationCT(ct);
  int dims[3];
  cut->GetDimensions(dims);
  ASSERT_EQ(dims[2], 5);
  EXPECT_DOUBLE_EQ(cut->GetOrigin()[2], 100.0 + 2 * 2.0); // slices 2..6
  EXPECT_EQ(cut->GetScalarComponentAsDouble(1, 1, 0, 0), 2.0);
  EXPECT_EQ(cut->GetScalarComponentAsDouble(1, 1, 4, 0), 6.0);
}

// Errors are estimated minus true, per axis, with their sign; a failed registration is never a
// success however close it ends.
TEST(AccuracyEvaluation, TrialRecordsKeepTheSignOfEachAxisError)
{
  const std::vector<Eigen::Vector3d> targets{ { 10.0, 0.0, 0.0 }, { 0.0, 10.0, 0.0 } };
  xp::Pose truth;
  truth.translation = Eigen::Vector3d(5.0, -3.0, 2.0);
  xp::StereoRegistrationResult result;
  result.ok = true;
  result.misalignment = truth;
  result.misalignment.translation += Eigen::Vector3d(0.5, 0.0, -0.25);
  const xp::TrialRecord ok = xp::MakeTrialRecord(4, "B", "noisy", truth, result, targets, Eigen::Vector3d::Zero(), 2.0, 1.5);
  EXPECT_EQ(ok.trial, 4);
  EXPECT_NEAR(ok.error[0], 0.5, 1e-12);
  EXPECT_NEAR(ok.error[1], 0.0, 1e-12);
  EXPECT_NEAR(ok.error[2], -0.25, 1e-12);
  EXPECT_NEAR(ok.mtre, std::hypot(0.5, 0.25), 1e-9); // a pure translation moves every target alike
  EXPECT_NEAR(ok.initialTranslation, truth.translation.norm(), 1e-12);
  EXPECT_TRUE(ok.success);
  EXPECT_EQ(ok.status, "ok");
  result.ok = false;
  const xp::TrialRecord failed = xp::MakeTrialRecord(4, "B", "noisy", truth, result, targets, Eigen::Vector3d::Zero(), 2.0, 1.5);
  EXPECT_EQ(failed.status, "failed");
  EXPECT_FALSE(failed.success);
}
