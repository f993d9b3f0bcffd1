/**
 * @file xpVolumeFormats.h
 * @brief xpose's own MetaImage and NIfTI-1 readers, and the checked volume header they share.
 *
 * VTK's readers ignore their decoders' errors: a file cut short or a header whose sizes exceed
 * the data gave a volume padded with zeros, which registered as `ok`. These readers check every
 * header field and the data length before anything is allocated, and refuse rather than repair.
 */
#ifndef xpVolumeFormats_h
#define xpVolumeFormats_h

#include "vtkXPFileFormatsModule.h"
#include "xpCTVolume.h"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace xp
{

enum class VoxelType
{
  Int8,
  UInt8,
  Int16,
  UInt16,
  Int32,
  UInt32,
  Float32,
  Float64
};

/** A volume's header, as read from a file, before its voxels are. */
struct VTKXPFILEFORMATS_EXPORT VolumeHeader
{
  std::array<int64_t, 3> dimensions{ 0, 0, 0 };
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();      ///< LPS mm of voxel (0, 0, 0)
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity(); ///< columns: LPS axis directions
  VoxelType type = VoxelType::Int16;
  bool bigEndian = false;
  double slope = 1.0, intercept = 0.0;

  int64_t VoxelCount() const { return this->dimensions[0] * this->dimensions[1] * this->dimensions[2]; }
  /** Bytes of voxel data the header declares. */
  uint64_t DataBytes() const;
};

VTKXPFILEFORMATS_EXPORT size_t VoxelBytes(VoxelType type);

/** Bytes in the file at `path` (0 when it cannot be read). */
VTKXPFILEFORMATS_EXPORT uint64_t FileSize(const std::string& path);

/**
 * Checks what a header declares: at least 1 x 1 x 2 voxels and no more than the voxel limit,
 * finite positive spacing, finite origin, finite unit direction columns that span 3D, finite
 * slope and intercept. Throws xp::InputError naming `path` and the field (`fields` maps the
 * checks to the format's own field names: dimensions, spacing, origin, direction).
 */
VTKXPFILEFORMATS_EXPORT void CheckVolumeHeader(const VolumeHeader& header, const std::string& path, const std::array<std::string, 4>& fields);

/**
 * Whether a volume's HU are kept as 16-bit integers (vtkShortArray) rather than floats: stored
 * integers of at most 16 bits, rescale slope 1 and a whole intercept. Their HU are then whole
 * numbers; the few that could fall outside -32768..32767 (padding below air, overflow above
 * any metal) are clamped to it. Half the memory of floats, and a CT is read and prepared for
 * ray casting in half the time.
 */
VTKXPFILEFORMATS_EXPORT bool KeepsWholeHU16(const VolumeHeader& header);

/**
 * Makes the HU image of a volume whose voxel bytes, as stored in the file, `readVoxels`
 * gives in order: each call writes the next `count` bytes to the pointer it is given, and the
 * calls add up to header.DataBytes(). Stored native floats are read straight into the image;
 * other types a few MiB at a time, converted and rescaled in parallel, so no copy of the whole
 * file is held. 16-bit HU when KeepsWholeHU16, float otherwise; float voxels that are not
 * finite or beyond +-1e6 HU are refused, naming `path`.
 */
VTKXPFILEFORMATS_EXPORT CTVolume MakeCTVolume(
  const VolumeHeader& header, const std::string& path, const std::function<void(char*, uint64_t)>& readVoxels);

VTKXPFILEFORMATS_EXPORT CTVolume ReadMetaImage(const std::string& path);
VTKXPFILEFORMATS_EXPORT CTVolume ReadNIfTI(const std::string& path);

} // namespace xp

#endif
