// Credentials come from a private file or the environment; a file others can read, a malformed
// one, half a pair in the environment and a CA file without a certificate are refused, and no
// error repeats the secret.
#include "xpArchiveAccess.h"
#include "xpError.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <sys/stat.h>

namespace
{

std::string WriteFile(const std::string& name, const std::string& text, mode_t mode)
{
  const std::string path = "archive-access-" + name;
  std::filesystem::remove(path);
  std::ofstream(path) << text;
  chmod(path.c_str(), mode);
  return path;
}

std::string ErrorOf(const std::function<void()>& action)
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

void ClearCredentialVariables()
{
  for (const char* name : { "XPOSE_PACS_USER", "XPOSE_PACS_PASSWORD", "XPOSE_PACS_TOKEN" })
    unsetenv(name);
}

/** The credential variables unset for the test's length. */
struct CleanEnvironment
{
  CleanEnvironment() { ClearCredentialVariables(); }
  ~CleanEnvironment() { ClearCredentialVariables(); }
};

} // namespace

TEST(ArchiveAccess, ACredentialsFileIsPrivateAndHoldsOneLine)
{
  CleanEnvironment clean;
  const xp::ArchiveCredentials basic = xp::ReadCredentialsFile(WriteFile("basic", "radiology:pa:ss\n", 0600));
  EXPECT_EQ(basic.kind, xp::ArchiveCredentials::Kind::Basic);
  EXPECT_EQ(basic.user, "radiology");
  EXPECT_EQ(basic.secret, "pa:ss"); // a password may hold ':'
  const xp::ArchiveCredentials token = xp::ReadCredentialsFile(WriteFile("token", "token:abc.def", 0400));
  EXPECT_EQ(token.kind, xp::ArchiveCredentials::Kind::Bearer);
  EXPECT_EQ(token.secret, "abc.def");

  const std::string open = WriteFile("open", "radiology:secret-word", 0644);
  const std::string message = ErrorOf([&] { xp::ReadCredentialsFile(open); });
  EXPECT_NE(message.find(open), std::string::npos) << message;
  EXPECT_NE(message.find("0644"), std::string::npos) << message;
  EXPECT_EQ(message.find("secret-word"), std::string::npos) << message;
  EXPECT_THROW(xp::ReadCredentialsFile(WriteFile("group", "a:b", 0640)), xp::InputError);
  EXPECT_THROW(xp::ReadCredentialsFile(WriteFile("noline", "no colon", 0600)), xp::InputError);
  EXPECT_THROW(xp::ReadCredentialsFile(WriteFile("twolines", "a:b\nc:d\n", 0600)), xp::InputError);
  EXPECT_THROW(xp::ReadCredentialsFile(WriteFile("nouser", ":secret", 0600)), xp::InputError);
  EXPECT_THROW(xp::ReadCredentialsFile("archive-access-no-such-file"), xp::InputError);
}

TEST(ArchiveAccess, TheEnvironmentGivesATokenOrAWholePair)
{
  CleanEnvironment clean;
  EXPECT_EQ(xp::CredentialsFromEnvironment().kind, xp::ArchiveCredentials::Kind::None);
  setenv("XPOSE_PACS_USER", "radiology", 1);
  const std::string message = ErrorOf([] { xp::CredentialsFromEnvironment(); });
  EXPECT_NE(message.find("XPOSE_PACS_PASSWORD"), std::string::npos) << message;
  setenv("XPOSE_PACS_PASSWORD", "secret-word", 1);
  xp::ArchiveCredentials pair = xp::CredentialsFromEnvironment();
  EXPECT_EQ(pair.kind, xp::ArchiveCredentials::Kind::Basic);
  EXPECT_EQ(pair.user, "radiology");
  EXPECT_EQ(pair.secret, "secret-word");
  setenv("XPOSE_PACS_TOKEN", "tok", 1);
  EXPECT_EQ(xp::CredentialsFromEnvironment().kind, xp::ArchiveCredentials::Kind::Bearer);
  // A file given on the command line wins over the environment.
  const xp::ArchiveAccess access = xp::ResolveArchiveAccess(WriteFile("wins", "other:pw", 0600), "");
  EXPECT_EQ(access.credentials.user, "other");
}

TEST(ArchiveAccess, ACAFileMustHoldACertificate)
{
  CleanEnvironment clean;
  const std::string notPEM = WriteFile("ca", "not a certificate", 0644);
  const std::string message = ErrorOf([&] { xp::ResolveArchiveAccess("", notPEM); });
  EXPECT_NE(message.find(notPEM), std::string::npos) << message;
  EXPECT_THROW(xp::ResolveArchiveAccess("", "archive-access-no-such-ca.pem"), xp::InputError);
  const std::string pem = WriteFile("ca-ok", "-----BEGIN CERTIFICATE-----\nMIIB\n-----END CERTIFICATE-----\n", 0644);
  EXPECT_EQ(xp::ResolveArchiveAccess("", pem).caFile, pem);
}
