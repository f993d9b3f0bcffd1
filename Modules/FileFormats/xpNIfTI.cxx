// NIfTI-1 (.nii, .nii.gz) reading with every header field and the data length checked.
#include "xpError.h"
#include "xpVolumeFormats.h"

#include <Eigen/Geometry>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <cstring>

namespace xp
{

namespace
{

const std::array<std::string, 4> NIfTIFields{ "dim", "pixdim", "qoffset/srow", "quatern/srow" };
constexpr int HeaderBytes = 348;

/** The NIfTI-1 header fields xpose uses, at their byte offsets (nifti1.h). */
struct NIfTIHeader
{
  int16_t dim[8];
  int16_t datatype;
  float pixdim[8];
  float voxOffset, sclSlope, sclInter;
  int16_t qformCode, sformCode;
  float quatern[3], qoffset[3], srow[3][4];
};

template <typename T>
T Field(const unsigned char* bytes, int offset, bool swap)
{
  unsigned char copy[sizeof(T)];
  std::memcpy(copy, bytes + offset, sizeof(T));
  if (swap)
    std::reverse(copy, copy + sizeof(T));
  T value;
  std::memcpy(&value, copy, sizeof(T));
  return value;
}

NIfTIHeader ParseHeader(const unsigned char* b, const std::string& path, bool& swap)
{
  const int32_t size = Field<int32_t>(b, 0, false);
  swap = size != HeaderBytes;
  if (swap && Field<int32_t>(b, 0, true) != HeaderBytes)
  {
    const bool nifti2 = size == 540 || Field<int32_t>(b, 0, true) == 540;
    throw InputError(path, nifti2 ? "sizeof_hdr: NIfTI-2 is not supported (write NIfTI-1)"
                                  : "sizeof_hdr: not 348, not a NIfTI-1 file");
  }
  if (std::memcmp(b + 344, "n+1\0", 4) != 0)
  {
    throw InputError(path, std::memcmp(b + 344, "ni1\0", 4) == 0
        ? "magic: a header/image pair (.hdr/.img) is not supported; write a single .nii file"
        : "magic: not 'n+1', not a NIfTI-1 file");
  }
  NIfTIHeader h;
  for (int i = 0; i < 8; ++i)
  {
    h.dim[i] = Field<int16_t>(b, 40 + 2 * i, swap);
    h.pixdim[i] = Field<float>(b, 76 + 4 * i, swap);
  }
  h.datatype = Field<int16_t>(b, 70, swap);
  h.voxOffset = Field<float>(b, 108, swap);
  h.sclSlope = Field<float>(b, 112, swap);
  h.sclInter = Field<float>(b, 116, swap);
  h.qformCode = Field<int16_t>(b, 252, swap);
  h.sformCode = Field<int16_t>(b, 254, swap);
  for (int i = 0; i < 3; ++i)
  {
    h.quatern[i] = Field<float>(b, 256 + 4 * i, swap);
    h.qoffset[i] = Field<float>(b, 268 + 4 * i, swap);
    for (int j = 0; j < 4; ++j)
      h.srow[i][j] = Field<float>(b, 280 + 16 * i + 4 * j, swap);
  }
  return h;
}

VoxelType DataType(int16_t code, const std::string& path)
{
  switch (code)
  {
    case 2:
      return VoxelType::UInt8;
    case 4:
      return VoxelType::Int16;
    case 8:
      return VoxelType::Int32;
    case 16:
      return VoxelType::Float32;
    case 64:
      return VoxelType::Float64;
    case 256:
      return VoxelType::Int8;
    case 512:
      return VoxelType::UInt16;
    case 768:
      return VoxelType::UInt32;
    default:
      throw InputError(path, "datatype: " + std::to_string(code) + " is not a supported scalar type");
  }
}

/** index -> RAS mm, by the qform (method 2), else the sform (method 3), else pixdim (method 1). */
Eigen::Matrix4d IndexToRAS(const NIfTIHeader& h, const std::string& path)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Vector3d spacing(h.pixdim[1], h.pixdim[2], h.pixdim[3]);
  if (h.qformCode > 0)
  {
    const Eigen::Vector3d bcd(h.quatern[0], h.quatern[1], h.quatern[2]);
    const Eigen::Vector3d offset(h.qoffset[0], h.qoffset[1], h.qoffset[2]);
    if (!bcd.allFinite() || !offset.allFinite() || bcd.squaredNorm() > 1.0 + 1e-4)
    {
      throw InputError(path, "quatern_b/c/d, qoffset: not a finite unit quaternion and offset");
    }
    const double a = std::sqrt(std::max(0.0, 1.0 - bcd.squaredNorm()));
    const Eigen::Matrix3d r = Eigen::Quaterniond(a, bcd[0], bcd[1], bcd[2]).normalized().toRotationMatrix();
    const double qfac = h.pixdim[0] < 0 ? -1.0 : 1.0;
    m.topLeftCorner<3, 3>() = r * Eigen::Vector3d(spacing[0], spacing[1], qfac * spacing[2]).asDiagonal();
    m.topRightCorner<3, 1>() = offset;
  }
  else if (h.sformCode > 0)
  {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        m(r, c) = h.srow[r][c];
    if (!m.allFinite())
    {
      throw InputError(path, "srow_x/y/z: not finite");
    }
  }
  else
  {
    m.topLeftCorner<3, 3>() = spacing.asDiagonal();
  }
  return m;
}

/** Reads exactly `count` bytes; zlib reads plain and gzip-compressed files alike. */
void ReadExactly(gzFile file, char* out, uint64_t count, const std::string& path, const std::string& what)
{
  uint64_t done = 0;
  while (done < count)
  {
    const unsigned chunk = static_cast<unsigned>(std::min<uint64_t>(count - done, 1u << 30));
    const int got = gzread(file, out + done, chunk);
    if (got <= 0)
    {
      int code = 0;
      const char* message = gzerror(file, &code);
      throw InputError(path, what + " ends after " + std::to_string(done) + " of " + std::to_string(count) + " bytes" +
          (code != Z_OK && message ? std::string(" (") + message + ")" : std::string(" (truncated file)")));
    }
    done += static_cast<uint64_t>(got);
  }
}

struct GzCloser
{
  void operator()(gzFile_s* file) const { gzclose(file); }
};

} // namespace

