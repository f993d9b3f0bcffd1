// Fuzz target: the stereo geometry JSON (Coordinates.md).
#include "xpFuzzInput.h"
#include "xpStereoGeometry.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
  const std::string text(reinterpret_cast<const char*>(data), size);
  return xp::fuzz::Expect([&] { xp::ValidateStereoGeometry(xp::ParseStereoGeometry(text, "geometry.json"), "geometry.json"); });
}
