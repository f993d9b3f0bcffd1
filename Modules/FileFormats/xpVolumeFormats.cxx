#include "xpVolumeFormats.h"

#include "xpError.h"
#include "xpPageMemory.h"

#include <vtkFloatArray.h>
#include <vtkShortArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>

#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <sys/stat.h>

namespace xp
{

namespace
{

// 2^30 voxels: 4 GiB of float HU, beyond any planning CT; checked before allocating.
constexpr int64_t MaxVoxels = int64_t(1) << 30;
// Beyond any extended-range CT scale; also keeps the double -> float conversion defined.
constexpr double MaxAbsoluteHU = 1e6;

template <typename T>
T Swapped(T value)
{
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  std::reverse(bytes, bytes + sizeof(T));
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

/**
 * Decodes, rescales and checks voxels [begin, end); returns the index of the first bad one, or
 * -1. The loop has no early exit, so that it vectorises; a bad voxel is then looked for again.
 */
template <typename T>
int64_t ConvertRange(const char* data, int64_t begin, int64_t end, bool swap, double slope, double intercept, float* out)
{
  bool allGood = true;
  for (int64_t i = begin; i < end; ++i)
  {
    T stored;
    std::memcpy(&stored, data + i * sizeof(T), sizeof(T));
    const double value = static_cast<double>(swap ? Swapped(stored) : stored) * slope + intercept;
    const bool good = std::abs(value) <= MaxAbsoluteHU; // false for NaN
    allGood &= good;
    out[i] = good ? static_cast<float>(value) : 0.0f;
  }
  if (allGood)
    return -1;
  for (int64_t i = begin; i < end; ++i)
  {
    T stored;
    std::memcpy(&stored, data + i * sizeof(T), sizeof(T));
    if (!(std::abs(static_cast<double>(swap ? Swapped(stored) : stored) * slope + intercept) <= MaxAbsoluteHU))
      return i;
  }
  return -1;
}

/** ConvertRange over all voxels, in parallel; the first bad voxel in file order, or -1. */
template <typename T>
int64_t Convert(const char* data, int64_t count, bool swap, double slope, double intercept, float* out)
{
  std::atomic<int64_t> firstBad{ count };
  vtkSMPTools::For(0, count, int64_t(1) << 20,
    [&](int64_t begin, int64_t end)
    {
      const int64_t bad = ConvertRange<T>(data, begin, end, swap, slope, intercept, out);
      int64_t seen = firstBad.load();
      while (bad >= 0 && bad < seen && !firstBad.compare_exchange_weak(seen, bad))
      {
      }
    });
  return firstBad.load() < count ? firstBad.load() : -1;
}

/** Calls f with a value of the C++ type of `type` (f(int16_t{}) for Int16, ...). */
template <typename F>
auto WithStoredType(VoxelType type, F&& f)
{
  switch (type)
  {
    case VoxelType::Int8:
      return f(int8_t{});
    case VoxelType::UInt8:
      return f(uint8_t{});
    case VoxelType::Int16:
      return f(int16_t{});
    case VoxelType::UInt16:
      return f(uint16_t{});
    case VoxelType::Int32:
      return f(int32_t{});
    case VoxelType::UInt32:
      return f(uint32_t{});
    case VoxelType::Float32:
      return f(float{});
    case VoxelType::Float64:
      break;
  }
  return f(double{});
}

/** Reads the stored voxels a chunk at a time and converts each chunk in parallel; the first
 *  bad voxel in file order, or -1 (reading stops there). */
template <typename T>
int64_t ConvertStream(const VolumeHeader& header, const std::function<void(char*, uint64_t)>& readVoxels, float* out)
{
  constexpr int64_t ChunkVoxels = int64_t(1) << 21; // at most 16 MiB of stored voxels in memory
  const int64_t n = header.VoxelCount();
  const bool swap = header.bigEndian && sizeof(T) > 1; // every supported host is little-endian
  std::vector<char> chunk(static_cast<size_t>(std::min(n, ChunkVoxels)) * sizeof(T));
  for (int64_t start = 0; start < n; start += ChunkVoxels)
  {
    const int64_t count = std::min(ChunkVoxels, n - start);
    readVoxels(chunk.data(), static_cast<uint64_t>(count) * sizeof(T));
    const int64_t bad = Convert<T>(chunk.data(), count, swap, header.slope, header.intercept, out + start);
    if (bad >= 0)
      return start + bad;
  }
  return -1;
}

/** Reads the stored integers a chunk at a time as 16-bit HU (stored + intercept, clamped to
 *  the 16-bit range), each chunk in parallel. */
template <typename T>
void ConvertStreamToShort(const VolumeHeader& header, const std::function<void(char*, uint64_t)>& readVoxels, int16_t* out)
{
  constexpr int64_t ChunkVoxels = int64_t(1) << 21;
  const int64_t n = header.VoxelCount();
  const bool swap = header.bigEndian && sizeof(T) > 1;
  const int32_t intercept = static_cast<int32_t>(header.intercept);
  std::vector<char> chunk(static_cast<size_t>(std::min(n, ChunkVoxels)) * sizeof(T));
  for (int64_t start = 0; start < n; start += ChunkVoxels)
  {
    const int64_t count = std::min(ChunkVoxels, n - start);
    readVoxels(chunk.data(), static_cast<uint64_t>(count) * sizeof(T));
    const char* data = chunk.data();
    vtkSMPTools::For(0, count, int64_t(1) << 18,
      [&](int64_t begin, int64_t end)
      {
        for (int64_t i = begin; i < end; ++i)
        {
          T stored;
          std::memcpy(&stored, data + i * sizeof(T), sizeof(T));
          const int32_t hu = static_cast<int32_t>(swap ? Swapped(stored) : stored) + intercept;
          out[start + i] = static_cast<int16_t>(std::clamp<int32_t>(hu, -32768, 32767));
        }
      });
  }
}

/** Checks float voxels already in place, in parallel; the first bad one, or -1. */
int64_t CheckInPlace(const float* voxels, int64_t count)
{
  std::atomic<int64_t> firstBad{ count };
  vtkSMPTools::For(0, count, int64_t(1) << 20,
    [&](int64_t begin, int64_t end)
    {
      bool allGood = true;
      for (int64_t i = begin; i < end; ++i)
        allGood &= std::abs(voxels[i]) <= static_cast<float>(MaxAbsoluteHU);
      if (allGood)
        return;
      for (int64_t i = begin; i < end; ++i)
      {
        if (!(std::abs(voxels[i]) <= static_cast<float>(MaxAbsoluteHU)))
        {
          int64_t seen = firstBad.load();
          while (i < seen && !firstBad.compare_exchange_weak(seen, i))
          {
          }
          return;
        }
      }
    });
  return firstBad.load() < count ? firstBad.load() : -1;
}

} // namespace

size_t VoxelBytes(VoxelType type)
{
  switch (type)
  {
    case VoxelType::Int8:
    case VoxelType::UInt8:
      return 1;
    case VoxelType::Int16:
    case VoxelType::UInt16:
      return 2;
    case VoxelType::Int32:
    case VoxelType::UInt32:
    case VoxelType::Float32:
      return 4;
    case VoxelType::Float64:
      return 8;
  }
  return 0;
}

uint64_t FileSize(const std::string& path)
{
  struct stat status;
  return stat(path.c_str(), &status) == 0 ? static_cast<uint64_t>(status.st_size) : 0;
}

bool KeepsWholeHU16(const VolumeHeader& header)
{
  const bool smallIntegers = header.type == VoxelType::Int8 || header.type == VoxelType::UInt8 ||
    header.type == VoxelType::Int16 || header.type == VoxelType::UInt16;
  return smallIntegers && header.slope == 1.0 && header.intercept == std::floor(header.intercept) &&
    std::abs(header.intercept) <= 65536.0;
}

uint64_t VolumeHeader::DataBytes() const
{
  return static_cast<uint64_t>(this->VoxelCount()) * VoxelBytes(this->type);
}

void CheckVolumeHeader(const VolumeHeader& header, const std::string& path, const std::array<std::string, 4>& fields)
{
  const auto& d = header.dimensions;
  if (d[0] < 1 || d[1] < 1 || d[2] < 1)
  {
    throw InputError(path, fields[0] + ": every dimension must be at least 1");
  }
  if (d[0] > MaxVoxels || d[1] > MaxVoxels || d[2] > MaxVoxels || d[0] * d[1] > MaxVoxels ||
    header.VoxelCount() > MaxVoxels)
  {
    throw InputError(path, fields[0] + ": " + std::to_string(d[0]) + " x " + std::to_string(d[1]) + " x " +
        std::to_string(d[2]) + " voxels exceed the limit of " + std::to_string(MaxVoxels));
  }
  if (d[2] < 2)
  {
    throw InputError(path, fields[0] + ": a CT volume needs at least two slices");
  }
  if (!header.spacing.allFinite() || !(header.spacing.minCoeff() > 0.0))
  {
    throw InputError(path, fields[1] + ": voxel spacing must be finite and positive");
  }
  if (!header.origin.allFinite())
  {
    throw InputError(path, fields[2] + ": the origin must be finite");
  }
  if (!header.direction.allFinite() || std::abs(header.direction.determinant()) < 1e-3)
  {
    throw InputError(path, fields[3] + ": the axis directions must be finite and span three dimensions");
  }
  for (int a = 0; a < 3; ++a)
  {
    if (std::abs(header.direction.col(a).norm() - 1.0) > 1e-3)
    {
      throw InputError(path, fields[3] + ": axis " + std::to_string(a) + " is not a unit vector");
    }
  }
  if (!std::isfinite(header.slope) || !std::isfinite(header.intercept) || header.slope == 0.0)
  {
    throw InputError(path, "the intensity slope and intercept must be finite, the slope non-zero");
  }
}

CTVolume MakeCTVolume(
  const VolumeHeader& header, const std::string& path, const std::function<void(char*, uint64_t)>& readVoxels)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(static_cast<int>(header.dimensions[0]), static_cast<int>(header.dimensions[1]),
    static_cast<int>(header.dimensions[2]));
  image->SetOrigin(header.origin.data());
  image->SetSpacing(header.spacing.data());
  const Eigen::Matrix3d& m = header.direction;
  image->SetDirectionMatrix(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2));
  const int64_t n = header.VoxelCount();
  if (KeepsWholeHU16(header))
  {
    vtkSmartPointer<vtkShortArray> hu = NewPageShortArray(n);
    hu->SetName("HU");
    int16_t* out = hu->GetPointer(0);
    if (header.type == VoxelType::Int16 && !header.bigEndian && header.intercept == 0.0)
      readVoxels(reinterpret_cast<char*>(out), header.DataBytes()); // already 16-bit HU
    else
      WithStoredType(header.type, [&](auto stored) { ConvertStreamToShort<decltype(stored)>(header, readVoxels, out); });
    image->GetPointData()->SetScalars(hu);
    return CTVolume{ image };
  }
  vtkSmartPointer<vtkFloatArray> hu = NewPageFloatArray(n);
  hu->SetName("HU");
  float* out = hu->GetPointer(0);
  int64_t bad = -1;
  if (header.type == VoxelType::Float32 && !header.bigEndian && header.slope == 1.0 && header.intercept == 0.0)
  {
    readVoxels(reinterpret_cast<char*>(out), header.DataBytes());
    bad = CheckInPlace(out, n);
  }
  else
  {
    bad = WithStoredType(header.type, [&](auto stored) { return ConvertStream<decltype(stored)>(header, readVoxels, out); });
  }
  if (bad >= 0)
  {
    throw InputError(path, "voxel " + std::to_string(bad) + " is not finite or beyond +-1e6 HU after rescaling");
  }
  image->GetPointData()->SetScalars(hu);
  return CTVolume{ image };
}

} // namespace xp
