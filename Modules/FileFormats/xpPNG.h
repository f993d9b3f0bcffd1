/**
 * @file xpPNG.h
 * @brief PNG decoding and encoding with libpng under xpose's own error handling.
 *
 * VTK's PNG reader crashed (SIGSEGV in png_destroy_read_struct) on a cut or damaged file, so
 * PNGs are decoded here with libpng directly: every libpng error, a short file, a damaged
 * chunk or an image header larger than its data, becomes an xp::InputError naming the file.
 * Encoding is here too, so that several images can be written at once: VTK's writer is a
 * pipeline object, and creating and destroying those on several threads is not safe.
 */
#ifndef xpPNG_h
#define xpPNG_h

#include "vtkXPFileFormatsModule.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace xp
{

struct VTKXPFILEFORMATS_EXPORT DecodedPNG
{
  int columns = 0, rows = 0;
  int bitDepth = 0;  ///< as stored (1, 2, 4, 8 or 16)
  int colorType = 0; ///< as stored (PNG_COLOR_TYPE_*)
  int channels = 0;  ///< of `samples`: palette and low bit depths are expanded, alpha kept
  /** Rows top first, channels interleaved; 8-bit samples are 0..255, 16-bit 0..65535. */
  std::vector<uint16_t> samples;

  bool IsGrey16() const;
};

/** Decodes the whole file; images larger than 16384 pixels a side are refused. */
VTKXPFILEFORMATS_EXPORT DecodedPNG DecodePNG(const std::string& path);

/**
 * Writes `rows` rows of `columns` pixels of `channels` (1 grey ... 4 RGBA) samples of
 * `bitDepth` 8 or 16 (native byte order), top row first, one row every `rowStride` bytes.
 * Thread-safe for distinct files. Throws xp::Error naming the file.
 */
VTKXPFILEFORMATS_EXPORT void EncodePNG(const std::string& path, const void* topRow, std::ptrdiff_t rowStride, int columns,
  int rows, int channels, int bitDepth);

} // namespace xp

#endif
