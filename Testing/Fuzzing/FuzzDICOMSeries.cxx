// Fuzz target: a CT series of two DICOM files (the input holds both, split at "XPSLICE\n"),
// scanned and read as xpose reads a CT folder.
#include "xpDICOMSeries.h"
#include "xpFuzzInput.h"

#include <cstring>
#include <sys/stat.h>
#include <unistd.h>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  static const char marker[] = "XPSLICE\n";
  const uint8_t* split = static_cast<const uint8_t*>(memmem(data, size, marker, 8));
  const size_t first = split ? static_cast<size_t>(split - data) : size;
  static const std::string folder = [] {
    const std::string path = xp::fuzz::Folder() + "/series";
    mkdir(path.c_str(), 0700);
    return path;
  }();
  unlink((folder + "/b.dcm").c_str());
  xp::fuzz::WriteFile("series/a.dcm", data, first);
  if (split)
    xp::fuzz::WriteFile("series/b.dcm", split + 8, size - first - 8);
  return xp::fuzz::Expect([&] {
    const xp::CTSeriesInfo info = xp::ScanCTSeries(folder);
    std::vector<float> hounsfield(static_cast<size_t>(info.columns) * info.rows * info.files.size());
    xp::ReadCTSeriesVoxels(info, hounsfield.data());
  });
}
