#include "xpTIFF.h"

#include "xpError.h"

#include <tiffio.h>

#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>

namespace xp
{

namespace
{

constexpr uint32_t MaxSide = 16384;
constexpr int MaxPages = 4096;

/** libtiff reports through global handlers: the last error of this thread is kept here and
 *  named in the exception, instead of being printed. */
thread_local std::string LastError;

void OnError(const char* module, const char* format, va_list arguments)
{
  char text[256];
  std::vsnprintf(text, sizeof(text), format, arguments);
  LastError = std::string(module ? module : "libtiff") + ": " + text;
}

void OnWarning(const char*, const char*, va_list)
{
  // Unknown tags and the like do not affect the pixels.
}

struct TIFFCloser
{
  void operator()(TIFF* tiff) const { TIFFClose(tiff); }
};

[[noreturn]] void Refuse(const std::string& path, int page, const std::string& what)
{
  throw InputError(path, (page > 0 ? "page " + std::to_string(page + 1) + ": " : std::string()) + what);
}

} // namespace

bool IsTIFF(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  unsigned char magic[4] = {};
  in.read(reinterpret_cast<char*>(magic), 4);
  return in.gcount() == 4 &&
    ((magic[0] == 'I' && magic[1] == 'I' && magic[2] == 42 && magic[3] == 0) ||
      (magic[0] == 'M' && magic[1] == 'M' && magic[2] == 0 && magic[3] == 42));
}

DecodedTIFF DecodeTIFF(const std::string& path)
{
  TIFFSetErrorHandler(OnError);
  TIFFSetWarningHandler(OnWarning);
  LastError.clear();
  std::unique_ptr<TIFF, TIFFCloser> tiff(TIFFOpen(path.c_str(), "r"));
  if (!tiff)
    Refuse(path, 0, "not a readable TIFF" + (LastError.empty() ? std::string() : " (" + LastError + ")"));
  DecodedTIFF out;
  int page = 0;
  do
  {
    if (page >= MaxPages)
      Refuse(path, 0, "more than " + std::to_string(MaxPages) + " pages");
    uint32_t width = 0, height = 0;
    uint16_t bits = 0, samples = 1, format = SAMPLEFORMAT_UINT, photometric = PHOTOMETRIC_MINISBLACK;
    if (!TIFFGetField(tiff.get(), TIFFTAG_IMAGEWIDTH, &width) || !TIFFGetField(tiff.get(), TIFFTAG_IMAGELENGTH, &height))
      Refuse(path, page, "no image width or length");
    TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_BITSPERSAMPLE, &bits);
    TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLESPERPIXEL, &samples);
    TIFFGetFieldDefaulted(tiff.get(), TIFFTAG_SAMPLEFORMAT, &format);
    TIFFGetField(tiff.get(), TIFFTAG_PHOTOMETRIC, &photometric);
    if (width == 0 || height == 0 || width > MaxSide || height > MaxSide)
      Refuse(path, page, std::to_string(width) + " x " + std::to_string(height) + " pixels: expected 1 to 16384 a side");
    if (samples != 1 || (photometric != PHOTOMETRIC_MINISBLACK && photometric != PHOTOMETRIC_MINISWHITE))
      Refuse(path, page, "expected one grey sample per pixel, found " + std::to_string(samples) + " sample(s), photometric " +
          std::to_string(photometric));
    if ((bits != 8 && bits != 16) || format != SAMPLEFORMAT_UINT)
      Refuse(path, page, std::to_string(bits) + "-bit samples of format " + std::to_string(format) +
          ": expected unsigned 8 or 16 bits");
    if (TIFFIsTiled(tiff.get()))
      Refuse(path, page, "a tiled TIFF: expected strips (write it with strips, as most tools do)");
    if (page == 0)
    {
      out.columns = static_cast<int>(width);
      out.rows = static_cast<int>(height);
      out.bitsPerSample = bits;
    }
    else if (static_cast<int>(width) != out.columns || static_cast<int>(height) != out.rows || bits != out.bitsPerSample)
      Refuse(path, page, std::to_string(width) + " x " + std::to_string(height) + " at " + std::to_string(bits) +
          " bits, unlike the first page's " + std::to_string(out.columns) + " x " + std::to_string(out.rows) + " at " +
          std::to_string(out.bitsPerSample));
    std::vector<uint16_t> pixels(static_cast<size_t>(width) * height);
    std::vector<uint8_t> line(static_cast<size_t>(TIFFScanlineSize(tiff.get())));
    if (line.size() < static_cast<size_t>(width) * (bits / 8))
      Refuse(path, page, "its rows are shorter than its width");
    const uint16_t top = bits == 8 ? 255 : 65535;
    for (uint32_t row = 0; row < height; ++row)
    {
      if (TIFFReadScanline(tiff.get(), line.data(), row) < 0)
        Refuse(path, page, "row " + std::to_string(row) + " cannot be read" + (LastError.empty() ? "" : " (" + LastError + ")"));
      uint16_t* to = pixels.data() + static_cast<size_t>(row) * width;
      for (uint32_t column = 0; column < width; ++column)
      {
        uint16_t v = line[column];
        if (bits == 16)
          std::memcpy(&v, line.data() + 2 * column, 2); // libtiff gives native byte order
        to[column] = photometric == PHOTOMETRIC_MINISWHITE ? static_cast<uint16_t>(top - v) : v;
      }
    }
    out.pages.push_back(std::move(pixels));
    ++page;
  } while (TIFFReadDirectory(tiff.get()));
  if (!LastError.empty())
    Refuse(path, page - 1, LastError);
  return out;
}

} // namespace xp
