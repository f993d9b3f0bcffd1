// Fuzz target: a MetaImage CT (.mha, header and data in one file).
#include "xpFuzzInput.h"
#include "xpVolumeIO.h"

#include <vtkImageData.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string path = xp::fuzz::WriteFile("ct.mha", data, size);
  return xp::fuzz::Expect([&] { xp::ReadCTVolume(path); });
}
