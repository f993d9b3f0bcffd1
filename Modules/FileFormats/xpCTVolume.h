/**
 * @file xpCTVolume.h
 * @brief A planning CT as read: HU voxels placed in LPS, and the patient's position on the couch.
 */
#ifndef xpCTVolume_h
#define xpCTVolume_h

#include "vtkXPFileFormatsModule.h"

#include <vtkSmartPointer.h>

#include <string>

class vtkImageData;

namespace xp
{

struct VTKXPFILEFORMATS_EXPORT CTVolume
{
  /** HU: 16-bit integers (VTK_SHORT) where the file stores integers of at most 16 bits with
   *  rescale slope 1 and a whole intercept (values beyond the 16-bit range clamped), float
   *  otherwise; index-to-physical (origin, spacing, DirectionMatrix) gives LPS mm. */
  vtkSmartPointer<vtkImageData> image;
  /** DICOM Patient Position; "HFS" for formats that do not carry one. */
  std::string patientPosition = "HFS";
};

} // namespace xp

#endif
