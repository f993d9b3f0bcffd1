/**
 * @file xpTIFF.h
 * @brief TIFF decoding with libtiff under xpose's own error handling.
 *
 * X-rays from research systems (biplane videoradiography, image intensifiers) and bone volumes
 * cut from a CT come as TIFF: one grey page, or a stack of pages. Every libtiff error, a cut
 * file, a page of another size or depth than the first, becomes an xp::InputError naming the
 * file and the page.
 */
#ifndef xpTIFF_h
#define xpTIFF_h

#include "vtkXPFileFormatsModule.h"

#include <cstdint>
#include <string>
#include <vector>

namespace xp
{

struct VTKXPFILEFORMATS_EXPORT DecodedTIFF
{
  int columns = 0, rows = 0;
  int bitsPerSample = 0; ///< 8 or 16
  /** Per page (the file's order), rows top first; grey levels as stored, except that a
   *  white-is-zero page is turned round (max - value), so that larger is brighter in all. */
  std::vector<std::vector<uint16_t>> pages;
};

/** True when the file starts as a TIFF does (II*\0 or MM\0*). */
VTKXPFILEFORMATS_EXPORT bool IsTIFF(const std::string& path);

/**
 * Decodes every page of a grey (one sample per pixel), 8- or 16-bit unsigned TIFF; images larger
 * than 16384 pixels a side, or more than 4096 pages, are refused.
 */
VTKXPFILEFORMATS_EXPORT DecodedTIFF DecodeTIFF(const std::string& path);

} // namespace xp

#endif
