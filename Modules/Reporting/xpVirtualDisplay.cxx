#include "xpVirtualDisplay.h"

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

namespace xp
{

bool DisplayAnswers(const std::string& display)
{
  const size_t colon = display.rfind(':');
  if (colon == std::string::npos)
    return false;
  if (colon > 0 && display.compare(0, colon, "unix") != 0)
    return true; // a remote or TCP display: trust it, as X clients do
  const int number = std::atoi(display.c_str() + colon + 1);
  // A local server listens on /tmp/.X11-unix/XN; connecting proves it is alive, not just a stale file.
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0)
    return false;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof(address.sun_path), "/tmp/.X11-unix/X%d", number);
  const bool answers = connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
  close(fd);
  return answers;
}

std::unique_ptr<VirtualDisplay> VirtualDisplay::Ensure(std::string& reason)
{
  std::unique_ptr<VirtualDisplay> result(new VirtualDisplay);
  const char* current = std::getenv("DISPLAY");
  if (current && *current && DisplayAnswers(current))
  {
    result->Display = current;
    return result;
  }
  result->HadDisplay = current != nullptr;
  result->PreviousDisplay = current ? current : "";

  // Xvfb picks a free display number itself and writes it to the pipe (-displayfd).
  int channel[2];
  if (pipe2(channel, O_CLOEXEC) != 0)
  {
    reason = std::string("cannot start Xvfb: ") + std::strerror(errno);
    return nullptr;
  }
  const pid_t pid = fork();
  if (pid < 0)
  {
    reason = std::string("cannot start Xvfb: ") + std::strerror(errno);
    close(channel[0]);
    close(channel[1]);
    return nullptr;
  }
  if (pid == 0)
  {
    dup2(channel[1], 3); // dup2 clears close-on-exec on the copy
    const int null = open("/dev/null", O_WRONLY);
    if (null >= 0)
    {
      dup2(null, STDOUT_FILENO);
      dup2(null, STDERR_FILENO);
    }
    execlp("Xvfb", "Xvfb", "-displayfd", "3", "-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset",
      static_cast<char*>(nullptr));
    _exit(127);
  }
  close(channel[1]);
  std::string number;
  pollfd wait{ channel[0], POLLIN, 0 };
  for (int waited = 0; waited < 100; ++waited) // up to 10 s
  {
    if (poll(&wait, 1, 100) > 0)
    {
      char buffer[16];
      const ssize_t n = read(channel[0], buffer, sizeof(buffer));
      if (n <= 0)
        break;
      number.append(buffer, static_cast<size_t>(n));
      if (number.find('\n') != std::string::npos)
        break;
    }
  }
  close(channel[0]);
  while (!number.empty() && (number.back() == '\n' || number.back() == '\r'))
    number.pop_back();
  result->ServerProcess = pid;
  result->Display = ":" + number;
  if (number.empty() || !DisplayAnswers(result->Display))
  {
    int status = 0;
    const bool exited = waitpid(pid, &status, WNOHANG) == pid;
    reason = exited && WIFEXITED(status) && WEXITSTATUS(status) == 127
      ? "no display and no Xvfb to start (install the xvfb package)"
      : "no display, and the Xvfb started for it did not answer";
    return nullptr; // the destructor stops what was started
  }
  setenv("DISPLAY", result->Display.c_str(), 1);
  return result;
}

VirtualDisplay::~VirtualDisplay()
{
  if (this->ServerProcess <= 0)
    return;
  kill(this->ServerProcess, SIGTERM);
  int status = 0;
  waitpid(this->ServerProcess, &status, 0);
  if (this->HadDisplay)
    setenv("DISPLAY", this->PreviousDisplay.c_str(), 1);
  else
    unsetenv("DISPLAY");
}

} // namespace xp
