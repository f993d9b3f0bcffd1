// Fuzz target: a PNG read as a 12-bit X-ray and as a validity mask.
#include "xpFuzzInput.h"
#include "xpImageIO.h"

#include <vtkImageData.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string path = xp::fuzz::WriteFile("image.png", data, size);
  xp::fuzz::Expect([&] { xp::ReadXRayPNG(path); });
  return xp::fuzz::Expect([&] { xp::ReadMaskPNG(path, 64, 48); });
}
