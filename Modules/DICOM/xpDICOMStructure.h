/**
 * @file xpDICOMStructure.h
 * @brief A bounds check of a DICOM file's element structure, made before GDCM parses it.
 *
 * Debian's GDCM is built with assertions: a file cut inside its header aborts the process in
 * GDCM's parser, which no caller can catch. So every DICOM file xpose reads is walked here
 * first: each data element, nested sequences and pixel data fragments included, must lie
 * inside the file. The walk also returns the few image attributes needed to check the pixel
 * data against Rows x Columns before anything is allocated or decoded.
 */
#ifndef xpDICOMStructure_h
#define xpDICOMStructure_h

#include <cstdint>
#include <string>

namespace xp
{

/** What the walk learned about a file that passed it. */
struct DICOMLayout
{
  std::string transferSyntax; ///< (0002,0010)
  bool encapsulated = false;  ///< pixel data in fragments (compressed transfer syntax)
  bool hasPixelData = false;
  uint64_t pixelDataBytes = 0; ///< native pixel data length; 0 when encapsulated
  // Top-level Image Pixel attributes (0 when absent).
  uint32_t rows = 0, columns = 0, bitsAllocated = 0, bitsStored = 0, highBit = 0;
  uint32_t samplesPerPixel = 1; ///< (0028,0002), 1 when absent
  uint32_t pixelRepresentation = 0; ///< (0028,0103)
  std::string photometric;          ///< (0028,0004)
  std::string recognitionCode; ///< (0008,0010), retired ACR-NEMA; GDCM asserts on odd values
  uint32_t frames = 1; ///< Number of Frames (0028,0008), 1 when absent

  /** Bytes that native pixel data of these attributes needs. */
  uint64_t NativePixelBytes() const;
};

/** True for files that claim to be DICOM: the "DICM" mark at byte 128, or a .dcm/.ima name. */
bool LooksLikeDICOM(const std::string& path);

/**
 * Walks every data element of `path`. Throws xp::InputError naming the file, the element and
 * the byte offset when an element's length runs past the file (or its enclosing item), a
 * sequence or item is not terminated, a VR is not one of DICOM's, the file is not Part 10
 * (preamble, "DICM", file meta information with its group length), or the transfer syntax is
 * not one xpose reads (deflated, for one).
 */
DICOMLayout CheckDICOMStructure(const std::string& path);

/**
 * Checks the image attributes of a walked file before GDCM decodes it: Rows and Columns present
 * and within `maxPixels`, Bits Allocated 8, 16 or 32 (GDCM asserts on others), Bits Stored and
 * High Bit consistent with it, one sample of MONOCHROME1/2 (GDCM asserts on palettes without
 * their tables), Pixel Representation 0 or 1, and native pixel data at least as long as they need (GDCM pads
 * short pixel data silently). Throws xp::InputError naming the file and field.
 */
void CheckPixelDataSize(const DICOMLayout& layout, const std::string& path, uint64_t maxPixels);

} // namespace xp

#endif
