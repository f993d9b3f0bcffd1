// Shared by the fuzz targets: the input as a file in a private temporary folder, and the rule
// that a reader may refuse input only with xp::Error (anything else is a defect).
#ifndef xpFuzzInput_h
#define xpFuzzInput_h

#include "xpError.h"

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <unistd.h>

namespace xp::fuzz
{

/** A folder of this process's own, removed at exit. */
inline const std::string& Folder()
{
  static const std::string folder = []
  {
    const char* shm = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    std::string pattern = std::string(shm) + "/xpose-fuzz-XXXXXX";
    if (!mkdtemp(pattern.data()))
      std::abort();
    static const std::string removeCommand = "rm -rf '" + pattern + "'";
    std::atexit([] { (void)!std::system(removeCommand.c_str()); });
    return pattern;
  }();
  return folder;
}

inline std::string WriteFile(const std::string& name, const uint8_t* data, size_t size)
{
  const std::string path = Folder() + "/" + name;
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), size);
  return path;
}

/** Runs `read`; refusing the input with xp::Error is the expected outcome of bad bytes. */
template <typename Read>
int Expect(Read&& read)
{
  try
  {
    read();
  }
  catch (const xp::Error&)
  {
  }
  return 0;
}

} // namespace xp::fuzz

#endif
