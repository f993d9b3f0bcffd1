/**
 * @file xpDICOMXRay.h
 * @brief Reads a projection X-ray stored as DICOM (DX, CR or RT Image) with its stored values (up to 16 bits; MONOCHROME1 inverted so that the open field is bright).
 *
 * Pixel data through GDCM (compressed syntaxes included). MONOCHROME1 (bright = attenuating) is
 * inverted so that, as in xpose's DRRs, bone is dark. Values are scaled from Bits Stored to 12
 * bits when more are stored. The geometry file stays the source of truth for the room geometry.
 */
#ifndef xpDICOMXRay_h
#define xpDICOMXRay_h

#include "vtkXPDICOMModule.h"

#include <vtkSmartPointer.h>

#include <string>

class vtkImageData;

namespace xp
{

/** The X-ray as unsigned short, its stored values (up to 16 bits), in VTK row order; throws
 *  xp::InputError naming the file. */
VTKXPDICOM_EXPORT vtkSmartPointer<vtkImageData> ReadXRayDICOM(const std::string& path);

/** An X-ray from a grey PNG, a grey one-page TIFF (8 or 16 bits; xpImageIO.h) or a DICOM
 *  DX/CR/RT Image file, chosen by content, values as stored. */
VTKXPDICOM_EXPORT vtkSmartPointer<vtkImageData> ReadXRayImage(const std::string& path);

} // namespace xp

#endif
