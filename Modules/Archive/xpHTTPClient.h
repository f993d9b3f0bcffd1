/**
 * @file xpHTTPClient.h
 * @brief HTTP(S) requests through libcurl: TLS verified against the system's or a given CA,
 *        basic or bearer authentication, time-outs, a bounded retry when the connection fails.
 *
 * Errors name the URL (which never carries credentials) and the HTTP status or libcurl's reason;
 * the credentials themselves appear in no message.
 */
#ifndef xpHTTPClient_h
#define xpHTTPClient_h

#include "vtkXPArchiveModule.h"
#include "xpArchiveAccess.h"

#include <string>

namespace xp
{

struct VTKXPARCHIVE_EXPORT HTTPResponse
{
  long status = 0;
  std::string contentType; ///< the Content-Type header, as sent
  std::string body;
};

class VTKXPARCHIVE_EXPORT HTTPClient
{
public:
  explicit HTTPClient(ArchiveAccess access);

  /** GET `url` asking for `accept`. Throws xp::InputError when the archive cannot be reached,
   *  its certificate is not trusted or it refuses the credentials (401, 403); any other status
   *  is returned. */
  HTTPResponse Get(const std::string& url, const std::string& accept) const;

  /** POST `body` as `contentType`; the same errors. Retried only when nothing was sent. */
  HTTPResponse Post(const std::string& url, const std::string& body, const std::string& contentType,
    const std::string& accept) const;

  /** The longest answer taken (one DICOM series part, one listing). */
  static constexpr size_t MaxAnswerBytes = size_t(2) << 30;

private:
  HTTPResponse Perform(const std::string& method, const std::string& url, const std::string* body,
    const std::string& contentType, const std::string& accept) const;

  ArchiveAccess Access;
};

} // namespace xp

#endif
