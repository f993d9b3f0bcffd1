/**
 * @file xpVolumeIO.h
 * @brief Loads a planning CT from whatever a user names: a DICOM folder, a MetaImage (.mha/.mhd),
 *        NIfTI (.nii/.nii.gz) or a TIFF stack (the file formats are read by Modules/FileFormats).
 */
#ifndef xpVolumeIO_h
#define xpVolumeIO_h

#include "vtkXPDICOMModule.h"
#include "xpCTVolume.h"

#include <array>
#include <string>

namespace xp
{

/**
 * Reads a CT. A folder is read as DICOM (`seriesUID` selects among several series); a file by
 * its extension. MetaImage direction (TransformMatrix) is taken as LPS, as ITK writes it; NIfTI
 * qform/sform (RAS) is converted to LPS.
 *
 * A TIFF stack (.tif/.tiff; 8- or 16-bit grey pages, as bone volumes cut from a CT come) carries
 * no voxel size: `voxelSizeMM` (x, y, z) gives it, and is refused for the other formats, which
 * carry their own. Columns run along x, rows along y, pages along z (the first page lowest);
 * its values are proportional to attenuation, 0 = air and 1000 = water (CT numbers + 1000), so
 * HU = value - 1000. Its axes are the room's at pose zero: it is placed as an HFS CT whose
 * LPS directions are those that HFS turns into Room x, y, z.
 *
 * Throws xp::InputError naming the path, or --voxel-size.
 */
VTKXPDICOM_EXPORT CTVolume ReadCTVolume(
  const std::string& path, const std::string& seriesUID = "", const std::array<double, 3>& voxelSizeMM = { 0, 0, 0 });

/** Whether ReadCTVolume reads `path` as a TIFF stack (.tif or .tiff, any case). */
VTKXPDICOM_EXPORT bool IsTIFFVolumePath(const std::string& path);

/** "0.4,0.4,0.625" -> three positive sizes (mm); "" -> zeros (none given). Throws xp::InputError
 *  naming `option`. */
VTKXPDICOM_EXPORT std::array<double, 3> ParseVoxelSize(const std::string& text, const std::string& option);

} // namespace xp

#endif
