#include "xpArchiveAccess.h"

#include "xpError.h"
#include "xpWholeFile.h"

#include <cstdio>
#include <cstdlib>
#include <sys/stat.h>

namespace xp
{

ArchiveCredentials ReadCredentialsFile(const std::string& path)
{
  struct stat status
  {
  };
  if (stat(path.c_str(), &status) != 0)
    throw InputError(path, "--pacs-credentials: the file cannot be read");
  if ((status.st_mode & 077) != 0)
  {
    char mode[8];
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(status.st_mode & 07777));
    throw InputError(path, std::string("--pacs-credentials: others can read it (mode ") + mode +
        "); make it private with chmod 600");
  }
  std::string text = ReadWholeFile(path);
  while (!text.empty() && (text.back() == '\n' || text.back() == '\r'))
    text.pop_back();
  const size_t colon = text.find(':');
  if (text.find('\n') != std::string::npos || colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw InputError(path, "--pacs-credentials: expected one line, user:password or token:VALUE");
  ArchiveCredentials credentials;
  const std::string name = text.substr(0, colon);
  credentials.kind = name == "token" ? ArchiveCredentials::Kind::Bearer : ArchiveCredentials::Kind::Basic;
  credentials.user = credentials.kind == ArchiveCredentials::Kind::Basic ? name : "";
  credentials.secret = text.substr(colon + 1);
  return credentials;
}

ArchiveCredentials CredentialsFromEnvironment()
{
  ArchiveCredentials credentials;
  const char* token = std::getenv("XPOSE_PACS_TOKEN");
  const char* user = std::getenv("XPOSE_PACS_USER");
  const char* password = std::getenv("XPOSE_PACS_PASSWORD");
  if (token && *token)
  {
    credentials.kind = ArchiveCredentials::Kind::Bearer;
    credentials.secret = token;
    return credentials;
  }
  const bool hasUser = user && *user, hasPassword = password && *password;
  if (hasUser != hasPassword)
    throw InputError(hasUser ? "XPOSE_PACS_PASSWORD" : "XPOSE_PACS_USER",
      std::string("is not set while ") + (hasUser ? "XPOSE_PACS_USER" : "XPOSE_PACS_PASSWORD") + " is: set both or neither");
  if (hasUser)
  {
    credentials.kind = ArchiveCredentials::Kind::Basic;
    credentials.user = user;
    credentials.secret = password;
  }
  return credentials;
}

ArchiveAccess ResolveArchiveAccess(const std::string& credentialsFile, const std::string& caFile)
{
  ArchiveAccess access;
  access.credentials = credentialsFile.empty() ? CredentialsFromEnvironment() : ReadCredentialsFile(credentialsFile);
  if (!caFile.empty())
  {
    if (ReadWholeFile(caFile).find("-----BEGIN CERTIFICATE-----") == std::string::npos)
      throw InputError(caFile, "--ca-file: no PEM certificate in it");
    access.caFile = caFile;
  }
  return access;
}

} // namespace xp
