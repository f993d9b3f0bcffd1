/**
 * @file xpPNG.h
 * @brief PNG decoding under xpose's own error handling (module-private).
 *
 * VTK's PNG reader crashed (SIGSEGV in png_destroy_read_struct) on a cut or damaged file, so
 * PNGs are decoded here with libpng directly: every libpng error, a short file, a damaged
 * chunk or an image header larger than its data, becomes an xp::InputError naming the file.
 */
#ifndef xpPNG_h
#define xpPNG_h

#include <cstdint>
#include <string>
#include <vector>

namespace xp
{

struct DecodedPNG
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
DecodedPNG DecodePNG(const std::string& path);

} // namespace xp

#endif
