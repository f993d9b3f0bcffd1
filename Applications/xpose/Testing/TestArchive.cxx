// A registration through a real archive (Orthanc, started here on loopback with a temporary
// configuration and storage): the CT and X-rays are fetched by UID, the REG and the RT Images go
// back to the same study, and what comes back equals what was written. Label: pacs.
#include "xpCommands.h"
#include "xpDICOMSeries.h"
#include "xpDICOMSeriesWriter.h"
#include "xpError.h"
#include "xpOrthanc.h"
#include "xpWholeFile.h"

#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace
{

const std::string Geometry = std::string(XP_SOURCE_DIR) + "/Data/geometry/stereo-oblique-90.json";

std::string Contents(const std::string& path)
{
  return xp::ReadWholeFile(path);
}

/** The SOP Instance UID of a file xpose wrote (ScanCTSeries-free: the RT Image's own tag). */
std::string InstanceUID(const std::string& path)
{
  // xpose writes explicit VR little endian: (0008,0018) UI, a 2-byte length, the value.
  const std::string bytes = Contents(path);
  const std::string tag("\x08\x00\x18\x00UI", 6);
  const size_t at = bytes.find(tag);
  if (at == std::string::npos)
    return "";
  const size_t length = static_cast<unsigned char>(bytes[at + 6]) | static_cast<unsigned char>(bytes[at + 7]) << 8;
  std::string uid = bytes.substr(at + 8, length);
  while (!uid.empty() && uid.back() == '\0')
    uid.pop_back();
  return uid;
}

/** An Orthanc server of its own: temporary storage, HTTP on a free loopback port, stopped after. */
class ArchiveTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    if (std::system("command -v Orthanc > /dev/null 2>&1") != 0)
      GTEST_SKIP() << "Orthanc (Debian package orthanc) not installed: the archive tests are skipped";
    this->Folder = "archive-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(this->Folder);
    std::filesystem::create_directories(this->Folder + "/storage");
    this->Port = 20000 + static_cast<int>(getpid() % 20000);
    std::ofstream(this->Folder + "/orthanc.json")
      << "{ \"Name\": \"xpose-test\", \"StorageDirectory\": \"" << this->Folder << "/storage\", \"IndexDirectory\": \""
      << this->Folder << "/storage\", \"HttpPort\": " << this->Port
      << ", \"DicomServerEnabled\": false, \"RemoteAccessAllowed\": false, \"AuthenticationEnabled\": false }\n";
    this->Server = fork();
    if (this->Server == 0)
    {
      std::freopen((this->Folder + "/orthanc.log").c_str(), "w", stdout);
      std::freopen((this->Folder + "/orthanc.log").c_str(), "a", stderr);
      execlp("Orthanc", "Orthanc", (this->Folder + "/orthanc.json").c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    this->Url = "http://127.0.0.1:" + std::to_string(this->Port);
    for (int attempt = 0; attempt < 100; ++attempt)
    {
      try
      {
        xp::OrthancArchive(this->Url).CheckReachable();
        return;
      }
      catch (const xp::Error&)
      {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    }
    GTEST_SKIP() << "Orthanc did not start on port " << this->Port << " (see " << this->Folder << "/orthanc.log)";
  }

  void TearDown() override
  {
    if (this->Server > 0)
    {
      kill(this->Server, SIGTERM);
      waitpid(this->Server, nullptr, 0);
    }
  }

  std::string Folder, Url;
  int Port = 0;
  pid_t Server = 0;
};

/** Stores every file of `folder` (sorted) in the archive. */
void StoreFolder(const xp::OrthancArchive& archive, const std::string& folder)
{
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(folder))
    files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  archive.Store(files);
}

} // namespace

