// The CUDA ray caster's face in a build without a CUDA compiler: nothing runs on a GPU, and every
// call says why. xpCudaRayCaster.cu replaces this file where CMake finds nvcc.
#include "xpCudaRayCaster.h"

#include "xpError.h"

namespace xp
{
namespace cuda
{

namespace
{
const char* const NotBuilt = "this xpose was built without CUDA (no CUDA compiler was found when it was configured)";
}

bool Available(std::string* reason)
{
  if (reason)
    *reason = NotBuilt;
  return false;
}

struct GPUContext::Resident
{
};

GPUContext::GPUContext()
{
  throw Error("CUDA", NotBuilt);
}

GPUContext::~GPUContext() = default;

std::string GPUContext::DeviceName() const
{
  throw Error("CUDA", NotBuilt);
}

int GPUContext::AddVolume(const uint16_t*, const joseph::Grid&)
{
  throw Error("CUDA", NotBuilt);
}

int GPUContext::AddPixels(const int*, int)
{
  throw Error("CUDA", NotBuilt);
}

void GPUContext::Remove(int) {}

long long GPUContext::Render(int, const joseph::Job*, const int*, int, float* const*, Interpolation)
{
  throw Error("CUDA", NotBuilt);
}

int GPUContext::AddMetricView(int, const uint8_t*, int, double, double, const std::vector<uint8_t>&)
{
  throw Error("CUDA", NotBuilt);
}

long long GPUContext::MutualInformation(int, const joseph::Job*, const int*, int, double*, Interpolation)
{
  throw Error("CUDA", NotBuilt);
}

} // namespace cuda
} // namespace xp
