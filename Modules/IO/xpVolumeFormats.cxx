#include "xpVolumeFormats.h"

#include "xpError.h"

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <Eigen/LU>
#include <algorithm>
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
double Decode(const char* bytes, bool swap)
{
  char copy[sizeof(T)];
  std::memcpy(copy, bytes, sizeof(T));
  if (swap)
  {
    std::reverse(copy, copy + sizeof(T));
  }
  T value;
  std::memcpy(&value, copy, sizeof(T));
  return static_cast<double>(value);
}

/** Decodes, rescales and checks every voxel; returns the index of the first bad one, or -1. */
template <typename T>
int64_t Convert(const char* data, int64_t count, bool swap, double slope, double intercept, float* out)
{
  for (int64_t i = 0; i < count; ++i)
  {
    const double value = Decode<T>(data + i * sizeof(T), swap) * slope + intercept;
    if (!(std::abs(value) <= MaxAbsoluteHU))
    {
      return i;
    }
    out[i] = static_cast<float>(value);
  }
  return -1;
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

CTVolume MakeCTVolume(const VolumeHeader& header, const std::vector<char>& data, const std::string& path)
{
  if (data.size() != header.DataBytes())
  {
    throw Error(path, "internal: voxel data size differs from the header");
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(static_cast<int>(header.dimensions[0]), static_cast<int>(header.dimensions[1]),
    static_cast<int>(header.dimensions[2]));
  image->SetOrigin(header.origin.data());
  image->SetSpacing(header.spacing.data());
  const Eigen::Matrix3d& m = header.direction;
  image->SetDirectionMatrix(m(0, 0), m(0, 1), m(0, 2), m(1, 0), m(1, 1), m(1, 2), m(2, 0), m(2, 1), m(2, 2));
  vtkNew<vtkFloatArray> hu;
  hu->SetName("HU");
  hu->SetNumberOfValues(header.VoxelCount());
  float* out = hu->GetPointer(0);
  const bool swap = header.bigEndian; // every supported host is little-endian (x86-64, AArch64)
  const int64_t n = header.VoxelCount();
  const double k = header.slope, c = header.intercept;
  int64_t bad = -1;
  switch (header.type)
  {
    case VoxelType::Int8:
      bad = Convert<int8_t>(data.data(), n, false, k, c, out);
      break;
    case VoxelType::UInt8:
      bad = Convert<uint8_t>(data.data(), n, false, k, c, out);
      break;
    case VoxelType::Int16:
      bad = Convert<int16_t>(data.data(), n, swap, k, c, out);
      break;
    case VoxelType::UInt16:
      bad = Convert<uint16_t>(data.data(), n, swap, k, c, out);
      break;
    case VoxelType::Int32:
      bad = Convert<int32_t>(data.data(), n, swap, k, c, out);
      break;
    case VoxelType::UInt32:
      bad = Convert<uint32_t>(data.data(), n, swap, k, c, out);
      break;
    case VoxelType::Float32:
      bad = Convert<float>(data.data(), n, swap, k, c, out);
      break;
    case VoxelType::Float64:
      bad = Convert<double>(data.data(), n, swap, k, c, out);
      break;
  }
  if (bad >= 0)
  {
    throw InputError(path, "voxel " + std::to_string(bad) + " is not finite or beyond +-1e6 HU after rescaling");
  }
  image->GetPointData()->SetScalars(hu);
  CTVolume volume;
  volume.image = image;
  return volume;
}

} // namespace xp
