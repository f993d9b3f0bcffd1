#include "xpOrthanc.h"

#include "xpError.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <netdb.h>
#include <sstream>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

namespace xp
{

namespace
{

constexpr int TimeoutSeconds = 30;
// One answer is one DICOM file or one listing: far beyond any CT slice or X-ray.
constexpr size_t MaxAnswerBytes = size_t(1) << 30;

/** Orthanc identifiers are hexadecimal groups joined by '-': anything else is refused, as the
 *  fetched files are named after them (no path may come from the archive). */
const std::string& CheckedID(const std::string& id, const std::string& url)
{
  if (id.empty() || id.size() > 64 || id.find_first_not_of("0123456789abcdef-") != std::string::npos)
    throw Error(url, "the archive answered with an identifier that is not Orthanc's: '" + id.substr(0, 64) + "'");
  return id;
}

struct SocketCloser
{
  void operator()(int* socket) const
  {
    close(*socket);
    delete socket;
  }
};

Json::Value ParseJSON(const std::string& text, const std::string& what)
{
  Json::CharReaderBuilder builder;
  std::unique_ptr<Json::CharReader> reader(builder.newCharReader());
  Json::Value value;
  std::string errors;
  if (!reader->parse(text.data(), text.data() + text.size(), &value, &errors))
    throw Error(what, "the archive answered with something that is not JSON: " + errors);
  return value;
}

} // namespace

OrthancArchive::OrthancArchive(const std::string& url)
  : Url(url)
{
  const std::string prefix = "http://";
  if (url.compare(0, prefix.size(), prefix) != 0)
    throw InputError("--pacs", "expected http://HOST:PORT, got '" + url + "' (https is not supported)");
  std::string rest = url.substr(prefix.size());
  while (!rest.empty() && rest.back() == '/')
    rest.pop_back();
  const size_t colon = rest.rfind(':');
  this->Host = colon == std::string::npos ? rest : rest.substr(0, colon);
  const std::string port = colon == std::string::npos ? "80" : rest.substr(colon + 1);
  char* end = nullptr;
  const long number = std::strtol(port.c_str(), &end, 10);
  if (this->Host.empty() || rest.find('/') != std::string::npos || *end != '\0' || number < 1 || number > 65535)
    throw InputError("--pacs", "expected http://HOST:PORT, got '" + url + "'");
  this->Port = static_cast<int>(number);
}

OrthancArchive::Response OrthancArchive::Request(
  const std::string& method, const std::string& path, const std::string& body, const std::string& contentType) const
{
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* addresses = nullptr;
  if (getaddrinfo(this->Host.c_str(), std::to_string(this->Port).c_str(), &hints, &addresses) != 0 || !addresses)
    throw InputError("--pacs", this->Url + ": cannot resolve host '" + this->Host + "'");
  int descriptor = -1;
  for (addrinfo* a = addresses; a && descriptor < 0; a = a->ai_next)
  {
    descriptor = socket(a->ai_family, a->ai_socktype, a->ai_protocol);
    if (descriptor < 0)
      continue;
    timeval timeout{ TimeoutSeconds, 0 };
    setsockopt(descriptor, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    setsockopt(descriptor, SOL_SOCKET, SO_SNDTIMEO, &timeout, sizeof(timeout));
    if (connect(descriptor, a->ai_addr, a->ai_addrlen) != 0)
    {
      close(descriptor);
      descriptor = -1;
    }
  }
  freeaddrinfo(addresses);
  if (descriptor < 0)
    throw InputError("--pacs", this->Url + ": no archive answers there (" + std::strerror(errno) + ")");
  const std::unique_ptr<int, SocketCloser> connection(new int(descriptor));

  std::string request = method + " " + path + " HTTP/1.1\r\nHost: " + this->Host + "\r\nConnection: close\r\n";
  if (!body.empty() || method == "POST")
    request += "Content-Type: " + contentType + "\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
  request += "\r\n" + body;
  for (size_t sent = 0; sent < request.size();)
  {
    const ssize_t n = send(descriptor, request.data() + sent, request.size() - sent, MSG_NOSIGNAL);
    if (n <= 0)
      throw Error(this->Url + path, std::string("the archive closed the connection while xpose sent (") + std::strerror(errno) + ")");
    sent += static_cast<size_t>(n);
  }
  std::string answer;
  char buffer[65536];
  for (;;)
  {
    const ssize_t n = recv(descriptor, buffer, sizeof(buffer), 0);
    if (n < 0)
      throw Error(this->Url + path, std::string("no complete answer from the archive (") + std::strerror(errno) + ")");
    if (n == 0)
      break;
    answer.append(buffer, static_cast<size_t>(n));
    if (answer.size() > MaxAnswerBytes)
      throw Error(this->Url + path, "the archive's answer exceeds " + std::to_string(MaxAnswerBytes >> 20) + " MiB");
  }
  const size_t headerEnd = answer.find("\r\n\r\n");
  int status = 0;
  if (headerEnd == std::string::npos || std::sscanf(answer.c_str(), "HTTP/%*d.%*d %d", &status) != 1)
    throw Error(this->Url + path, "the archive's answer is not HTTP");
  Response response;
  response.status = status;
  const std::string headers = answer.substr(0, headerEnd);
  response.body = answer.substr(headerEnd + 4);
  std::string lower = headers;
  for (char& c : lower)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const size_t length = lower.find("\r\ncontent-length:");
  if (lower.find("transfer-encoding: chunked") != std::string::npos)
  {
    std::string decoded;
    size_t at = 0;
    for (;;)
    {
      const size_t lineEnd = response.body.find("\r\n", at);
      if (lineEnd == std::string::npos)
        throw Error(this->Url + path, "the archive's chunked answer is cut short");
      const size_t size = std::strtoul(response.body.substr(at, lineEnd - at).c_str(), nullptr, 16);
      if (size == 0)
        break;
      if (lineEnd + 2 + size > response.body.size())
        throw Error(this->Url + path, "the archive's chunked answer is cut short");
      decoded.append(response.body, lineEnd + 2, size);
      at = lineEnd + 2 + size + 2;
    }
    response.body = decoded;
  }
  else if (length != std::string::npos && std::strtoul(lower.c_str() + length + 17, nullptr, 10) != response.body.size())
  {
    throw Error(this->Url + path, "the archive's answer is cut short (Content-Length)");
  }
  return response;
}

std::string OrthancArchive::Get(const std::string& path) const
{
  const Response response = this->Request("GET", path);
  if (response.status != 200)
    throw Error(this->Url + path, "the archive answered " + std::to_string(response.status));
  return response.body;
}

void OrthancArchive::CheckReachable() const
{
  const Response response = this->Request("GET", "/system");
  if (response.status != 200 || !ParseJSON(response.body, this->Url).isMember("Version"))
    throw InputError("--pacs", this->Url + " answers, but not as an Orthanc archive (GET /system: " +
        std::to_string(response.status) + ")");
}

std::vector<std::string> OrthancArchive::Find(const std::string& level, const std::string& tag, const std::string& value) const
{
  Json::Value query;
  query["Level"] = level;
  query["Query"][tag] = value;
  const Response response = this->Request("POST", "/tools/find", Json::writeString(Json::StreamWriterBuilder(), query));
  if (response.status != 200)
    throw Error(this->Url + "/tools/find", "the archive refused the query (" + std::to_string(response.status) + ")");
  std::vector<std::string> ids;
  for (const Json::Value& id : ParseJSON(response.body, this->Url))
    ids.push_back(CheckedID(id.asString(), this->Url));
  return ids;
}

std::vector<ArchivedSeries> OrthancArchive::SeriesOfStudy(const std::string& studyUID) const
{
  const std::vector<std::string> studies = this->Find("Study", "StudyInstanceUID", studyUID);
  if (studies.empty())
    throw InputError("--study", "the archive at " + this->Url + " holds no study " + studyUID);
  std::vector<ArchivedSeries> series;
  for (const std::string& study : studies)
  {
    for (const Json::Value& s : ParseJSON(this->Get("/studies/" + study + "/series"), this->Url))
    {
      ArchivedSeries item;
      item.seriesInstanceUID = s["MainDicomTags"]["SeriesInstanceUID"].asString();
      item.modality = s["MainDicomTags"]["Modality"].asString();
      item.description = s["MainDicomTags"]["SeriesDescription"].asString();
      item.instances = static_cast<int>(s["Instances"].size());
      series.push_back(item);
    }
  }
  return series;
}

std::string OrthancArchive::CTSeriesOfStudy(const std::string& studyUID) const
{
  const std::vector<ArchivedSeries> series = this->SeriesOfStudy(studyUID);
  std::vector<const ArchivedSeries*> cts;
  std::string found;
  for (const ArchivedSeries& s : series)
  {
    found += "\n  " + s.modality + " " + s.seriesInstanceUID + " (" + std::to_string(s.instances) + " images" +
      (s.description.empty() ? "" : ", " + s.description) + ")";
    if (s.modality == "CT")
      cts.push_back(&s);
  }
  if (cts.size() != 1)
    throw InputError("--study", "study " + studyUID + " holds " + (cts.empty() ? "no CT series" : "several CT series") +
        "; choose one with --ct-series. The archive holds:" + found);
  return cts.front()->seriesInstanceUID;
}

std::vector<std::string> OrthancArchive::FetchSeries(const std::string& seriesUID, const std::string& directory) const
{
  const std::vector<std::string> ids = this->Find("Series", "SeriesInstanceUID", seriesUID);
  if (ids.empty())
    throw InputError("--ct-series", "the archive at " + this->Url + " holds no series " + seriesUID);
  std::vector<std::string> files;
  for (const std::string& id : ids)
  {
    const Json::Value instances = ParseJSON(this->Get("/series/" + id + "/instances"), this->Url);
    for (const Json::Value& instance : instances)
    {
      const std::string instanceId = CheckedID(instance["ID"].asString(), this->Url);
      const std::string path = directory + "/" + instanceId + ".dcm";
      std::ofstream out(path, std::ios::binary);
      out << this->Get("/instances/" + instanceId + "/file");
      if (!out)
        throw Error(path, "cannot be written");
      files.push_back(path);
    }
  }
  return files;
}

void OrthancArchive::FetchInstance(const std::string& sopInstanceUID, const std::string& path) const
{
  const std::vector<std::string> ids = this->Find("Instance", "SOPInstanceUID", sopInstanceUID);
  if (ids.size() != 1)
    throw InputError("--xray-instance", "the archive at " + this->Url + " holds " + std::to_string(ids.size()) +
        " instances " + sopInstanceUID + ", expected one");
  const std::string file = this->Get("/instances/" + ids.front() + "/file");
  std::ofstream out(path, std::ios::binary);
  out << file;
  if (!out)
    throw Error(path, "cannot be written");
}

void OrthancArchive::Store(const std::vector<std::string>& files) const
{
  std::vector<std::string> stored; // Orthanc identifiers, to take back on failure
  for (const std::string& file : files)
  {
    Response response;
    std::string failure;
    try
    {
      response = this->Request("POST", "/instances", ReadWholeFile(file), "application/dicom");
      if (response.status != 200)
        failure = "the archive refused it (" + std::to_string(response.status) + ")";
    }
    catch (const Error& e)
    {
      failure = e.what();
    }
    if (failure.empty())
    {
      const Json::Value answer = ParseJSON(response.body, this->Url);
      if (answer.get("Status", "").asString() == "AlreadyStored")
        continue; // stored before this call: not ours to delete
      stored.push_back(CheckedID(answer["ID"].asString(), this->Url));
      continue;
    }
    for (const std::string& id : stored)
    {
      try
      {
        this->Request("DELETE", "/instances/" + id);
      }
      catch (const Error&)
      {
        failure += "; and " + id + " could not be taken back";
      }
    }
    throw Error(file, "not stored in " + this->Url + ": " + failure + "; the files stored before it were taken back");
  }
}

} // namespace xp