CTVolume ReadNIfTI(const std::string& path)
{
  std::unique_ptr<gzFile_s, GzCloser> file(gzopen(path.c_str(), "rb"));
  if (!file)
  {
    throw InputError(path, "cannot open the NIfTI file");
  }
  unsigned char bytes[HeaderBytes];
  ReadExactly(file.get(), reinterpret_cast<char*>(bytes), HeaderBytes, path, "the NIfTI header");
  bool swap = false;
  const NIfTIHeader h = ParseHeader(bytes, path, swap);

  if (h.dim[0] < 3 || h.dim[0] > 7)
  {
    throw InputError(path, "dim[0] = " + std::to_string(h.dim[0]) + ": a CT volume has 3 dimensions");
  }
  for (int d = 4; d <= h.dim[0]; ++d)
  {
    if (h.dim[d] != 1)
    {
      throw InputError(path, "dim[" + std::to_string(d) + "] = " + std::to_string(h.dim[d]) +
          ": time series and vector volumes are not supported");
    }
  }
  VolumeHeader header;
  for (int a = 0; a < 3; ++a)
    header.dimensions[a] = h.dim[a + 1];
  header.type = DataType(h.datatype, path);
  header.bigEndian = swap;
  if (std::isfinite(h.sclSlope) && h.sclSlope != 0.0f)
  {
    header.slope = h.sclSlope;
    header.intercept = h.sclInter;
  }
  for (int a = 1; a <= 3; ++a)
  {
    if (!std::isfinite(h.pixdim[a]) || !(h.pixdim[a] > 0.0f))
    {
      throw InputError(path, "pixdim[" + std::to_string(a) + "] = " + std::to_string(h.pixdim[a]) +
          ": voxel spacing must be finite and positive");
    }
  }
  // RAS (NIfTI) -> LPS (xpose), then split into spacing and unit directions.
  const Eigen::Matrix4d indexToLPS = Eigen::Vector4d(-1, -1, 1, 1).asDiagonal() * IndexToRAS(h, path);
  for (int a = 0; a < 3; ++a)
  {
    header.spacing[a] = indexToLPS.block<3, 1>(0, a).norm();
    header.direction.col(a) = indexToLPS.block<3, 1>(0, a) / std::max(header.spacing[a], 1e-300);
  }
  header.origin = indexToLPS.block<3, 1>(0, 3);
  CheckVolumeHeader(header, path, NIfTIFields);

  if (!(h.voxOffset >= 352.0f) || h.voxOffset > 1e8f || h.voxOffset != std::floor(h.voxOffset))
  {
    throw InputError(path, "vox_offset = " + std::to_string(h.voxOffset) + ": expected a whole number of at least 352");
  }
  const uint64_t expected = header.DataBytes();
  const uint64_t onDisk = FileSize(path);
  const bool compressed = gzdirect(file.get()) == 0;
  const uint64_t offset = static_cast<uint64_t>(h.voxOffset);
  // Deflate compresses at most about 1032:1, so a small .nii.gz cannot hold a large volume.
  if ((!compressed && onDisk < offset + expected) || (compressed && (offset + expected) / 1032 > onDisk + 64))
  {
    throw InputError(path, "holds too little data for dim x datatype (" + std::to_string(expected) +
        " bytes of voxels): truncated file or wrong dim");
  }
  std::vector<char> skip(offset - HeaderBytes);
  ReadExactly(file.get(), skip.data(), skip.size(), path, "the NIfTI extension area");
  return MakeCTVolume(header, path, [&](char* voxels, uint64_t count) { ReadExactly(file.get(), voxels, count, path, "the voxel data"); });
}

} // namespace xp
