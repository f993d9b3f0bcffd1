#include "xpCudaRayCaster.h"

#include "xpError.h"

#include <cuda_runtime.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

namespace xp
{
namespace cuda
{

namespace
{

void Check(cudaError_t status, const char* what)
{
  if (status != cudaSuccess)
  {
    throw Error("CUDA", std::string(what) + ": " + cudaGetErrorString(status));
  }
}

constexpr int RaysPerBlock = 128;
constexpr int MaxBins = 64; // the joint histogram lives in shared memory: 64 x 64 counts, 16 KiB

/** A padded volume as the kernels read it: plain global memory for the float interpolation, and a
 *  texture of the same 16-bit steps for the hardware filter, made the first time it is asked for. */
struct DeviceVolume
{
  joseph::Grid grid{};
  uint16_t* voxels = nullptr;
  cudaArray_t array = nullptr;
  cudaTextureObject_t texture = 0;
};

struct DevicePixels
{
  int* pixels = nullptr;
  int count = 0;
};

struct DeviceMetricView
{
  int pixels = -1;
  int bins = 0;
  double low = 0.0, toCell = 1.0;
  int cells = 0;
  uint8_t* xrayBins = nullptr;
  uint8_t* cellBins = nullptr;
};

/** What a kernel needs of one DRR, in one array on the GPU. */
struct Launch
{
  joseph::Job job;
  const int* pixels;
  int count;
  float* out;
  // Metric launches only.
  const uint8_t* xrayBins;
  const uint8_t* cellBins;
  int cells, bins;
  double low, toCell;
  unsigned int* histogram;
};

struct GlobalVoxel
{
  const uint16_t* voxels;
  int nx, nxy;
  __device__ float operator()(int x, int y, int z) const { return __ldg(voxels + x + y * nx + z * nxy); }
};

/** Trilinear through the texture unit: on a voxel plane the coordinate along its axis is whole,
 *  so the filter is bilinear there, as the float path. Unnormalised coordinates: voxel centres
 *  at i + 0.5. Returns volume steps (the texture reads 16-bit steps as fractions of 65535). */
__device__ float TextureSample(const joseph::Planes& p, int j, cudaTextureObject_t texture)
{
  const float fj = static_cast<float>(j);
  float at[3];
  at[p.axis] = static_cast<float>(p.m0 + p.sa * j);
  at[p.b] = fminf(fmaxf(p.b0 + fj * p.db, 0.0f), p.upperB);
  at[p.c] = fminf(fmaxf(p.c0 + fj * p.dc, 0.0f), p.upperC);
  return 65535.0f * tex3D<float>(texture, at[0] + 0.5f, at[1] + 0.5f, at[2] + 0.5f);
}

__device__ float TraceRay(const joseph::Job& job, const joseph::Grid& grid, int pixel, const uint16_t* voxels,
  cudaTextureObject_t texture, bool useTexture)
{
  if (!useTexture)
  {
    const GlobalVoxel voxel{ voxels, grid.dims[0], grid.dims[0] * grid.dims[1] };
    return joseph::LineIntegral(job, grid, pixel, voxel);
  }
  joseph::Planes planes;
  if (!joseph::SetUp(job, grid, pixel, planes))
    return 0.0f;
  float sum = 0.0f;
  for (int j = 0; j < planes.count; ++j)
    sum += TextureSample(planes, j, texture);
  return static_cast<float>(sum * planes.dt * grid.quantum);
}

/** Block (x, y): rays x * RaysPerBlock + thread of DRR y. */
__global__ void RenderKernel(const Launch* launches, joseph::Grid grid, const uint16_t* voxels,
  cudaTextureObject_t texture, bool useTexture)
{
  const Launch& launch = launches[blockIdx.y];
  const int n = blockIdx.x * blockDim.x + threadIdx.x;
  if (n >= launch.count)
    return;
  launch.out[n] = TraceRay(launch.job, grid, launch.pixels[n], voxels, texture, useTexture);
}

/** Joint histogram of DRR y's rendered integrals (launch.out) against its X-ray's bins: counted in
 *  shared memory per block, then added to the DRR's histogram in global memory. */
__global__ void HistogramKernel(const Launch* launches)
{
  __shared__ unsigned int counts[MaxBins * MaxBins];
  const Launch& launch = launches[blockIdx.y];
  const int cells = launch.bins * launch.bins;
  for (int i = threadIdx.x; i < cells; i += blockDim.x)
    counts[i] = 0;
  __syncthreads();
  for (int n = blockIdx.x * blockDim.x + threadIdx.x; n < launch.count; n += gridDim.x * blockDim.x)
  {
    // LevelTable's cell: the double product truncated towards zero, then clamped.
    const double scaled = (static_cast<double>(launch.out[n]) - launch.low) * launch.toCell;
    long long cell = static_cast<long long>(scaled);
    cell = cell < 0 ? 0 : (cell >= launch.cells ? launch.cells - 1 : cell);
    const int drrBin = launch.cellBins[cell];
    atomicAdd(&counts[launch.xrayBins[n] * launch.bins + drrBin], 1u);
  }
  __syncthreads();
  for (int i = threadIdx.x; i < cells; i += blockDim.x)
    if (counts[i])
      atomicAdd(&launch.histogram[i], counts[i]);
}

/** The sum of every thread's `value` over the block (blockDim.x a power of two), in shared memory. */
__device__ double BlockSum(double value, double* scratch)
{
  scratch[threadIdx.x] = value;
  __syncthreads();
  for (int half = blockDim.x / 2; half > 0; half /= 2)
  {
    if (threadIdx.x < half)
      scratch[threadIdx.x] += scratch[threadIdx.x + half];
    __syncthreads();
  }
  const double sum = scratch[0];
  __syncthreads();
  return sum;
}

__device__ double CLogC(double c)
{
  return c > 0.0 ? c * log(c) : 0.0;
}

/** One block per DRR: MI = H(X-ray) + H(DRR) - H(joint) from its histogram (JointHistogram's
 *  formula: H = ln N - sum c ln c / N), clamped at 0; 0 where no pixel counted. Block of 256. */
__global__ void MutualInformationKernel(const Launch* launches, double* mi)
{
  __shared__ double scratch[256];
  const Launch& launch = launches[blockIdx.x];
  const int bins = launch.bins;
  double joint = 0.0, total = 0.0, fixed = 0.0, moving = 0.0;
  for (int i = threadIdx.x; i < bins * bins; i += blockDim.x)
  {
    const double c = launch.histogram[i];
    joint += CLogC(c);
    total += c;
  }
  for (int b = threadIdx.x; b < bins; b += blockDim.x)
  {
    double row = 0.0, column = 0.0;
    for (int k = 0; k < bins; ++k)
    {
      row += launch.histogram[b * bins + k];
      column += launch.histogram[k * bins + b];
    }
    fixed += CLogC(row);
    moving += CLogC(column);
  }
  joint = BlockSum(joint, scratch);
  total = BlockSum(total, scratch);
  fixed = BlockSum(fixed, scratch);
  moving = BlockSum(moving, scratch);
  if (threadIdx.x == 0)
  {
    if (total <= 0.0)
    {
      mi[blockIdx.x] = 0.0;
      return;
    }
    const double logN = log(total);
    const double hFixed = logN - fixed / total, hMoving = logN - moving / total, hJoint = logN - joint / total;
    mi[blockIdx.x] = fmax(0.0, hFixed + hMoving - hJoint);
  }
}

template <typename T>
T* DeviceCopy(const T* host, size_t count)
{
  T* device = nullptr;
  Check(cudaMalloc(&device, std::max<size_t>(count, 1) * sizeof(T)), "allocating GPU memory");
  if (count)
    Check(cudaMemcpy(device, host, count * sizeof(T), cudaMemcpyHostToDevice), "copying to the GPU");
  return device;
}

} // namespace

bool Available(std::string* reason)
{
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess || count < 1)
  {
    if (reason)
      *reason = status == cudaErrorInsufficientDriver || status == cudaErrorNoDevice
        ? std::string("no NVIDIA GPU with a driver for CUDA ") + std::to_string(CUDART_VERSION / 1000) + " found"
        : status != cudaSuccess ? std::string("no usable CUDA GPU (") + cudaGetErrorString(status) + ")"
                                : std::string("no CUDA GPU found");
    cudaGetLastError(); // a failed query leaves no error behind for later calls
    return false;
  }
  return true;
}

struct GPUContext::Resident
{
  int device = 0;
  cudaStream_t stream = nullptr;
  int next = 1;
  std::map<int, DeviceVolume> volumes;
  std::map<int, DevicePixels> pixels;
  std::map<int, DeviceMetricView> views;
  // Per call, grown as needed and kept.
  Launch* launches = nullptr;
  size_t launchCapacity = 0;
  float* integrals = nullptr;
  size_t integralCapacity = 0;
  unsigned int* histograms = nullptr;
  size_t histogramCapacity = 0;
  double* mi = nullptr;
  size_t miCapacity = 0;
  float* staging = nullptr; // pinned: the integrals' way back
  size_t stagingCapacity = 0;

