// What a DICOMweb archive answers is input too, and so is the URL a user gives: each malformed
// answer or URL is refused with a message that names where, before anything is sent.
#include "xpDICOMwebArchive.h"
#include "xpDIMSEArchive.h"
#include "xpError.h"

#include <gtest/gtest.h>

namespace
{

std::string InputErrorOf(const std::function<void()>& action)
{
  try
  {
    action();
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}

} // namespace

TEST(DICOMwebAnswers, ServiceRootsAreCheckedBeforeAnythingIsSent)
{
  const xp::ArchiveAccess access;
  EXPECT_EQ(xp::DICOMwebArchive("https://pacs.example:8443/dicom-web/", access).Address(), "https://pacs.example:8443/dicom-web");
  EXPECT_EQ(xp::DICOMwebArchive("http://127.0.0.1:8042/dicom-web", access).Address(), "http://127.0.0.1:8042/dicom-web");
  // No path: the message names the DICOMweb URL to use.
  const std::string noPath = InputErrorOf([&] { xp::DICOMwebArchive("http://127.0.0.1:8042", access); });
  EXPECT_NE(noPath.find("http://127.0.0.1:8042/dicom-web"), std::string::npos) << noPath;
  // Credentials in the URL would be printed and logged: refused, and not repeated.
  const std::string inURL = InputErrorOf([&] { xp::DICOMwebArchive("https://user:secret-word@pacs/dicom-web", access); });
  EXPECT_NE(inURL.find("--pacs-credentials"), std::string::npos) << inURL;
  EXPECT_EQ(inURL.find("secret-word"), std::string::npos) << inURL;
  EXPECT_THROW(xp::DICOMwebArchive("ftp://pacs/dicom-web", access), xp::InputError);
  EXPECT_THROW(xp::DICOMwebArchive("pacs:8042/dicom-web", access), xp::InputError);
  EXPECT_THROW(xp::DICOMwebArchive("https:///dicom-web", access), xp::InputError);
  EXPECT_THROW(xp::DICOMwebArchive("https://pacs/dicom-web?x=1", access), xp::InputError);
}

TEST(DICOMwebAnswers, UIDsThatWouldChangeTheURLAreRefused)
{
  EXPECT_EQ(xp::CheckedUID("1.2.840.10008.5.1.4.1.1.2", "--study"), "1.2.840.10008.5.1.4.1.1.2");
  for (const std::string& bad : { std::string("1.2/../3"), std::string("1.2?x"), std::string(""), std::string(65, '1') })
    EXPECT_NE(InputErrorOf([&] { xp::CheckedUID(bad, "--study"); }).find("--study"), std::string::npos) << bad;
}

TEST(DICOMwebAnswers, QueryAndStoreAnswersAreReadAsDICOMJSON)
{
  const std::string answer = R"([{"0020000E": {"vr": "UI", "Value": ["1.2.3"]}, "00080060": {"vr": "CS", "Value": ["CT"]},
    "00201209": {"vr": "IS", "Value": [120]}, "0008103E": {"vr": "LO", "Value": ["pelvis"]}},
    {"0020000E": {"vr": "UI", "Value": ["1.2.4"]}, "00080060": {"vr": "CS", "Value": ["REG"]}, "00201209": {"vr": "IS", "Value": ["1"]}}])";
  const std::vector<xp::ArchivedSeries> series = xp::ParseSeriesAnswer(answer, "test");
  ASSERT_EQ(series.size(), 2u);
  EXPECT_EQ(series[0].seriesInstanceUID, "1.2.3");
  EXPECT_EQ(series[0].modality, "CT");
  EXPECT_EQ(series[0].instances, 120);
  EXPECT_EQ(series[0].description, "pelvis");
  EXPECT_EQ(series[1].instances, 1); // IS as a string, as some archives send it
  EXPECT_TRUE(xp::ParseSeriesAnswer("[]", "test").empty());
  EXPECT_THROW(xp::ParseSeriesAnswer("<html>Bad gateway</html>", "test"), xp::Error);
  EXPECT_THROW(xp::ParseSeriesAnswer("{\"0020000E\": {}}", "test"), xp::Error);
  EXPECT_THROW(xp::ParseSeriesAnswer("[1, 2]", "test"), xp::Error);

  EXPECT_TRUE(xp::ParseStoreFailures(R"({"00081199": {"vr": "SQ", "Value": [{}]}})", "test").empty());
  const std::vector<std::string> failures = xp::ParseStoreFailures(
    R"({"00081198": {"vr": "SQ", "Value": [{"00081155": {"vr": "UI", "Value": ["1.2.9"]}, "00081197": {"vr": "US", "Value": [49152]}}]}})", "test");
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].find("1.2.9"), std::string::npos);
  EXPECT_NE(failures[0].find("49152"), std::string::npos);
  EXPECT_THROW(xp::ParseStoreFailures("not json", "test"), xp::Error);
}

TEST(DICOMwebAnswers, DIMSEAddressesAndAETitlesAreChecked)
{
  const xp::ArchiveAccess access;
  const std::unique_ptr<xp::DICOMArchive> opened = xp::OpenArchive("dicom://ORTHANC@127.0.0.1:4242", access, "XPOSE");
  const auto* dimse = dynamic_cast<const xp::DIMSEArchive*>(opened.get());
  ASSERT_NE(dimse, nullptr);
  EXPECT_EQ(dimse->CalledAET(), "ORTHANC");
  EXPECT_EQ(dimse->Host(), "127.0.0.1");
  EXPECT_EQ(dimse->Port(), 4242);
  EXPECT_NE(dynamic_cast<const xp::DICOMwebArchive*>(xp::OpenArchive("https://pacs/dicom-web", access, "XPOSE").get()), nullptr);
  for (const std::string& bad : { "dicom://127.0.0.1:4242", "dicom://ORTHANC@127.0.0.1", "dicom://ORTHANC@:4242",
         "dicom://ORTHANC@host:0", "dicom://A_TITLE_LONGER_THAN_16@host:104", "dicom://BACK\\SLASH@host:104" })
    EXPECT_NE(InputErrorOf([&] { xp::DIMSEArchive(bad, "XPOSE", access); }).find("--pacs"), std::string::npos) << bad;
  EXPECT_NE(InputErrorOf([&] { xp::DIMSEArchive("dicom://ORTHANC@host:104", "", access); }).find("--aet"), std::string::npos);
  // Credentials mean nothing to DIMSE: refused rather than ignored.
  xp::ArchiveAccess withPassword;
  withPassword.credentials.kind = xp::ArchiveCredentials::Kind::Basic;
  EXPECT_THROW(xp::DIMSEArchive("dicom://ORTHANC@host:104", "XPOSE", withPassword), xp::InputError);
}
