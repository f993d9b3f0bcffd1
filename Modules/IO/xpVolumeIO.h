/**
 * @file xpVolumeIO.h
 * @brief Loads a planning CT from a DICOM folder, a MetaImage (.mha/.mhd) or NIfTI (.nii/.nii.gz).
 */
#ifndef xpVolumeIO_h
#define xpVolumeIO_h

#include "vtkXPIOModule.h"

#include <vtkSmartPointer.h>

#include <string>

class vtkImageData;

namespace xp
{

struct VTKXPIO_EXPORT CTVolume
{
  /** HU: 16-bit integers (VTK_SHORT) where the file stores integers of at most 16 bits with
   *  rescale slope 1 and a whole intercept (values beyond the 16-bit range clamped), float
   *  otherwise; index-to-physical (origin, spacing, DirectionMatrix) gives LPS mm. */
  vtkSmartPointer<vtkImageData> image;
  /** DICOM Patient Position; "HFS" for formats that do not carry one. */
  std::string patientPosition = "HFS";
};

/**
 * Reads a CT. A folder is read as DICOM (`seriesUID` selects among several series); a file by
 * its extension. MetaImage direction (TransformMatrix) is taken as LPS, as ITK writes it; NIfTI
 * qform/sform (RAS) is converted to LPS. Throws xp::InputError naming the path.
 */
VTKXPIO_EXPORT CTVolume ReadCTVolume(const std::string& path, const std::string& seriesUID = "");

} // namespace xp

#endif
