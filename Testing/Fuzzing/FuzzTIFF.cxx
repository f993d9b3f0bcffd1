// Fuzz target: a TIFF read as an X-ray and as a bone volume stack.
#include "xpFuzzInput.h"
#include "xpImageIO.h"
#include "xpVolumeIO.h"

#include <vtkImageData.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string path = xp::fuzz::WriteFile("image.tif", data, size);
  xp::fuzz::Expect([&] { xp::ReadXRayTIFF(path); });
  return xp::fuzz::Expect([&] { xp::ReadCTVolume(path, "", { 0.5, 0.5, 1.0 }); });
}
