/**
 * @file xpDICOMXRay.h
 * @brief Reads a projection X-ray stored as DICOM (DX, CR or RT Image) as a 12-bit image.
 *
 * Pixel data through GDCM (compressed syntaxes included). MONOCHROME1 (bright = attenuating) is
 * inverted so that, as in xpose's DRRs, bone is dark. Values are scaled from Bits Stored to 12
 * bits when more are stored. The geometry file stays the source of truth for the room geometry.
 */
#ifndef xpDICOMXRay_h
#define xpDICOMXRay_h

#include "vtkXPIOModule.h"

#include <vtkSmartPointer.h>

#include <string>

class vtkImageData;

namespace xp
{

/** The X-ray as unsigned short 0..4095 in VTK row order; throws xp::InputError naming the file. */
VTKXPIO_EXPORT vtkSmartPointer<vtkImageData> ReadXRayDICOM(const std::string& path);

/** A 12-bit X-ray from a 16-bit PNG or a DICOM DX/CR/RT Image file, chosen by content. */
VTKXPIO_EXPORT vtkSmartPointer<vtkImageData> ReadXRayImage(const std::string& path);

} // namespace xp

#endif
