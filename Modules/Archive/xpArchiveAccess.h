/**
 * @file xpArchiveAccess.h
 * @brief How xpose reaches an archive: as whom (credentials from a private file or the
 *        environment, never from the command line) and trusting which certificates.
 */
#ifndef xpArchiveAccess_h
#define xpArchiveAccess_h

#include "vtkXPArchiveModule.h"

#include <string>

namespace xp
{

struct VTKXPARCHIVE_EXPORT ArchiveCredentials
{
  enum class Kind
  {
    None,
    Basic, ///< HTTP basic: user and password
    Bearer ///< a bearer token
  };
  Kind kind = Kind::None;
  std::string user;
  std::string secret; ///< the password or the token: never printed, logged or written
};

struct VTKXPARCHIVE_EXPORT ArchiveAccess
{
  ArchiveCredentials credentials;
  /** PEM file of the certificate authorities to trust; empty: the system's CA store. */
  std::string caFile;
  /** The longest one request may take, connection included. */
  long timeoutSeconds = 120;
  /** Tries of a request whose connection failed (the archive restarting, a dropped link). */
  int connectAttempts = 3;
};

/**
 * One line `user:password` (HTTP basic) or `token:VALUE` (bearer). Throws xp::InputError naming
 * the file when it cannot be read, is malformed, or can be read by its group or others (a
 * password beside the data must be as private as a key).
 */
VTKXPARCHIVE_EXPORT ArchiveCredentials ReadCredentialsFile(const std::string& path);

/** XPOSE_PACS_TOKEN, or XPOSE_PACS_USER with XPOSE_PACS_PASSWORD; Kind::None when unset.
 *  Throws xp::InputError when only one of user and password is set. */
VTKXPARCHIVE_EXPORT ArchiveCredentials CredentialsFromEnvironment();

/** The credentials of `credentialsFile` when given, otherwise the environment's, and the CA file
 *  (checked readable). Throws xp::InputError naming the option at fault. */
VTKXPARCHIVE_EXPORT ArchiveAccess ResolveArchiveAccess(const std::string& credentialsFile, const std::string& caFile);

} // namespace xp

#endif
