// Fuzz target: a NIfTI-1 CT (.nii; gzip-compressed input is read the same way).
#include "xpFuzzInput.h"
#include "xpVolumeIO.h"

#include <vtkImageData.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string path = xp::fuzz::WriteFile("ct.nii", data, size);
  return xp::fuzz::Expect([&] { xp::ReadCTVolume(path); });
}
