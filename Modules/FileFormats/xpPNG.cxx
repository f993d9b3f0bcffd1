#include "xpPNG.h"

#include "xpError.h"

#include <png.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <memory>

namespace xp
{

namespace
{

constexpr png_uint_32 MaxSide = 16384;

struct ErrorText
{
  char text[200] = "";
};

void OnError(png_structp png, png_const_charp message)
{
  auto* error = static_cast<ErrorText*>(png_get_error_ptr(png));
  std::snprintf(error->text, sizeof(error->text), "%s", message ? message : "libpng error");
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp)
{
  // Warnings (an unknown ancillary chunk, an sRGB profile) do not affect the pixels.
}

/**
 * The libpng calls, between one setjmp and the errors that jump back to it. Only memory behind
 * `out` and `error` changes after setjmp, so nothing is left indeterminate by a longjmp, and no
 * C++ object is created or destroyed in this frame after it.
 */
bool Decode(png_structp png, png_infop info, uint64_t fileBytes, DecodedPNG* out, std::vector<uint8_t>* bytes,
  std::vector<png_bytep>* rows, ErrorText* error)
{
  if (setjmp(png_jmpbuf(png)))
  {
    return false;
  }
  png_set_user_limits(png, MaxSide, MaxSide);
  png_set_benign_errors(png, 0); // "not enough image data" and the like are errors here
  png_read_info(png, info);
  out->columns = static_cast<int>(png_get_image_width(png, info));
  out->rows = static_cast<int>(png_get_image_height(png, info));
  out->bitDepth = png_get_bit_depth(png, info);
  out->colorType = png_get_color_type(png, info);
  png_set_expand(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  out->channels = png_get_channels(png, info);
  const size_t rowBytes = png_get_rowbytes(png, info);
  // Deflate compresses at most about 1032:1: a header that declares more pixels than the file
  // could hold is refused before a buffer of its size is allocated.
  if (static_cast<uint64_t>(rowBytes) * static_cast<uint64_t>(out->rows) > 1100 * fileBytes + (1 << 16))
  {
    std::snprintf(error->text, sizeof(error->text), "the header declares %dx%d pixels, more than a %llu-byte file can hold",
      out->columns, out->rows, static_cast<unsigned long long>(fileBytes));
    return false;
  }
  bytes->resize(rowBytes * static_cast<size_t>(out->rows));
  rows->resize(static_cast<size_t>(out->rows));
  for (int r = 0; r < out->rows; ++r)
  {
    (*rows)[static_cast<size_t>(r)] = bytes->data() + rowBytes * static_cast<size_t>(r);
  }
  png_read_image(png, rows->data());
  png_read_end(png, nullptr); // checks the chunks after the image through IEND
  return true;
}

struct FileCloser
{
  void operator()(FILE* file) const { std::fclose(file); }
};

/** The libpng calls of EncodePNG, between one setjmp and the errors that jump back to it. */
bool Encode(
  png_structp png, png_infop info, FILE* file, const std::vector<png_bytep>& rows, int columns, int channels, int bitDepth)
{
  if (setjmp(png_jmpbuf(png)))
  {
    return false;
  }
  static const int colourTypes[] = { PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
    PNG_COLOR_TYPE_RGB_ALPHA };
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(columns), static_cast<png_uint_32>(rows.size()), bitDepth,
    colourTypes[channels - 1], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  // Fastest deflate: DRRs and masks are written on every run, and level 1 takes a third of the
  // time of the default for files about a third larger.
  png_set_compression_level(png, 1);
  png_write_info(png, info);
  if (bitDepth == 16)
  {
    png_set_swap(png); // PNG stores 16-bit samples big-endian; every supported host is little-endian
  }
  png_write_image(png, const_cast<png_bytepp>(rows.data()));
  png_write_end(png, nullptr);
  return true;
}


} // namespace

bool DecodedPNG::IsGrey16() const
{
  return this->colorType == PNG_COLOR_TYPE_GRAY && this->bitDepth == 16;
}

DecodedPNG DecodePNG(const std::string& path)
{
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file)
  {
    throw InputError(path, "cannot open the PNG file");
  }
  unsigned char signature[8] = {};
  if (std::fread(signature, 1, 8, file.get()) != 8 || png_sig_cmp(signature, 0, 8) != 0)
  {
    throw InputError(path, "not a PNG file (no PNG signature)");
  }
  ErrorText error;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, OnError, OnWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info)
  {
    png_destroy_read_struct(&png, nullptr, nullptr);
    throw Error(path, "cannot start libpng");
  }
  png_init_io(png, file.get());
  png_set_sig_bytes(png, 8);
  DecodedPNG image;
  std::vector<uint8_t> bytes;
  std::vector<png_bytep> rows;
  std::fseek(file.get(), 0, SEEK_END);
  const uint64_t fileBytes = static_cast<uint64_t>(std::max(0L, std::ftell(file.get())));
  std::fseek(file.get(), 8, SEEK_SET);
  const bool decoded = Decode(png, info, fileBytes, &image, &bytes, &rows, &error);
  png_destroy_read_struct(&png, &info, nullptr);
  if (!decoded)
  {
    throw InputError(path, std::string("damaged or truncated PNG (libpng: ") + error.text + ")");
  }
  // Samples as numbers: 16-bit PNG samples are big-endian.
  const size_t count = static_cast<size_t>(image.columns) * image.rows * image.channels;
  image.samples.resize(count);
  const bool wide = image.bitDepth == 16;
  for (size_t i = 0; i < count; ++i)
  {
    image.samples[i] = wide ? static_cast<uint16_t>(bytes[2 * i] << 8 | bytes[2 * i + 1]) : bytes[i];
  }
  return image;
}

void EncodePNG(const std::string& path, const void* topRow, std::ptrdiff_t rowStride, int columns, int rows, int channels,
  int bitDepth)
{
  if (columns < 1 || rows < 1 || channels < 1 || channels > 4 || (bitDepth != 8 && bitDepth != 16))
  {
    throw Error(path, "PNG needs at least one pixel, 1 to 4 channels and 8 or 16 bits");
  }
  std::vector<png_bytep> rowPointers(static_cast<size_t>(rows));
  for (int r = 0; r < rows; ++r)
  {
    rowPointers[static_cast<size_t>(r)] =
      static_cast<png_bytep>(const_cast<void*>(topRow)) + static_cast<std::ptrdiff_t>(r) * rowStride;
  }
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "wb"));
  if (!file)
  {
    throw Error(path, "cannot create the PNG file");
  }
  ErrorText error;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, OnError, OnWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info)
  {
    png_destroy_write_struct(&png, nullptr);
    throw Error(path, "cannot start libpng");
  }
  const bool encoded = Encode(png, info, file.get(), rowPointers, columns, channels, bitDepth);
  png_destroy_write_struct(&png, &info);
  const bool flushed = std::fflush(file.get()) == 0 && !std::ferror(file.get());
  if (!encoded || !flushed)
  {
    throw Error(path, std::string("cannot write the PNG file") + (encoded ? " (disk full?)" : std::string(" (libpng: ") + error.text + ")"));
  }
}

} // namespace xp
