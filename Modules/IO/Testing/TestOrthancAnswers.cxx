// What an archive answers is input too: a fake server answers with a path for an identifier,
// with a cut-short body and with an error status; each is refused, and nothing is written.
#include "xpError.h"
#include "xpOrthanc.h"
#include "xpTestFolders.h"

#include <arpa/inet.h>
#include <filesystem>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <thread>
#include <unistd.h>

namespace
{

/** Answers each of `answers` to one connection, in order, on a free loopback port. */
class FakeArchive
{
public:
  explicit FakeArchive(std::vector<std::string> answers)
  {
    this->Listener = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in address{};
    address.sin_family = AF_INET;
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    bind(this->Listener, reinterpret_cast<sockaddr*>(&address), sizeof(address));
    socklen_t length = sizeof(address);
    getsockname(this->Listener, reinterpret_cast<sockaddr*>(&address), &length);
    this->Port = ntohs(address.sin_port);
    listen(this->Listener, 4);
    this->Server = std::thread([this, answers] {
      for (const std::string& answer : answers)
      {
        const int connection = accept(this->Listener, nullptr, nullptr);
        if (connection < 0)
          return;
        char request[65536];
        recv(connection, request, sizeof(request), 0); // the request fits one read here
        send(connection, answer.data(), answer.size(), MSG_NOSIGNAL);
        close(connection);
      }
    });
  }
  ~FakeArchive()
  {
    shutdown(this->Listener, SHUT_RDWR);
    close(this->Listener);
    this->Server.join();
  }
  std::string Url() const { return "http://127.0.0.1:" + std::to_string(this->Port); }

private:
  int Listener = -1;
  int Port = 0;
  std::thread Server;
};

std::string Http(int status, const std::string& body, size_t declaredLength)
{
  return "HTTP/1.1 " + std::to_string(status) + " X\r\nContent-Type: application/json\r\nContent-Length: " +
    std::to_string(declaredLength) + "\r\n\r\n" + body;
}

/** The message of the xp::Error `f` throws; empty when it throws none. */
template <typename F>
std::string ErrorOf(F f)
{
  try
  {
    f();
  }
  catch (const xp::Error& e)
  {
    return e.what();
  }
  return "";
}

} // namespace

TEST(OrthancAnswers, PathsForIdentifiersCutBodiesAndErrorsAreRefused)
{
  const std::string dir = xp::testing::FreshFolder("fake-archive");
  {
    const std::string evil = "[\"../../escaped\"]";
    FakeArchive archive({ Http(200, evil, evil.size()) });
    EXPECT_NE(ErrorOf([&] { xp::OrthancArchive(archive.Url()).FetchSeries("1.2.3", dir); }).find("identifier"), std::string::npos);
  }
  {
    const std::string body = "[\"0a1b-2c3d\"]";
    FakeArchive archive({ Http(200, body, body.size() + 10) });
    EXPECT_NE(ErrorOf([&] { xp::OrthancArchive(archive.Url()).FetchSeries("1.2.3", dir); }).find("cut short"), std::string::npos);
  }
  {
    const std::string found = "[\"0a1b-2c3d\"]", missing = "not found";
    FakeArchive archive({ Http(200, found, found.size()), Http(404, missing, missing.size()) });
    EXPECT_NE(ErrorOf([&] { xp::OrthancArchive(archive.Url()).FetchSeries("1.2.3", dir); }).find("answered 404"), std::string::npos);
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir)) << "nothing is written from a refused answer";
  EXPECT_FALSE(std::filesystem::exists("escaped"));
}
