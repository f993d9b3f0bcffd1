#include "xpVolumeIO.h"

#include "vtkXPDICOMCTReader.h"
#include "xpError.h"
#include "xpTIFF.h"
#include "xpVolumeFormats.h"

#include <vtkCallbackCommand.h>
#include <vtkImageData.h>
#include <vtkNew.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

namespace
{

bool EndsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
    [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
}

/** A TIFF stack as an HFS CT whose index axes are the room's (xpVolumeIO.h). */
CTVolume ReadTIFFVolume(const std::string& path, const std::array<double, 3>& voxelSizeMM)
{
  if (!(voxelSizeMM[0] > 0.0))
    throw InputError("--voxel-size", "is required for a TIFF volume (" + path + "): x,y,z in mm");
  const DecodedTIFF tiff = DecodeTIFF(path);
  if (tiff.pages.size() < 2)
    throw InputError(path, "one page: a volume needs at least two (a single X-ray is given with --xray)");
  VolumeHeader header;
  header.dimensions = { tiff.columns, tiff.rows, static_cast<int64_t>(tiff.pages.size()) };
  header.spacing = Eigen::Vector3d(voxelSizeMM[0], voxelSizeMM[1], voxelSizeMM[2]);
  // LPS directions of the index axes that HFS takes to Room x, y, z (xpPose.h: X = x, Y = z, Z = -y).
  header.direction << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  header.type = VoxelType::UInt16;
  header.intercept = -1000.0;
  CheckVolumeHeader(header, path, { "page size and count", "--voxel-size", "origin", "direction" });
  size_t page = 0, offset = 0; // bytes already given of the current page
  return MakeCTVolume(header, path, [&](char* to, uint64_t count)
    {
      while (count > 0)
      {
        const std::vector<uint16_t>& pixels = tiff.pages[page];
        const size_t bytes = std::min<uint64_t>(count, pixels.size() * 2 - offset);
        std::memcpy(to, reinterpret_cast<const char*>(pixels.data()) + offset, bytes);
        to += bytes;
        count -= bytes;
        offset += bytes;
        if (offset == pixels.size() * 2)
          ++page, offset = 0;
      }
    });
}

} // namespace

bool IsTIFFVolumePath(const std::string& path)
{
  return EndsWith(path, ".tif") || EndsWith(path, ".tiff");
}

std::array<double, 3> ParseVoxelSize(const std::string& text, const std::string& option)
{
  std::array<double, 3> size{ 0, 0, 0 };
  if (text.empty())
    return size;
  std::stringstream in(text);
  std::string item;
  int n = 0;
  while (std::getline(in, item, ','))
  {
    char* end = nullptr;
    const double value = std::strtod(item.c_str(), &end);
    if (n >= 3 || item.empty() || *end != '\0' || !(value > 0.0 && value <= 100.0))
      throw InputError(option, "expected three voxel sizes x,y,z in mm (each above 0, at most 100), got '" + text + "'");
    size[n++] = value;
  }
  if (n != 3)
    throw InputError(option, "expected three voxel sizes x,y,z in mm, got '" + text + "'");
  return size;
}

CTVolume ReadCTVolume(const std::string& path, const std::string& seriesUID, const std::array<double, 3>& voxelSizeMM)
{
  struct stat status;
  if (stat(path.c_str(), &status) != 0)
  {
    throw InputError(path, "no such file or folder");
  }
  const bool tiff = IsTIFFVolumePath(path);
  if (voxelSizeMM[0] > 0.0 && !tiff)
  {
    throw InputError("--voxel-size", "is for TIFF volumes only: " + path + " carries its own voxel size");
  }
  if (tiff)
  {
    return ReadTIFFVolume(path, voxelSizeMM);
  }
  if (S_ISDIR(status.st_mode))
  {
    vtkNew<vtkXPDICOMCTReader> reader;
    reader->SetDirectoryName(path.c_str());
    reader->SetSeriesInstanceUID(seriesUID.c_str());
    // The error text is rethrown below; a silent observer keeps VTK from printing it too.
    vtkNew<vtkCallbackCommand> silent;
    reader->AddObserver(vtkCommand::ErrorEvent, silent);
    reader->Update();
    if (!reader->GetErrorText().empty())
    {
      throw InputError(reader->GetErrorText());
    }
    CTVolume volume;
    volume.image = reader->GetOutput();
    volume.patientPosition = reader->GetPatientPosition();
    return volume;
  }
  if (EndsWith(path, ".mha") || EndsWith(path, ".mhd"))
  {
    return ReadMetaImage(path);
  }
  if (EndsWith(path, ".nii") || EndsWith(path, ".nii.gz"))
  {
    return ReadNIfTI(path);
  }
  throw InputError(path, "unknown CT format (expected a DICOM folder, .mha/.mhd, .nii/.nii.gz or a .tif stack)");
}

} // namespace xp
