#include "xpDICOMwebArchive.h"

#include "xpError.h"
#include "xpMultipart.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

namespace xp
{

namespace
{

// DICOM JSON keys (PS3.18 F.2): group and element in upper-case hex.
const char* const StudyInstanceUID = "0020000D";
const char* const SeriesInstanceUID = "0020000E";
const char* const Modality = "00080060";
const char* const SeriesDescription = "0008103E";
const char* const SeriesRelatedInstances = "00201209";
const char* const FailedSOPSequence = "00081198";
const char* const FailureReason = "00081197";
const char* const ReferencedSOPInstanceUID = "00081155";

Json::Value ParseJSON(const std::string& text, const std::string& where)
{
  Json::CharReaderBuilder builder;
  std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value value;
  std::string errors;
  if (!reader->parse(text.data(), text.data() + text.size(), &value, &errors))
    throw Error(where, "the archive answered with something that is not DICOM JSON: " + errors.substr(0, 200));
  return value;
}

/** The first value of `tag` in a DICOM JSON dataset, as text ("" when absent). */
std::string FirstValue(const Json::Value& dataset, const char* tag)
{
  if (!dataset.isObject() || !dataset.isMember(tag))
    return "";
  const Json::Value& values = dataset[tag]["Value"];
  if (!values.isArray() || values.empty())
    return "";
  const Json::Value& first = values[0];
  if (first.isString())
    return first.asString();
  if (first.isIntegral())
    return std::to_string(first.asLargestInt());
  return "";
}

bool IsDICOMFile(const std::string& bytes)
{
  return bytes.size() > 132 && bytes.compare(128, 4, "DICM") == 0;
}

} // namespace

std::vector<ArchivedSeries> ParseSeriesAnswer(const std::string& json, const std::string& where)
{
  const Json::Value answer = ParseJSON(json, where);
  if (!answer.isArray())
    throw Error(where, "the archive's answer is not a list of DICOM JSON datasets");
  std::vector<ArchivedSeries> series;
  for (const Json::Value& dataset : answer)
  {
    if (!dataset.isObject())
      throw Error(where, "the archive's answer is not a list of DICOM JSON datasets");
    ArchivedSeries item;
    item.studyInstanceUID = FirstValue(dataset, StudyInstanceUID);
    item.seriesInstanceUID = FirstValue(dataset, SeriesInstanceUID);
    item.modality = FirstValue(dataset, Modality);
    item.description = FirstValue(dataset, SeriesDescription);
    const std::string count = FirstValue(dataset, SeriesRelatedInstances);
    item.instances = count.empty() ? 0 : std::atoi(count.c_str());
    series.push_back(item);
  }
  return series;
}

std::vector<std::string> ParseStoreFailures(const std::string& json, const std::string& where)
{
  const Json::Value answer = ParseJSON(json, where);
  if (!answer.isObject())
    throw Error(where, "the archive's store answer is not a DICOM JSON dataset");
  std::vector<std::string> failures;
  const Json::Value& failed = answer[FailedSOPSequence]["Value"];
  if (failed.isArray())
    for (const Json::Value& item : failed)
      failures.push_back(FirstValue(item, ReferencedSOPInstanceUID) + " (failure reason " +
        (FirstValue(item, FailureReason).empty() ? "not given" : FirstValue(item, FailureReason)) + ")");
  return failures;
}

DICOMwebArchive::DICOMwebArchive(const std::string& url, ArchiveAccess access)
  : Client(std::move(access))
{
  const size_t scheme = url.find("://");
  const std::string name = scheme == std::string::npos ? "" : url.substr(0, scheme);
  if (name != "http" && name != "https")
    throw InputError("--pacs", "expected a DICOMweb service root http(s)://HOST:PORT/PATH, got '" + url + "'");
  const size_t pathStart = url.find('/', scheme + 3);
  const std::string authority = url.substr(scheme + 3, pathStart == std::string::npos ? std::string::npos : pathStart - scheme - 3);
  if (authority.find('@') != std::string::npos)
    throw InputError("--pacs", "credentials do not go in the URL, which is printed and logged: use --pacs-credentials FILE "
                               "or XPOSE_PACS_USER and XPOSE_PACS_PASSWORD (or XPOSE_PACS_TOKEN)");
  if (authority.empty())
    throw InputError("--pacs", "no host in '" + url + "'");
  std::string root = pathStart == std::string::npos ? "" : url.substr(pathStart);
  while (!root.empty() && root.back() == '/')
    root.pop_back();
  if (root.empty())
    throw InputError("--pacs", "'" + url + "' names no DICOMweb service root: give its path, for example " + name + "://" +
        authority + "/dicom-web (Orthanc's DICOMweb plugin)");
  if (root.find_first_of("?# ") != std::string::npos)
    throw InputError("--pacs", "the service root '" + url + "' may not hold a query, a fragment or a space");
  this->RootURL = name + "://" + authority + root;
}

std::string DICOMwebArchive::Query(const std::string& path) const
{
  const std::string url = this->RootURL + path;
  const HTTPResponse response = this->Client.Get(url, "application/dicom+json");
  // No match: an empty list, 204 No Content, or (for a study's series) 404.
  if (response.status == 204 || response.status == 404)
    return "[]";
  if (response.status != 200)
    throw Error("GET " + url, "the archive answered HTTP " + std::to_string(response.status));
  return response.body;
}

void DICOMwebArchive::CheckReachable() const
{
  const std::string url = this->RootURL + "/studies?limit=1";
  const HTTPResponse response = this->Client.Get(url, "application/dicom+json");
  if (response.status == 204)
    return;
  if (response.status != 200)
    throw InputError("--pacs", "GET " + url + ": no DICOMweb service there (HTTP " + std::to_string(response.status) + ")");
  try
  {
    ParseSeriesAnswer(response.body, url);
  }
  catch (const Error&)
  {
    throw InputError("--pacs", "GET " + url + ": answers, but not as a DICOMweb service (no DICOM JSON list)");
  }
}

std::vector<ArchivedSeries> DICOMwebArchive::SeriesOfStudy(const std::string& studyUID) const
{
  const std::string path = "/studies/" + CheckedUID(studyUID, "--study") + "/series?includefield=" + SeriesDescription +
    "&includefield=" + SeriesRelatedInstances;
  std::vector<ArchivedSeries> series = ParseSeriesAnswer(this->Query(path), this->RootURL + path);
  if (series.empty())
    throw InputError("--study", "the archive at " + this->RootURL + " holds no study " + studyUID);
  for (ArchivedSeries& item : series)
  {
    CheckedUID(item.seriesInstanceUID, this->RootURL + path + ": a series UID");
    item.studyInstanceUID = studyUID;
  }
  return series;
}

std::vector<std::string> DICOMwebArchive::Retrieve(const std::string& path) const
{
  const std::string url = this->RootURL + path;
  const HTTPResponse response = this->Client.Get(url, "multipart/related; type=\"application/dicom\"");
  if (response.status == 404)
    throw InputError("--pacs", "GET " + url + ": the archive holds no such instances (HTTP 404)");
  if (response.status != 200)
    throw Error("GET " + url, "the archive answered HTTP " + std::to_string(response.status));
  if (response.contentType.compare(0, 18, "multipart/related;") != 0 && response.contentType.compare(0, 19, "multipart/related ;") != 0)
    throw Error("GET " + url, "the archive answered '" + response.contentType.substr(0, 80) + "', not multipart/related");
  std::vector<std::string> files;
  for (MultipartPart& part : SplitMultipart(response.body, ContentTypeParameter(response.contentType, "boundary"), "GET " + url))
  {
    if (!IsDICOMFile(part.body))
      throw Error("GET " + url, "part " + std::to_string(files.size() + 1) + " of the answer is not a DICOM file");
    files.push_back(std::move(part.body));
  }
  if (files.empty())
    throw Error("GET " + url, "the archive answered with no instance");
  return files;
}

std::vector<std::string> DICOMwebArchive::FetchSeries(const std::string& seriesUID, const std::string& directory) const
{
  const std::string query = "/series?SeriesInstanceUID=" + CheckedUID(seriesUID, "--ct-series") + "&includefield=" + StudyInstanceUID;
  const std::vector<ArchivedSeries> found = ParseSeriesAnswer(this->Query(query), this->RootURL + query);
  if (found.size() != 1)
    throw InputError("--ct-series", "the archive at " + this->RootURL + " holds " + std::to_string(found.size()) + " series " + seriesUID +
        ", expected one");
  const std::string& study = CheckedUID(found.front().studyInstanceUID, this->RootURL + query + ": the study UID");
  std::vector<std::string> files;
  const std::vector<std::string> instances = this->Retrieve("/studies/" + study + "/series/" + seriesUID);
  for (size_t i = 0; i < instances.size(); ++i)
  {
    char name[32];
    std::snprintf(name, sizeof(name), "/%04zu.dcm", i + 1);
    files.push_back(directory + name);
    WriteWholeFile(files.back(), instances[i]);
  }
  return files;
}

void DICOMwebArchive::FetchInstance(const std::string& sopInstanceUID, const std::string& path) const
{
  const std::string query = "/instances?SOPInstanceUID=" + CheckedUID(sopInstanceUID, "--xray-instance") + "&includefield=" +
    StudyInstanceUID + "&includefield=" + SeriesInstanceUID;
  const std::vector<ArchivedSeries> found = ParseSeriesAnswer(this->Query(query), this->RootURL + query);
  if (found.size() != 1)
    throw InputError("--xray-instance", "the archive at " + this->RootURL + " holds " + std::to_string(found.size()) +
        " instances " + sopInstanceUID + ", expected one");
  const std::string where = this->RootURL + query;
  const std::string retrieve = "/studies/" + CheckedUID(found.front().studyInstanceUID, where + ": the study UID") + "/series/" +
    CheckedUID(found.front().seriesInstanceUID, where + ": the series UID") + "/instances/" + sopInstanceUID;
  const std::vector<std::string> files = this->Retrieve(retrieve);
  if (files.size() != 1)
    throw Error("GET " + this->RootURL + retrieve, "the archive answered " + std::to_string(files.size()) + " instances, expected one");
  WriteWholeFile(path, files.front());
}

void DICOMwebArchive::Store(const std::vector<std::string>& files) const
{
  const std::string url = this->RootURL + "/studies";
  for (size_t f = 0; f < files.size(); ++f)
  {
    std::string failure;
    try
    {
      const std::string boundary = NewBoundary();
      const HTTPResponse response = this->Client.Post(url, JoinMultipart({ ReadWholeFile(files[f]) }, "application/dicom", boundary),
        "multipart/related; type=\"application/dicom\"; boundary=" + boundary, "application/dicom+json");
      if (response.status != 200)
        failure = "the archive answered HTTP " + std::to_string(response.status);
      std::vector<std::string> failures;
      if (!response.body.empty() && response.contentType.find("json") != std::string::npos)
        failures = ParseStoreFailures(response.body, "POST " + url);
      for (const std::string& item : failures)
        failure += (failure.empty() ? "refused " : "; refused ") + item;
    }
    // Refused credentials, an untrusted certificate, no archive at the URL: the user's to fix
    // (exit 2), as when fetching.
    catch (const InputError& e)
    {
      this->ThrowStoreRefused(files, f, e.what(), true);
    }
    catch (const Error& e)
    {
      failure = e.what();
    }
    if (!failure.empty())
      this->ThrowStoreRefused(files, f, failure);
  }
}

} // namespace xp
