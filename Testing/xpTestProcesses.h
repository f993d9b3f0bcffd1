/**
 * @file xpTestProcesses.h
 * @brief Servers and tools the tests start beside themselves (Orthanc, nginx, xpose listen,
 *        dcmtk's storescp): started with their output in a log, waited for, stopped.
 */
#ifndef xpTestProcesses_h
#define xpTestProcesses_h

#include <chrono>
#include <csignal>
#include <cstdio>
#include <functional>
#include <string>
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