TEST_F(ArchiveTest, RegistersAStudyHeldOnlyInTheArchiveAndStoresTheResultsBack)
{
  const xp::OrthancArchive archive(this->Url);
  // The study: the phantom CT, and two X-rays (RT Image DRRs of a known misalignment).
  const std::string local = this->Folder + "/local";
  xp::PhantomOptions phantom;
  phantom.outputDirectory = local + "/ct";
  phantom.spacing = 3.0;
  ASSERT_EQ(xp::GuardedRun("phantom", [&] { return xp::RunPhantom(phantom); }), xp::ExitOk);
  xp::DRROptions drr;
  drr.ct = phantom.outputDirectory;
  drr.geometry = Geometry;
  drr.pose = "5,-3,2,1,-1,1.5";
  drr.outputDirectory = local + "/drr";
  drr.dicomOutputDirectory = local + "/xrays";
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  StoreFolder(archive, phantom.outputDirectory);
  StoreFolder(archive, drr.dicomOutputDirectory);
  const xp::CTSeriesInfo ct = xp::ScanCTSeries(phantom.outputDirectory);
  const std::vector<std::string> xrays = { InstanceUID(drr.dicomOutputDirectory + "/drr_A.dcm"),
    InstanceUID(drr.dicomOutputDirectory + "/drr_B.dcm") };
  std::filesystem::remove_all(local); // from here on, the study is in the archive only

  xp::RegisterOptions options;
  options.pacs = this->Url;
  options.study = ct.studyInstanceUID;
  options.xrayInstances = xrays;
  ASSERT_FALSE(xrays[0].empty());
  options.geometry = Geometry;
  options.size = "256x192";
  options.outputDirectory = this->Folder + "/result";
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);

  // The study now holds the REG and the RT Images, and the REG that comes back is the one written.
  int regs = 0, rtImages = 0;
  for (const xp::ArchivedSeries& series : archive.SeriesOfStudy(ct.studyInstanceUID))
  {
    regs += series.modality == "REG";
    rtImages += series.modality == "RTIMAGE" ? series.instances : 0;
  }
  EXPECT_EQ(regs, 1);
  EXPECT_EQ(rtImages, 4); // the two X-rays and the two DRRs of the result
  const std::string written = options.outputDirectory + "/dicom/reg.dcm";
  archive.FetchInstance(InstanceUID(written), this->Folder + "/reg-back.dcm");
  EXPECT_EQ(Contents(this->Folder + "/reg-back.dcm"), Contents(written));
  for (const std::string& xray : xrays) // the REG names the X-rays it was found from
    EXPECT_NE(Contents(written).find(xray), std::string::npos) << xray;
}

TEST_F(ArchiveTest, AmbiguousOrMissingCTsUnreachableArchivesAndRefusedFilesAreClearErrors)
{
  const xp::OrthancArchive archive(this->Url);
  // Two CT series in one study: the error lists both.
  xp::CTVolumeData volume;
  volume.dimensions = { 8, 6, 3 };
  volume.spacing = { 1.0, 1.0, 2.0 };
  volume.origin = { 0.0, 0.0, 0.0 };
  volume.hounsfield.assign(8 * 6 * 3, 0.0f);
  xp::CTSeriesWriteOptions first, second;
  first.studyInstanceUID = second.studyInstanceUID = "1.2.826.0.1.3680043.2.1143.77.1";
  first.seriesInstanceUID = "1.2.826.0.1.3680043.2.1143.77.2";
  second.seriesInstanceUID = "1.2.826.0.1.3680043.2.1143.77.3";
  std::filesystem::create_directories(this->Folder + "/one");
  std::filesystem::create_directories(this->Folder + "/two");
  xp::WriteCTSeries(volume, this->Folder + "/one", first);
  xp::WriteCTSeries(volume, this->Folder + "/two", second);
  StoreFolder(archive, this->Folder + "/one");
  EXPECT_EQ(archive.CTSeriesOfStudy(first.studyInstanceUID), first.seriesInstanceUID);
  StoreFolder(archive, this->Folder + "/two");
  try
  {
    archive.CTSeriesOfStudy(first.studyInstanceUID);
    ADD_FAILURE() << "two CT series were not refused";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find(first.seriesInstanceUID), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(second.seriesInstanceUID), std::string::npos) << e.what();
  }
  EXPECT_THROW(archive.CTSeriesOfStudy("1.2.3.4"), xp::InputError); // no such study

  // A refused file: the files stored before it in the same call are taken back.
  std::filesystem::create_directories(this->Folder + "/batch");
  xp::CTSeriesWriteOptions third = first;
  third.seriesInstanceUID = "1.2.826.0.1.3680043.2.1143.77.4";
  const std::vector<std::string> good = xp::WriteCTSeries(volume, this->Folder + "/batch", third);
  std::ofstream(this->Folder + "/batch/not-dicom.dcm") << "not a DICOM file";
  EXPECT_THROW(archive.Store({ good[0], good[1], this->Folder + "/batch/not-dicom.dcm", good[2] }), xp::Error);
  for (const xp::ArchivedSeries& series : archive.SeriesOfStudy(first.studyInstanceUID))
    EXPECT_NE(series.seriesInstanceUID, third.seriesInstanceUID) << "a half-stored series was left";

  // Nothing listens: a clear error, exit code 2.
  xp::RegisterOptions options;
  options.pacs = "http://127.0.0.1:" + std::to_string(this->Port + 1);
  options.ctSeries = first.seriesInstanceUID;
  options.xrayInstances = { "1.2.3", "1.2.4" };
  options.geometry = Geometry;
  options.outputDirectory = this->Folder + "/unreachable";
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  options.pacs = "ftp://somewhere";
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
}