  template <typename T>
  static void Grow(T*& buffer, size_t& capacity, size_t needed)
  {
    if (needed <= capacity)
      return;
    if (buffer)
      cudaFree(buffer);
    buffer = nullptr;
    capacity = 0;
    Check(cudaMalloc(&buffer, needed * sizeof(T)), "allocating GPU memory");
    capacity = needed;
  }

  void GrowStaging(size_t needed)
  {
    if (needed <= stagingCapacity)
      return;
    if (staging)
      cudaFreeHost(staging);
    staging = nullptr;
    stagingCapacity = 0;
    Check(cudaMallocHost(&staging, needed * sizeof(float)), "allocating pinned memory");
    stagingCapacity = needed;
  }

  DeviceVolume& Volume(int handle)
  {
    const auto found = volumes.find(handle);
    if (found == volumes.end())
      throw Error("CUDA ray caster", "no volume " + std::to_string(handle) + " on the GPU");
    return found->second;
  }

  /** The volume's texture (a 3D array of its 16-bit steps, read as fractions with the linear
   *  filter), copied from its voxels on the GPU the first time the filter is asked for. */
  static void EnsureTexture(DeviceVolume& volume)
  {
    if (volume.texture)
      return;
    const joseph::Grid& grid = volume.grid;
    const cudaChannelFormatDesc format = cudaCreateChannelDesc<uint16_t>();
    const cudaExtent extent = make_cudaExtent(grid.dims[0], grid.dims[1], grid.dims[2]);
    Check(cudaMalloc3DArray(&volume.array, &format, extent), "allocating the volume's texture");
    cudaMemcpy3DParms copy{};
    copy.srcPtr = make_cudaPitchedPtr(volume.voxels, grid.dims[0] * sizeof(uint16_t), grid.dims[0], grid.dims[1]);
    copy.dstArray = volume.array;
    copy.extent = extent;
    copy.kind = cudaMemcpyDeviceToDevice;
    Check(cudaMemcpy3D(&copy), "copying the volume's texture");
    cudaResourceDesc resource{};
    resource.resType = cudaResourceTypeArray;
    resource.res.array.array = volume.array;
    cudaTextureDesc texture{};
    for (int a = 0; a < 3; ++a)
      texture.addressMode[a] = cudaAddressModeClamp;
    texture.filterMode = cudaFilterModeLinear;
    texture.readMode = cudaReadModeNormalizedFloat;
    texture.normalizedCoords = 0;
    Check(cudaCreateTextureObject(&volume.texture, &resource, &texture, nullptr), "creating the volume's texture");
  }
  const DevicePixels& Pixels(int handle) const
  {
    const auto found = pixels.find(handle);
    if (found == pixels.end())
      throw Error("CUDA ray caster", "no pixel list " + std::to_string(handle) + " on the GPU");
    return found->second;
  }

