// A registration through a real archive as a hospital runs one: Orthanc with its DICOMweb plugin
// and a password, behind an nginx TLS proxy with a certificate made here, all on loopback with
// temporary configurations. The CT and X-rays are fetched by UID, the results go back to the
// study (the REG last), and the pose equals that of the same files given on the command line.
// Wrong credentials, an untrusted certificate, an unreachable host and an archive that answers
// garbage are clear errors; no credential appears in any output. Label: pacs.
#include "xpArchiveAccess.h"
#include "xpCommands.h"
#include "xpDICOMSeries.h"
#include "xpDICOMSeriesWriter.h"
#include "xpDICOMwebArchive.h"
#include "xpError.h"
#include "xpTestProcesses.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

namespace
{

const std::string Geometry = std::string(XP_SOURCE_DIR) + "/Data/geometry/stereo-oblique-90.json";
const std::string OrthancDICOMweb = "/usr/share/orthanc/plugins/libOrthancDicomWeb.so";
const std::string User = "radiology", Password = "Xq7-secret-word-9Lz";

/** The SOP Instance UID of a file xpose wrote (explicit VR little endian: tag, "UI", length). */
std::string InstanceUID(const std::string& path)
{
  const std::string bytes = xp::ReadWholeFile(path);
  const size_t at = bytes.find(std::string("\x08\x00\x18\x00UI", 6));
  if (at == std::string::npos)
    return "";
  const size_t length = static_cast<unsigned char>(bytes[at + 6]) | static_cast<unsigned char>(bytes[at + 7]) << 8;
  std::string uid = bytes.substr(at + 8, length);
  while (!uid.empty() && uid.back() == '\0')
    uid.pop_back();
  return uid;
}

/** Every value of the short-VR element (group, element) in explicit VR little endian bytes, in
 *  order (sequences of either length encoding hold them as they are). */
std::vector<std::string> ElementValues(const std::string& bytes, uint16_t group, uint16_t element)
{
  const char tag[4] = { static_cast<char>(group & 0xff), static_cast<char>(group >> 8), static_cast<char>(element & 0xff),
    static_cast<char>(element >> 8) };
  std::vector<std::string> values;
  for (size_t at = bytes.find(std::string(tag, 4)); at != std::string::npos; at = bytes.find(std::string(tag, 4), at + 1))
  {
    if (at + 8 > bytes.size())
      break;
    const size_t length = static_cast<unsigned char>(bytes[at + 6]) | static_cast<unsigned char>(bytes[at + 7]) << 8;
    values.push_back(bytes.substr(at + 8, length));
  }
  return values;
}

/** Every file under `folder` (recursively) whose bytes hold `text`. */
std::vector<std::string> FilesHolding(const std::string& folder, const std::string& text)
{
  std::vector<std::string> found;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(folder))
    if (entry.is_regular_file() && xp::ReadWholeFile(entry.path().string()).find(text) != std::string::npos)
      found.push_back(entry.path().string());
  return found;
}



Json::Value ReadJSON(const std::string& path)
{
  Json::Value value;
  std::ifstream in(path);
  in >> value;
  return value;
}

