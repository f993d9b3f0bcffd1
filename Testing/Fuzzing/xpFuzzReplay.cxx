// Runs a fuzz target over files and folders of inputs without libFuzzer: the regression corpus
// in ctest, with any compiler. Exits non-zero only by crashing, as the fuzzer would report.
#include <cstdint>
#include <cstdio>
#include <dirent.h>
#include <fstream>
#include <iterator>
#include <string>
#include <sys/stat.h>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace
{
int Replay(const std::string& path)
{
  struct stat status;
  if (stat(path.c_str(), &status) != 0)
  {
    std::fprintf(stderr, "%s: not found\n", path.c_str());
    return 1;
  }
  if (S_ISDIR(status.st_mode))
  {
    int count = 0;
    DIR* folder = opendir(path.c_str());
    while (dirent* entry = readdir(folder))
    {
      if (entry->d_name[0] != '.')
        count += Replay(path + "/" + entry->d_name);
    }
    closedir(folder);
    return count;
  }
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  return 1;
}
} // namespace

int main(int argc, char** argv)
{
  int count = 0;
  for (int i = 1; i < argc; ++i)
    count += Replay(argv[i]);
  std::printf("replayed %d inputs without a crash\n", count);
  return count > 0 ? 0 : 1;
}
