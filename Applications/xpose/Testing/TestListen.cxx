// xpose listen as a treatment room meets it: dcmtk's storescu sends the CT and an X-ray pair,
// the node registers the pair when the study goes quiet and forwards the REG to dcmtk's storescp;
// a second pair is registered again; a calling AE title not allowed is rejected; SIGTERM stops
// it cleanly. Label: pacs.
#include "xpCommands.h"
#include "xpTestProcesses.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

namespace
{

const std::string Geometry = std::string(XP_SOURCE_DIR) + "/Data/geometry/stereo-oblique-90.json";



Json::Value ReadJSON(const std::string& path)
{
  Json::Value value;
  std::ifstream in(path);
  in >> value;
  return value;
}

int Shell(const std::string& command)
{
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

} // namespace

TEST(Listen, RegistersEachPairSentAndForwardsTheREG)
{
  for (const char* tool : { "storescu", "storescp", "echoscu" })
    if (Shell("command -v " + std::string(tool) + " > /dev/null 2>&1") != 0)
      GTEST_SKIP() << tool << " is not installed (Debian dcmtk): the listen test is skipped";
  const std::string folder = std::filesystem::absolute("listen-node").string();
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder + "/forwarded");
  const int port = xp::test::FreeLoopbackPorts(2), forwardPort = port + 1;

  // The study: the phantom CT and two X-ray pairs of different misalignments.
  xp::PhantomOptions phantom;
  phantom.outputDirectory = folder + "/ct";
  phantom.spacing = 3.0;
  ASSERT_EQ(xp::GuardedRun("phantom", [&] { return xp::RunPhantom(phantom); }), xp::ExitOk);
  for (const std::string& pose : { "5,-3,2,1,-1,1.5", "-2,4,1,0,1,-1" })
  {
    xp::DRROptions drr;
    drr.ct = phantom.outputDirectory;
    drr.geometry = Geometry;
    drr.pose = pose;
    drr.outputDirectory = folder + "/drr-" + pose;
    drr.dicomOutputDirectory = folder + "/xrays-" + pose;
    drr.size = "512x384"; // RT Images read out binned 2x2 from the geometry's 1024x768 panels
    ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  }

  xp::test::RunningProcess receiver(folder + "/storescp.log", { "storescp", "-aet", "FWD", "-od", folder + "/forwarded", std::to_string(forwardPort) });
  xp::test::RunningProcess node(folder + "/listen.log", { XP_XPOSE_EXECUTABLE, "listen", "--port", std::to_string(port), "--geometry", Geometry,
    "--size", "256x192", "--settle", "1", "--allow-aet", "SENDER", "--forward", "dicom://FWD@127.0.0.1:" + std::to_string(forwardPort),
    "--out-dir", folder + "/node" });
  const std::string to = " -aec XPOSE 127.0.0.1 " + std::to_string(port);
  ASSERT_TRUE(xp::test::WaitFor([&] { return Shell("echoscu -aet SENDER" + to + " > /dev/null 2>&1") == 0; }, 20))
    << xp::ReadWholeFile(folder + "/listen.log");

  // A calling AE title not allowed is rejected.
  EXPECT_NE(Shell("storescu -aet INTRUDER" + to + " " + folder + "/xrays-5,-3,2,1,-1,1.5/drr_A.dcm > /dev/null 2>&1"), 0);

  // The CT and the first pair: registered into node/STUDY/, the REG forwarded.
  ASSERT_EQ(Shell("storescu -aet SENDER" + to + " " + folder + "/ct/*.dcm " + folder + "/xrays-5,-3,2,1,-1,1.5/*.dcm > " + folder +
              "/storescu.log 2>&1"), 0);
  std::string study;
  const auto firstResult = [&]
  {
    if (!std::filesystem::exists(folder + "/node"))
      return false;
    for (const auto& entry : std::filesystem::directory_iterator(folder + "/node"))
      if (std::filesystem::exists(entry.path() / "result.json"))
        study = entry.path().string();
    return !study.empty();
  };
  ASSERT_TRUE(xp::test::WaitFor(firstResult, 120)) << xp::ReadWholeFile(folder + "/listen.log");
  const Json::Value first = ReadJSON(study + "/result.json");
  EXPECT_EQ(first["status"].asString(), "ok");
  EXPECT_TRUE(xp::test::WaitFor(
    [&] { return xp::ReadWholeFile(folder + "/listen.log").find("; couch 6dof move") != std::string::npos; }, 20))
    << "the log line gives the couch motion: " << xp::ReadWholeFile(folder + "/listen.log");
  EXPECT_NEAR(first["misalignment"]["translation_mm"][0].asDouble(), 5.0, 0.5);
  EXPECT_NEAR(first["misalignment"]["translation_mm"][1].asDouble(), -3.0, 0.5);
  const auto forwarded = [&] { return !std::filesystem::is_empty(folder + "/forwarded"); };
  EXPECT_TRUE(xp::test::WaitFor(forwarded, 20)) << xp::ReadWholeFile(folder + "/storescp.log");

  // A new pair for the same study: registered again, into node/STUDY/2/.
  ASSERT_EQ(Shell("storescu -aet SENDER" + to + " " + folder + "/xrays--2,4,1,0,1,-1/*.dcm > /dev/null 2>&1"), 0);
  ASSERT_TRUE(xp::test::WaitFor([&] { return std::filesystem::exists(study + "/2/result.json"); }, 120)) << xp::ReadWholeFile(folder + "/listen.log");
  const Json::Value second = ReadJSON(study + "/2/result.json");
  EXPECT_EQ(second["status"].asString(), "ok");
  EXPECT_NEAR(second["misalignment"]["translation_mm"][1].asDouble(), 4.0, 0.5);

  const std::string log = xp::ReadWholeFile(folder + "/listen.log");
  EXPECT_NE(log.find("calling AE title 'INTRUDER' is not allowed"), std::string::npos) << log;
  EXPECT_NE(log.find("sent to dicom://FWD@"), std::string::npos) << log;

  // SIGTERM: a clean stop, exit code 0.
  EXPECT_EQ(node.Terminate(10), 0);
}