/** Orthanc (DICOMweb, a registered user, loopback only) behind nginx serving HTTPS. */
class ArchiveTest : public ::testing::Test
{
protected:
  void SetUp() override
  {
    for (const char* tool : { "Orthanc", "nginx", "openssl" })
      if (std::system(("command -v " + std::string(tool) + " > /dev/null 2>&1").c_str()) != 0)
        GTEST_SKIP() << tool << " is not installed (Debian orthanc, nginx-light, openssl): the archive tests are skipped";
    if (!std::filesystem::exists(OrthancDICOMweb))
      GTEST_SKIP() << OrthancDICOMweb << " missing (Debian orthanc-dicomweb): the archive tests are skipped";
    this->Folder = std::filesystem::absolute("archive-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    std::filesystem::remove_all(this->Folder);
    std::filesystem::create_directories(this->Folder + "/storage");
    std::filesystem::create_directories(this->Folder + "/nginx");
    ASSERT_EQ(std::system(("openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=127.0.0.1 -addext subjectAltName=IP:127.0.0.1 "
                           "-keyout " + this->Folder + "/key.pem -out " + this->Folder + "/cert.pem > " + this->Folder +
                           "/openssl.log 2>&1").c_str()), 0);
    this->CredentialsFile = this->Folder + "/credentials";
    std::ofstream(this->CredentialsFile) << User << ":" << Password << "\n";
    chmod(this->CredentialsFile.c_str(), 0600);
    // A server that could not take its port (another process took it first) ends at once: start
    // both again on other ports rather than wait for an answer that cannot come.
    std::string why;
    for (int start = 0; start < 3; ++start)
    {
      why = this->StartArchive(start);
      if (why.empty())
        return;
      xp::test::StopProcess(this->Nginx);
      xp::test::StopProcess(this->Orthanc);
    }
    FAIL() << why;
  }

  /** Starts Orthanc and nginx on free ports and waits up to a minute (a loaded two-core machine
   *  starts Orthanc slowly) for the archive to answer through both: empty when it does, else why. */
  std::string StartArchive(int start)
  {
    this->HTTPPort = xp::test::FreeLoopbackPorts(3, start);
    this->TLSPort = this->HTTPPort + 1;
    this->DICOMPort = this->HTTPPort + 2;
    std::ofstream(this->Folder + "/orthanc.json")
      << "{ \"Name\": \"xpose-test\", \"StorageDirectory\": \"" << this->Folder << "/storage\", \"IndexDirectory\": \""
      << this->Folder << "/storage\", \"HttpPort\": " << this->HTTPPort
      << ", \"DicomServerEnabled\": true, \"DicomAet\": \"ORTHANC\", \"DicomPort\": " << this->DICOMPort
      << ", \"DicomModalities\": { \"xpose\": { \"AET\": \"XPOSE\", \"Host\": \"127.0.0.1\", \"Port\": 104, \"AllowEcho\": true,"
      << " \"AllowFind\": true, \"AllowGet\": true, \"AllowStore\": true } },"
      << " \"RemoteAccessAllowed\": false, \"AuthenticationEnabled\": true,"
      << " \"RegisteredUsers\": { \"" << User << "\": \"" << Password << "\" }, \"Plugins\": [ \"" << OrthancDICOMweb
      << "\" ], \"DicomWeb\": { \"Enable\": true, \"Root\": \"/dicom-web/\" } }\n";
    // HTTPS as Orthanc's documentation advises: a reverse proxy in front of it. /garbage/ answers
    // what no archive would.
    std::ofstream(this->Folder + "/nginx.conf")
      << "daemon off; worker_processes 1; pid " << this->Folder << "/nginx/nginx.pid; error_log " << this->Folder << "/nginx/error.log;\n"
      << (getuid() == 0 ? "user root;\n" : "") << "events { worker_connections 64; }\n"
      << "http { access_log off; client_max_body_size 0; client_body_temp_path " << this->Folder << "/nginx/body; proxy_temp_path "
      << this->Folder << "/nginx/proxy; fastcgi_temp_path " << this->Folder << "/nginx/fastcgi; uwsgi_temp_path " << this->Folder
      << "/nginx/uwsgi; scgi_temp_path " << this->Folder << "/nginx/scgi;\n"
      << "  server { listen 127.0.0.1:" << this->TLSPort << " ssl; ssl_certificate " << this->Folder << "/cert.pem; ssl_certificate_key "
      << this->Folder << "/key.pem;\n"
      << "    location /dicom-web/ { proxy_pass http://127.0.0.1:" << this->HTTPPort << "; proxy_read_timeout 300s; }\n"
      << "    location /garbage/ { default_type application/dicom+json; return 200 'this is not DICOM JSON'; } } }\n";
    this->Orthanc = xp::test::StartProcess(this->Folder + "/orthanc.log", { "Orthanc", this->Folder + "/orthanc.json" });
    this->Nginx = xp::test::StartProcess(this->Folder + "/nginx.log",
      { "nginx", "-p", this->Folder + "/nginx", "-c", this->Folder + "/nginx.conf", "-e", this->Folder + "/nginx/error.log" });
    this->Url = "https://127.0.0.1:" + std::to_string(this->TLSPort) + "/dicom-web";
    const std::string logs = " (see " + this->Folder + "/orthanc.log and nginx/error.log)";
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < end)
    {
      const bool orthancRuns = xp::test::StillRunning(this->Orthanc), nginxRuns = xp::test::StillRunning(this->Nginx);
      if (!orthancRuns || !nginxRuns)
      {
        this->Orthanc = orthancRuns ? this->Orthanc : 0; // an ended process was reaped: nothing to stop
        this->Nginx = nginxRuns ? this->Nginx : 0;
        return std::string(orthancRuns ? "nginx" : "Orthanc") + " ended while starting on ports " + std::to_string(this->HTTPPort) + "-" +
          std::to_string(this->DICOMPort) + logs;
      }
      try
      {
        this->Archive().CheckReachable();
        return "";
      }
      catch (const xp::Error&)
      {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
      }
    }
    return "the archive did not answer at " + this->Url + " within a minute" + logs;
  }

