// Fuzz target: a DICOM DX/CR/RT Image X-ray.
#include "xpDICOMXRay.h"
#include "xpFuzzInput.h"

#include <vtkImageData.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string path = xp::fuzz::WriteFile("xray.dcm", data, size);
  return xp::fuzz::Expect([&] { xp::ReadXRayDICOM(path); });
}
