#include "xpHTTPClient.h"

#include "xpError.h"

#include <curl/curl.h>

#include <chrono>
#include <memory>
#include <mutex>
#include <thread>

namespace xp
{

namespace
{

struct Received
{
  std::string body;
  bool tooLong = false;
};

size_t Append(char* data, size_t size, size_t count, void* user)
{
  Received& received = *static_cast<Received*>(user);
  const size_t bytes = size * count;
  if (received.body.size() + bytes > HTTPClient::MaxAnswerBytes)
  {
    received.tooLong = true;
    return 0; // aborts the transfer
  }
  received.body.append(data, bytes);
  return bytes;
}

struct EasyDeleter
{
  void operator()(CURL* curl) const { curl_easy_cleanup(curl); }
};
struct ListDeleter
{
  void operator()(curl_slist* list) const { curl_slist_free_all(list); }
};

void InitializeOnce()
{
  static std::once_flag once;
  std::call_once(once, [] { curl_global_init(CURL_GLOBAL_DEFAULT); });
}

/** Worth another try: no connection was made, or (for a GET, which changes nothing) it broke. */
bool Retryable(CURLcode code, bool sendsBody)
{
  if (code == CURLE_COULDNT_CONNECT)
    return true;
  return !sendsBody && (code == CURLE_OPERATION_TIMEDOUT || code == CURLE_GOT_NOTHING || code == CURLE_RECV_ERROR);
}

} // namespace

HTTPClient::HTTPClient(ArchiveAccess access)
  : Access(std::move(access))
{
  InitializeOnce();
}

HTTPResponse HTTPClient::Get(const std::string& url, const std::string& accept) const
{
  return this->Perform("GET", url, nullptr, "", accept);
}

HTTPResponse HTTPClient::Post(
  const std::string& url, const std::string& body, const std::string& contentType, const std::string& accept) const
{
  return this->Perform("POST", url, &body, contentType, accept);
}

HTTPResponse HTTPClient::Perform(const std::string& method, const std::string& url, const std::string* body,
  const std::string& contentType, const std::string& accept) const
{
  const int attempts = std::max(1, this->Access.connectAttempts);
  for (int attempt = 1;; ++attempt)
  {
    const std::unique_ptr<CURL, EasyDeleter> curl(curl_easy_init());
    if (!curl)
      throw Error(url, "libcurl could not start a request");
    CURL* c = curl.get();
    char reason[CURL_ERROR_SIZE] = "";
    Received received;
    curl_easy_setopt(c, CURLOPT_URL, url.c_str());
    curl_easy_setopt(c, CURLOPT_ERRORBUFFER, reason);
    curl_easy_setopt(c, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(c, CURLOPT_PROTOCOLS_STR, "http,https");
    curl_easy_setopt(c, CURLOPT_REDIR_PROTOCOLS_STR, "http,https");
    // A redirect may lead elsewhere: libcurl then keeps the credentials to the first host.
    curl_easy_setopt(c, CURLOPT_FOLLOWLOCATION, 1L);
    curl_easy_setopt(c, CURLOPT_MAXREDIRS, 5L);
    curl_easy_setopt(c, CURLOPT_CONNECTTIMEOUT, 10L);
    curl_easy_setopt(c, CURLOPT_TIMEOUT, this->Access.timeoutSeconds);
    curl_easy_setopt(c, CURLOPT_WRITEFUNCTION, Append);
    curl_easy_setopt(c, CURLOPT_WRITEDATA, &received);
    curl_easy_setopt(c, CURLOPT_SSL_VERIFYPEER, 1L);
    curl_easy_setopt(c, CURLOPT_SSL_VERIFYHOST, 2L);
    if (!this->Access.caFile.empty())
      curl_easy_setopt(c, CURLOPT_CAINFO, this->Access.caFile.c_str());
    const ArchiveCredentials& credentials = this->Access.credentials;
    if (credentials.kind == ArchiveCredentials::Kind::Basic)
    {
      curl_easy_setopt(c, CURLOPT_HTTPAUTH, static_cast<long>(CURLAUTH_BASIC));
      curl_easy_setopt(c, CURLOPT_USERNAME, credentials.user.c_str());
      curl_easy_setopt(c, CURLOPT_PASSWORD, credentials.secret.c_str());
    }
    else if (credentials.kind == ArchiveCredentials::Kind::Bearer)
    {
      curl_easy_setopt(c, CURLOPT_HTTPAUTH, static_cast<long>(CURLAUTH_BEARER));
      curl_easy_setopt(c, CURLOPT_XOAUTH2_BEARER, credentials.secret.c_str());
    }
    curl_slist* list = nullptr;
    if (!accept.empty())
      list = curl_slist_append(list, ("Accept: " + accept).c_str());
    if (body)
    {
      list = curl_slist_append(list, ("Content-Type: " + contentType).c_str());
      curl_easy_setopt(c, CURLOPT_POST, 1L);
      curl_easy_setopt(c, CURLOPT_POSTFIELDS, body->data());
      curl_easy_setopt(c, CURLOPT_POSTFIELDSIZE_LARGE, static_cast<curl_off_t>(body->size()));
    }
    const std::unique_ptr<curl_slist, ListDeleter> headers(list);
    curl_easy_setopt(c, CURLOPT_HTTPHEADER, list);

    const CURLcode code = curl_easy_perform(c);
    if (code == CURLE_OK)
    {
      HTTPResponse response;
      curl_easy_getinfo(c, CURLINFO_RESPONSE_CODE, &response.status);
      const char* type = nullptr;
      curl_easy_getinfo(c, CURLINFO_CONTENT_TYPE, &type);
      response.contentType = type ? type : "";
      response.body = std::move(received.body);
      if (response.status == 401 || response.status == 403)
        throw InputError("--pacs-credentials", method + " " + url + ": the archive refused " +
            (credentials.kind == ArchiveCredentials::Kind::None ? "access without credentials" : "the credentials") +
            " (HTTP " + std::to_string(response.status) + ")");
      return response;
    }
    const std::string why = std::string(curl_easy_strerror(code)) + (reason[0] ? std::string(": ") + reason : "");
    if (received.tooLong)
      throw Error(url, "the archive's answer exceeds " + std::to_string(MaxAnswerBytes >> 20) + " MiB");
    if (code == CURLE_PEER_FAILED_VERIFICATION || code == CURLE_SSL_CACERT_BADFILE || code == CURLE_SSL_CONNECT_ERROR)
      throw InputError("--ca-file", url + ": the archive's certificate is not trusted or TLS failed (" + why +
          "); give its certificate authority with --ca-file PEM");
    if (code == CURLE_COULDNT_RESOLVE_HOST || code == CURLE_URL_MALFORMAT || code == CURLE_UNSUPPORTED_PROTOCOL)
      throw InputError("--pacs", url + ": " + why);
    // A POST whose connection was made may have been taken: only a failed connection is retried.
    if (attempt >= attempts || !Retryable(code, body != nullptr))
    {
      const std::string tries = attempt > 1 ? ", " + std::to_string(attempt) + " tries" : "";
      if (code == CURLE_COULDNT_CONNECT)
        throw InputError("--pacs", url + ": no archive answers there (" + why + tries + ")");
      throw Error(method + " " + url, "the request failed (" + why + tries + ")");
    }
    std::this_thread::sleep_for(std::chrono::seconds(attempt));
  }
}

} // namespace xp