  void TearDown() override
  {
    xp::test::StopProcess(this->Nginx);
    xp::test::StopProcess(this->Orthanc);
  }

  xp::ArchiveAccess Access() const
  {
    xp::ArchiveAccess access = xp::ResolveArchiveAccess(this->CredentialsFile, this->Folder + "/cert.pem");
    access.connectAttempts = 1;
    return access;
  }
  xp::DICOMwebArchive Archive() const { return xp::DICOMwebArchive(this->Url, this->Access()); }

  /** Stores every file of `folder` (sorted) in the archive. */
  void StoreFolder(const std::string& folder) const
  {
    std::vector<std::string> files;
    for (const auto& entry : std::filesystem::directory_iterator(folder))
      files.push_back(entry.path().string());
    std::sort(files.begin(), files.end());
    this->Archive().Store(files);
  }

  /** The study held only in the archive: the phantom CT and two X-rays (RT Image DRRs of a known
   *  misalignment); and the result of registering the same files from the command line. */
  struct Study
  {
    std::string studyUID;
    std::vector<std::string> xrays; ///< SOP Instance UIDs, imager order
    Json::Value direct;             ///< result.json of the files given on the command line
  };
  Study MakeStudy() const
  {
    Study study;
    const std::string local = this->Folder + "/local";
    xp::PhantomOptions phantom;
    phantom.outputDirectory = local + "/ct";
    phantom.spacing = 3.0;
    EXPECT_EQ(xp::GuardedRun("phantom", [&] { return xp::RunPhantom(phantom); }), xp::ExitOk);
    xp::DRROptions drr;
    drr.ct = phantom.outputDirectory;
    drr.geometry = Geometry;
    drr.pose = "5,-3,2,1,-1,1.5";
    drr.outputDirectory = local + "/drr";
    drr.dicomOutputDirectory = local + "/xrays";
    drr.size = "512x384"; // RT Images read out binned 2x2 from the geometry's 1024x768 panels
    EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
    this->StoreFolder(phantom.outputDirectory);
    this->StoreFolder(drr.dicomOutputDirectory);
    study.studyUID = xp::ScanCTSeries(phantom.outputDirectory).studyInstanceUID;
    study.xrays = { InstanceUID(drr.dicomOutputDirectory + "/drr_A.dcm"), InstanceUID(drr.dicomOutputDirectory + "/drr_B.dcm") };
    xp::RegisterOptions direct;
    direct.ct = phantom.outputDirectory;
    direct.xrays = { drr.dicomOutputDirectory + "/drr_A.dcm", drr.dicomOutputDirectory + "/drr_B.dcm" };
    direct.geometry = Geometry;
    direct.size = Eigen::Vector2i(256, 192);
    direct.outputDirectory = this->Folder + "/direct";
    EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(direct); }), xp::ExitOk);
    study.direct = ReadJSON(direct.outputDirectory + "/result.json");
    std::filesystem::remove_all(local); // from here on, the study is in the archive only
    return study;
  }

  /** The study's REG and RT Images in the archive, and the REG written is the one stored: byte
   *  for byte through DICOMweb; through DIMSE, which re-encodes (dcmtk's meta header, sequence
   *  lengths), with the same instance UID and transformation matrices. */
  void ExpectResultsStored(const Study& study, const std::string& out, bool byteForByte) const
  {
    int regs = 0, rtImages = 0;
    for (const xp::ArchivedSeries& series : this->Archive().SeriesOfStudy(study.studyUID))
    {
      regs += series.modality == "REG";
      rtImages += series.modality == "RTIMAGE" ? series.instances : 0;
    }
    EXPECT_EQ(regs, 1);
    EXPECT_EQ(rtImages, 4); // the two X-rays and the two DRRs of the result
    const std::string written = out + "/dicom/reg.dcm";
    this->Archive().FetchInstance(InstanceUID(written), this->Folder + "/reg-back.dcm");
    const std::string back = xp::ReadWholeFile(this->Folder + "/reg-back.dcm"), sent = xp::ReadWholeFile(written);
    if (byteForByte)
      EXPECT_TRUE(back == sent) << "the REG stored differs from the REG written";
    const std::vector<std::string> matrices = ElementValues(sent, 0x3006, 0x00C6);
    EXPECT_EQ(matrices.size(), 2u);
    EXPECT_EQ(ElementValues(back, 0x3006, 0x00C6), matrices);
    EXPECT_EQ(InstanceUID(this->Folder + "/reg-back.dcm"), InstanceUID(written));
    for (const std::string& xray : study.xrays) // the REG names the X-rays it was found from
      EXPECT_NE(xp::ReadWholeFile(written).find(xray), std::string::npos) << xray;
    // The pose from the archive is the pose from the files.
    const Json::Value fetched = ReadJSON(out + "/result.json");
    EXPECT_EQ(fetched["status"].asString(), "ok");
    const Json::Value& pose = fetched["misalignment"];
    const Json::Value& expected = study.direct["misalignment"];
    ASSERT_EQ(pose["translation_mm"].size(), 3u);
    for (Json::ArrayIndex a = 0; a < 3; ++a)
      EXPECT_EQ(pose["translation_mm"][a].asDouble(), expected["translation_mm"][a].asDouble()) << a;
    for (const char* angle : { "pitch", "roll", "yaw" })
    {
      ASSERT_TRUE(pose["rotation_deg"][angle].isDouble()) << angle;
      EXPECT_EQ(pose["rotation_deg"][angle].asDouble(), expected["rotation_deg"][angle].asDouble()) << angle;
    }
  }

  std::string Folder, Url, CredentialsFile;
  int HTTPPort = 0, TLSPort = 0, DICOMPort = 0;
  pid_t Orthanc = 0, Nginx = 0;
};

} // namespace

