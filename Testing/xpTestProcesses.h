/**
 * @file xpTestProcesses.h
 * @brief Servers and tools the tests start beside themselves (Orthanc, nginx, xpose listen,
 *        dcmtk's storescp): started with their output in a log, waited for, stopped.
 */
#ifndef xpTestProcesses_h
#define xpTestProcesses_h

#include <arpa/inet.h>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <netinet/in.h>
#include <string>
#include <sys/socket.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace xp
{
namespace test
{

/** Starts `command` (found on PATH) with stdout and stderr to `log`; returns its process id. */
inline pid_t StartProcess(const std::string& log, const std::vector<std::string>& command)
{
  // What the test printed so far would otherwise be printed again by the child.
  std::fflush(stdout);
  std::fflush(stderr);
  const pid_t child = fork();
  if (child == 0)
  {
    std::freopen(log.c_str(), "w", stdout);
    std::freopen(log.c_str(), "a", stderr);
    std::vector<char*> argv;
    for (const std::string& word : command)
      argv.push_back(const_cast<char*>(word.c_str()));
    argv.push_back(nullptr);
    execvp(argv[0], argv.data());
    _exit(127);
  }
  return child;
}

/** SIGTERM, then waits for it; `child` becomes 0. */
inline void StopProcess(pid_t& child)
{
  if (child > 0)
  {
    kill(child, SIGTERM);
    waitpid(child, nullptr, 0);
  }
  child = 0;
}

/** Waits up to `seconds` for `done`, looking every 0.2 s; true when it came. */
inline bool WaitFor(const std::function<bool()>& done, double seconds)
{
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end)
  {
    if (done())
      return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  return done();
}

/** True when a TCP server could listen on 127.0.0.1:`port` now. */
inline bool LoopbackPortFree(int port)
{
  const int probe = socket(AF_INET, SOCK_STREAM, 0);
  if (probe < 0)
    return false;
  int reuse = 1; // as servers set it: a port left in TIME_WAIT is free to them
  setsockopt(probe, SOL_SOCKET, SO_REUSEADDR, &reuse, sizeof(reuse));
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const bool free = bind(probe, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  close(probe);
  return free;
}

/** The first of `count` consecutive loopback ports that are free now, for the servers of one
 *  test process. Below Linux's ephemeral range (32768 up), where outgoing connections of the
 *  tests beside it would otherwise take a server's port between this check and its start; the
 *  search starts at a place of its own per process id and `salt` (a retry's number). */
inline int FreeLoopbackPorts(int count, int salt = 0)
{
  const int first = 20000, blocks = (32768 - first) / 16;
  for (int tried = 0; tried < blocks; ++tried)
  {
    const int base = first + static_cast<int>((getpid() + 7 * salt + tried) % blocks) * 16;
    bool free = true;
    for (int port = base; port < base + count && free; ++port)
      free = LoopbackPortFree(port);
    if (free)
      return base;
  }
  return first;
}

/** True while `child` (a process this one started) runs; false once it has ended. */
inline bool StillRunning(pid_t child)
{
  return child > 0 && waitpid(child, nullptr, WNOHANG) == 0;
}

/** A process started for one test and stopped when the test ends, however it ends. */
class RunningProcess
{
public:
  RunningProcess(const std::string& log, const std::vector<std::string>& command)
    : Id(StartProcess(log, command))
  {
  }
  ~RunningProcess() { StopProcess(this->Id); }
  RunningProcess(const RunningProcess&) = delete;
  RunningProcess& operator=(const RunningProcess&) = delete;

  /** SIGTERM and up to `seconds` for it to end: its exit code, or -1 (killed when it did not end). */
  int Terminate(double seconds)
  {
    kill(this->Id, SIGTERM);
    int status = 0;
    const bool ended = WaitFor([&] { return waitpid(this->Id, &status, WNOHANG) == this->Id; }, seconds);
    if (!ended)
    {
      kill(this->Id, SIGKILL);
      waitpid(this->Id, nullptr, 0);
    }
    this->Id = 0;
    return ended && WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

private:
  pid_t Id;
};

} // namespace test
} // namespace xp

#endif