  /** Fills `launches` on the GPU and starts the rays; outputs at integrals + offsets. */
  void StartRender(DeviceVolume& volume, std::vector<Launch>& host, Interpolation interpolation)
  {
    if (interpolation == Interpolation::Texture)
      EnsureTexture(volume);
    Grow(launches, launchCapacity, host.size());
    Check(cudaMemcpyAsync(launches, host.data(), host.size() * sizeof(Launch), cudaMemcpyHostToDevice, stream),
      "copying the DRRs' geometry");
    int most = 0;
    for (const Launch& launch : host)
      most = std::max(most, launch.count);
    if (most == 0)
      return;
    const dim3 blocks((most + RaysPerBlock - 1) / RaysPerBlock, static_cast<unsigned>(host.size()));
    RenderKernel<<<blocks, RaysPerBlock, 0, stream>>>(
      launches, volume.grid, volume.voxels, volume.texture, interpolation == Interpolation::Texture);
    Check(cudaGetLastError(), "starting the ray caster");
  }

  ~Resident()
  {
    for (auto& [handle, volume] : volumes)
    {
      if (volume.texture)
        cudaDestroyTextureObject(volume.texture);
      if (volume.array)
        cudaFreeArray(volume.array);
      cudaFree(volume.voxels);
    }
    for (auto& [handle, list] : pixels)
      cudaFree(list.pixels);
    for (auto& [handle, view] : views)
    {
      cudaFree(view.xrayBins);
      cudaFree(view.cellBins);
    }
    cudaFree(launches);
    cudaFree(integrals);
    cudaFree(histograms);
    cudaFree(mi);
    if (staging)
      cudaFreeHost(staging);
    if (stream)
      cudaStreamDestroy(stream);
  }
};

GPUContext::GPUContext()
  : Data(std::make_unique<Resident>())
{
  std::string reason;
  if (!Available(&reason))
    throw Error("CUDA", reason);
  Check(cudaSetDevice(this->Data->device), "selecting the GPU");
  Check(cudaStreamCreateWithFlags(&this->Data->stream, cudaStreamNonBlocking), "creating a stream");
}

GPUContext::~GPUContext() = default;

std::string GPUContext::DeviceName() const
{
  cudaDeviceProp properties{};
  Check(cudaGetDeviceProperties(&properties, this->Data->device), "reading the GPU's properties");
  return properties.name;
}

int GPUContext::AddVolume(const uint16_t* paddedVoxels, const joseph::Grid& grid)
{
  for (int a = 0; a < 3; ++a)
    if (grid.dims[a] < 2)
      throw Error("CUDA ray caster", "a padded volume has at least 2 voxels per axis");
  DeviceVolume volume;
  volume.grid = grid;
  const size_t count = static_cast<size_t>(grid.dims[0]) * grid.dims[1] * grid.dims[2];
  volume.voxels = DeviceCopy(paddedVoxels, count);
  const int handle = this->Data->next++;
  this->Data->volumes.emplace(handle, volume);
  return handle;
}

int GPUContext::AddPixels(const int* pixels, int count)
{
  if (count < 0)
    throw Error("CUDA ray caster", "a negative pixel count");
  DevicePixels list;
  list.pixels = DeviceCopy(pixels, static_cast<size_t>(count));
  list.count = count;
  const int handle = this->Data->next++;
  this->Data->pixels.emplace(handle, list);
  return handle;
}

void GPUContext::Remove(int handle)
{
  Resident& data = *this->Data;
  if (auto volume = data.volumes.find(handle); volume != data.volumes.end())
  {
    if (volume->second.texture)
      cudaDestroyTextureObject(volume->second.texture);
    if (volume->second.array)
      cudaFreeArray(volume->second.array);
    cudaFree(volume->second.voxels);
    data.volumes.erase(volume);
  }
  if (auto list = data.pixels.find(handle); list != data.pixels.end())
  {
    cudaFree(list->second.pixels);
    data.pixels.erase(list);
  }
  if (auto view = data.views.find(handle); view != data.views.end())
  {
    cudaFree(view->second.xrayBins);
    cudaFree(view->second.cellBins);
    data.views.erase(view);
  }
}

long long GPUContext::Render(int volumeHandle, const joseph::Job* jobs, const int* pixels, int count, float* const* out,
  Interpolation interpolation)
{
  Resident& data = *this->Data;
  DeviceVolume& volume = data.Volume(volumeHandle);
  std::vector<Launch> launches(static_cast<size_t>(std::max(count, 0)));
  size_t total = 0;
  std::vector<size_t> offsets;
  for (int d = 0; d < count; ++d)
  {
    const DevicePixels& list = data.Pixels(pixels[d]);
    offsets.push_back(total);
    launches[d] = Launch{ jobs[d], list.pixels, list.count, nullptr, nullptr, nullptr, 0, 0, 0.0, 0.0, nullptr };
    total += static_cast<size_t>(list.count);
  }
  if (total == 0)
    return 0;
  Resident::Grow(data.integrals, data.integralCapacity, total);
  for (int d = 0; d < count; ++d)
    launches[d].out = data.integrals + offsets[d];
  data.StartRender(volume, launches, interpolation);
  data.GrowStaging(total);
  Check(cudaMemcpyAsync(data.staging, data.integrals, total * sizeof(float), cudaMemcpyDeviceToHost, data.stream),
    "copying the line integrals back");
  Check(cudaStreamSynchronize(data.stream), "casting the rays");
  for (int d = 0; d < count; ++d)
    std::copy(data.staging + offsets[d], data.staging + offsets[d] + launches[d].count, out[d]);
  return static_cast<long long>(total);
}

int GPUContext::AddMetricView(int pixels, const uint8_t* xrayBins, int bins, double low, double toCell,
  const std::vector<uint8_t>& cellBins)
{
  Resident& data = *this->Data;
  const DevicePixels& list = data.Pixels(pixels);
  if (bins < 2 || bins > MaxBins)
    throw Error("CUDA metric", "bins must be 2 to " + std::to_string(MaxBins) + ", not " + std::to_string(bins));
  if (cellBins.empty())
    throw Error("CUDA metric", "no level table");
  for (int n = 0; n < list.count; ++n)
    if (xrayBins[n] >= bins)
      throw Error("CUDA metric", "an X-ray bin beyond the bins");
  for (uint8_t bin : cellBins)
    if (bin >= bins)
      throw Error("CUDA metric", "a level table's bin beyond the bins");
  DeviceMetricView view;
  view.pixels = pixels;
  view.bins = bins;
  view.low = low;
  view.toCell = toCell;
  view.cells = static_cast<int>(cellBins.size());
  view.xrayBins = DeviceCopy(xrayBins, static_cast<size_t>(list.count));
  view.cellBins = DeviceCopy(cellBins.data(), cellBins.size());
  const int handle = data.next++;
  data.views.emplace(handle, view);
  return handle;
}

long long GPUContext::MutualInformation(int volumeHandle, const joseph::Job* jobs, const int* views, int count, double* mi,
  Interpolation interpolation)
{
  Resident& data = *this->Data;
  DeviceVolume& volume = data.Volume(volumeHandle);
  if (count <= 0)
    return 0;
  std::vector<Launch> launches(static_cast<size_t>(count));
  size_t total = 0, cells = 0;
  std::vector<size_t> offsets, histogramOffsets;
  for (int d = 0; d < count; ++d)
  {
    const auto found = data.views.find(views[d]);
    if (found == data.views.end())
      throw Error("CUDA metric", "no metric view " + std::to_string(views[d]) + " on the GPU");
    const DeviceMetricView& view = found->second;
    const DevicePixels& list = data.Pixels(view.pixels);
    offsets.push_back(total);
    histogramOffsets.push_back(cells);
    launches[d] = Launch{ jobs[d], list.pixels, list.count, nullptr, view.xrayBins, view.cellBins, view.cells, view.bins,
      view.low, view.toCell, nullptr };
    total += static_cast<size_t>(list.count);
    cells += static_cast<size_t>(view.bins) * view.bins;
  }
  Resident::Grow(data.integrals, data.integralCapacity, std::max<size_t>(total, 1));
  Resident::Grow(data.histograms, data.histogramCapacity, cells);
  Resident::Grow(data.mi, data.miCapacity, static_cast<size_t>(count));
  for (int d = 0; d < count; ++d)
  {
    launches[d].out = data.integrals + offsets[d];
    launches[d].histogram = data.histograms + histogramOffsets[d];
  }
  Check(cudaMemsetAsync(data.histograms, 0, cells * sizeof(unsigned int), data.stream), "clearing the histograms");
  data.StartRender(volume, launches, interpolation);
  int most = 0;
  for (const Launch& launch : launches)
    most = std::max(most, launch.count);
  if (most > 0)
  {
    // Enough blocks to fill the GPU, each counting a few thousand pixels into shared memory.
    const unsigned blocksPerDRR = static_cast<unsigned>(std::min(64, (most + 4095) / 4096));
    HistogramKernel<<<dim3(blocksPerDRR, static_cast<unsigned>(count)), 256, 0, data.stream>>>(data.launches);
    Check(cudaGetLastError(), "starting the histograms");
  }
  MutualInformationKernel<<<static_cast<unsigned>(count), 256, 0, data.stream>>>(data.launches, data.mi);
  Check(cudaGetLastError(), "starting the mutual information");
  Check(cudaMemcpyAsync(mi, data.mi, static_cast<size_t>(count) * sizeof(double), cudaMemcpyDeviceToHost, data.stream),
    "copying the mutual information back");
  Check(cudaStreamSynchronize(data.stream), "computing the mutual information");
  return static_cast<long long>(total);
}

} // namespace cuda
} // namespace xp