TEST_F(ArchiveTest, RegistersAStudyHeldOnlyInTheArchiveOverTLSAndStoresTheResultsBack)
{
  const Study study = this->MakeStudy();
  // The xpose process, as a user runs it: credentials from the environment, the CA given.
  const std::string out = this->Folder + "/result", log = this->Folder + "/register.log";
  const std::string command = "XPOSE_PACS_USER='" + User + "' XPOSE_PACS_PASSWORD='" + Password + "' '" + XP_XPOSE_EXECUTABLE +
    "' register --pacs " + this->Url + " --ca-file " + this->Folder + "/cert.pem --study " + study.studyUID +
    " --xray-instance " + study.xrays[0] + " --xray-instance " + study.xrays[1] + " --geometry " + Geometry +
    " --size 256x192 --out-dir " + out + " --report " + out + "/report > " + log + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << xp::ReadWholeFile(log);
  this->ExpectResultsStored(study, out, true);
  // No credential in anything written or printed.
  EXPECT_EQ(FilesHolding(out, Password), std::vector<std::string>());
  EXPECT_EQ(xp::ReadWholeFile(log).find(Password), std::string::npos);
}

TEST_F(ArchiveTest, RegistersThroughDIMSE)
{
  // The same study through Orthanc's DICOM port: C-FIND, C-GET, C-STORE as the AE title its
  // configuration declares.
  const Study study = this->MakeStudy();
  xp::RegisterOptions options;
  options.pacs = "dicom://ORTHANC@127.0.0.1:" + std::to_string(this->DICOMPort);
  options.study = study.studyUID;
  options.xrayInstances = study.xrays;
  options.geometry = Geometry;
  options.size = Eigen::Vector2i(256, 192);
  options.outputDirectory = this->Folder + "/dimse";
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  this->ExpectResultsStored(study, options.outputDirectory, false);
  // An AE title the archive does not know may not fetch.
  options.aet = "STRANGER";
  options.outputDirectory = this->Folder + "/stranger";
  EXPECT_NE(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  EXPECT_FALSE(std::filesystem::exists(options.outputDirectory + "/result.json"));
}

TEST_F(ArchiveTest, WrongCredentialsUntrustedCertificatesUnreachableHostsAndGarbageAreClearErrors)
{
  xp::RegisterOptions options;
  options.pacs = this->Url;
  options.caFile = this->Folder + "/cert.pem";
  options.pacsCredentials = this->CredentialsFile;
  options.ctSeries = "1.2.826.0.1.3680043.2.1143.77.2";
  options.xrayInstances = { "1.2.3", "1.2.4" };
  options.geometry = Geometry;
  const auto refused = [&](const std::string& name, const std::string& expected)
  {
    options.outputDirectory = this->Folder + "/" + name;
    testing::internal::CaptureStderr();
    const int code = xp::GuardedRun("register", [&] { return xp::RunRegister(options); });
    const std::string message = testing::internal::GetCapturedStderr();
    EXPECT_EQ(code, xp::ExitBadInput) << name << ": " << message;
    EXPECT_NE(message.find(expected), std::string::npos) << name << ": " << message;
    EXPECT_EQ(message.find(Password), std::string::npos) << name;
    EXPECT_FALSE(std::filesystem::exists(options.outputDirectory + "/result.json")) << name;
  };
  // A series the archive does not hold.
  refused("no-series", "holds 0 series");
  // A wrong password: the archive says 401, and the message says so without the password.
  const std::string wrong = this->Folder + "/wrong-credentials";
  std::ofstream(wrong) << User << ":not-" << Password << "\n";
  chmod(wrong.c_str(), 0600);
  options.pacsCredentials = wrong;
  refused("wrong-password", "refused the credentials (HTTP 401)");
  options.pacsCredentials = this->CredentialsFile;
  // The proxy's certificate without --ca-file: not in the system's store.
  options.caFile.clear();
  refused("untrusted", "not trusted");
  options.caFile = this->Folder + "/cert.pem";
  // Nothing listens; a URL without the service root; an answer that is not DICOM JSON.
  options.pacs = "https://127.0.0.1:1/dicom-web";
  refused("unreachable", "no archive answers there");
  options.pacs = "https://127.0.0.1:" + std::to_string(this->TLSPort);
  refused("no-root", "/dicom-web");
  options.pacs = "https://127.0.0.1:" + std::to_string(this->TLSPort) + "/garbage";
  refused("garbage", "not as a DICOMweb service");
}

TEST_F(ArchiveTest, AmbiguousOrMissingCTsAndRefusedFilesAreReported)
{
  const xp::DICOMwebArchive archive = this->Archive();
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
  this->StoreFolder(this->Folder + "/one");
  EXPECT_EQ(archive.CTSeriesOfStudy(first.studyInstanceUID), first.seriesInstanceUID);
  this->StoreFolder(this->Folder + "/two");
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
  // The series comes back whole: three slices.
  std::filesystem::create_directories(this->Folder + "/fetched");
  EXPECT_EQ(archive.FetchSeries(first.seriesInstanceUID, this->Folder + "/fetched").size(), 3u);

  // A refused file stops the store: the error lists what was stored and what was not, and the
  // file after it is not sent.
  std::filesystem::create_directories(this->Folder + "/batch");
  xp::CTSeriesWriteOptions third = first;
  third.seriesInstanceUID = "1.2.826.0.1.3680043.2.1143.77.4";
  const std::vector<std::string> good = xp::WriteCTSeries(volume, this->Folder + "/batch", third);
  const std::string bad = this->Folder + "/batch/not-dicom.dcm";
  std::ofstream(bad) << "not a DICOM file";
  try
  {
    archive.Store({ good[0], bad, good[1] });
    ADD_FAILURE() << "a file that is not DICOM was stored";
  }
  catch (const xp::Error& e)
  {
    const std::string message = e.what();
    EXPECT_NE(message.find("Stored: " + std::filesystem::path(good[0]).filename().string()), std::string::npos) << message;
    EXPECT_NE(message.find("not stored: not-dicom.dcm " + std::filesystem::path(good[1]).filename().string()), std::string::npos)
      << message;
  }
  // Credentials the archive refuses when storing: bad input, as when fetching, with the same list.
  const std::string wrong = this->Folder + "/wrong-credentials";
  std::ofstream(wrong) << User << ":not-" << Password << "\n";
  chmod(wrong.c_str(), 0600);
  xp::ArchiveAccess refusedAccess = xp::ResolveArchiveAccess(wrong, this->Folder + "/cert.pem");
  refusedAccess.connectAttempts = 1;
  try
  {
    xp::DICOMwebArchive(this->Url, refusedAccess).Store({ good[1] });
    ADD_FAILURE() << "a store with a wrong password was accepted";
  }
  catch (const xp::InputError& e)
  {
    const std::string message = e.what();
    EXPECT_NE(message.find("refused the credentials (HTTP 401)"), std::string::npos) << message;
    EXPECT_NE(message.find("Stored: none; not stored: " + std::filesystem::path(good[1]).filename().string()), std::string::npos)
      << message;
    EXPECT_EQ(message.find(Password), std::string::npos) << message;
  }
  int instances = -1;
  for (const xp::ArchivedSeries& series : archive.SeriesOfStudy(first.studyInstanceUID))
    if (series.seriesInstanceUID == third.seriesInstanceUID)
      instances = series.instances;
  EXPECT_EQ(instances, 1);
}
