#include "xpDICOMStructure.h"

#include "xpError.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <strings.h>
#include <vector>

namespace xp
{

namespace
{

constexpr uint32_t UndefinedLength = 0xffffffffu;
constexpr int MaxDepth = 32;

constexpr uint32_t Tag(uint16_t group, uint16_t element)
{
  return (static_cast<uint32_t>(group) << 16) | element;
}

constexpr uint32_t ItemTag = Tag(0xfffe, 0xe000);
constexpr uint32_t ItemEndTag = Tag(0xfffe, 0xe00d);
constexpr uint32_t SequenceEndTag = Tag(0xfffe, 0xe0dd);
constexpr uint32_t PixelDataTag = Tag(0x7fe0, 0x0010);

std::string TagText(uint32_t tag)
{
  char text[16];
  std::snprintf(text, sizeof(text), "(%04X,%04X)", tag >> 16, tag & 0xffff);
  return text;
}

/** Explicit VRs whose length field is 4 bytes after 2 reserved ones (PS3.5 7.1.2). */
bool HasLongLength(const char vr[2])
{
  static const char* const longVRs[] = { "OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV" };
  for (const char* v : longVRs)
  {
    if (vr[0] == v[0] && vr[1] == v[1])
      return true;
  }
  return false;
}

class ElementWalker
{
public:
  ElementWalker(const std::vector<char>& bytes, const std::string& path)
    : Bytes(bytes)
    , Path(path)
  {
  }

  DICOMLayout Walk()
  {
    // Only DICOM Part 10 files: without the preamble and file meta information GDCM guesses the
    // encoding in a "compatibility" parser that asserts on damaged input.
    if (this->Bytes.size() < 132 || std::memcmp(this->Bytes.data() + 128, "DICM", 4) != 0)
    {
      throw InputError(this->Path, "not a DICOM Part 10 file (no 'DICM' preamble at byte 128)");
    }
    size_t pos = 132;
    // File meta information: group 0002, always explicit VR little endian.
    this->Explicit = true;
    int64_t groupLength = -1;
    size_t groupStart = 0;
    uint32_t previous = 0; // every meta tag is above (0000,0000)
    while (pos + 8 <= this->Bytes.size() && this->U16(pos) == 0x0002)
    {
      if (this->TagAt(pos) <= previous)
      {
        this->Fail(pos, this->TagAt(pos), "is out of order or repeated (after " + TagText(previous) + ")");
      }
      previous = this->TagAt(pos);
      pos = this->Element(pos, this->Bytes.size(), 0);
      if (this->LastTag == Tag(0x0002, 0x0000) && pos - this->LastValue == 4)
      {
        groupLength = this->U32(this->LastValue);
        groupStart = pos;
      }
      if (this->LastTag == Tag(0x0002, 0x0010))
      {
        this->Layout.transferSyntax = this->Text(this->LastValue, pos - this->LastValue);
      }
    }
    if (groupLength >= 0 && static_cast<uint64_t>(groupLength) != pos - groupStart)
    {
      throw InputError(this->Path, "corrupt DICOM: File Meta Information Group Length (0002,0000) = " +
          std::to_string(groupLength) + " where the group holds " + std::to_string(pos - groupStart) + " bytes");
    }
    const std::string& syntax = this->Layout.transferSyntax;
    if (syntax.empty())
    {
      throw InputError(this->Path, "Transfer Syntax UID (0002,0010) missing from the file meta information");
    }
    static const char* const native[] = { "1.2.840.10008.1.2", "1.2.840.10008.1.2.1", "1.2.840.10008.1.2.2" };
    static const char* const encapsulated[] = { "1.2.840.10008.1.2.4.50", "1.2.840.10008.1.2.4.51",
      "1.2.840.10008.1.2.4.57", "1.2.840.10008.1.2.4.70", "1.2.840.10008.1.2.4.80", "1.2.840.10008.1.2.4.81",
      "1.2.840.10008.1.2.4.90", "1.2.840.10008.1.2.4.91", "1.2.840.10008.1.2.5" };
    const auto listed = [&](const auto& list) {
      return std::find(std::begin(list), std::end(list), syntax) != std::end(list);
    };
    if (!listed(native) && !listed(encapsulated))
    {
      throw InputError(this->Path, "Transfer Syntax UID (0002,0010) = '" + syntax +
          "' is not supported (implicit/explicit VR, JPEG, JPEG-LS, JPEG 2000 or RLE)");
    }
    this->Explicit = syntax != native[0];
    this->BigEndian = syntax == native[2];
    this->Layout.encapsulated = listed(encapsulated);
    this->Elements(pos, this->Bytes.size(), 0, false);
    return this->Layout;
  }

private:
  /** One of the VRs of PS3.5 6.2: GDCM reads any other pair of letters its own way. */
  static bool IsVR(const char* vr)
  {
    static const char* const known[] = { "AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL", "IS", "LO", "LT", "OB",
      "OD", "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ", "SS", "ST", "SV", "TM", "UC", "UI", "UL", "UN", "UR", "US",
      "UT", "UV" };
    for (const char* v : known)
    {
      if (vr[0] == v[0] && vr[1] == v[1])
        return true;
    }
    return false;
  }

  uint16_t U16(size_t at) const
  {
    const auto* p = reinterpret_cast<const unsigned char*>(this->Bytes.data() + at);
    return this->BigEndian ? static_cast<uint16_t>(p[0] << 8 | p[1]) : static_cast<uint16_t>(p[1] << 8 | p[0]);
  }

  uint32_t U32(size_t at) const
  {
    const uint32_t a = this->U16(at), b = this->U16(at + 2);
    return this->BigEndian ? (a << 16 | b) : (b << 16 | a);
  }

  uint32_t TagAt(size_t at) const { return Tag(this->U16(at), this->U16(at + 2)); }

  std::string Text(size_t at, size_t length) const
  {
    std::string text(this->Bytes.data() + at, length);
    while (!text.empty() && (text.back() == '\0' || text.back() == ' '))
      text.pop_back();
    return text;
  }

  [[noreturn]] void Fail(size_t at, uint32_t tag, const std::string& what) const
  {
    throw InputError(this->Path, "corrupt or truncated DICOM: element " + TagText(tag) + " at byte " + std::to_string(at) +
        " " + what);
  }

  /** Reads one element at `pos` inside [pos, end); returns the position after it. */
  size_t Element(size_t pos, size_t end, int depth)
  {
    if (end - pos < 8)
    {
      this->Fail(pos, 0, "is cut short (" + std::to_string(end - pos) + " bytes left)");
    }
    const uint32_t tag = this->TagAt(pos);
    uint32_t length = 0;
    size_t header = 8;
    bool sequence = false;
    if (this->Explicit && (tag >> 16) != 0xfffe)
    {
      const char* vr = this->Bytes.data() + pos + 4;
      if (!IsVR(vr))
      {
        this->Fail(pos, tag, "has no valid VR ('" + std::string(vr, 2) + "')");
      }
      if (HasLongLength(vr))
      {
        if (end - pos < 12)
        {
          this->Fail(pos, tag, "is cut short inside its header");
        }
        length = this->U32(pos + 8);
        header = 12;
        sequence = vr[0] == 'S' && vr[1] == 'Q';
      }
      else
      {
        length = this->U16(pos + 6);
      }
    }
    else
    {
      length = this->U32(pos + 4);
    }
    const size_t value = pos + header;
    this->LastTag = tag;
    this->LastValue = value;
    if (length == UndefinedLength)
    {
      if (tag == PixelDataTag)
      {
        this->Layout.hasPixelData = this->Layout.hasPixelData || depth == 0;
        return this->Items(value, end, depth + 1, true, true);
      }
      return this->Items(value, end, depth + 1, true, false);
    }
    if (length > end - value)
    {
      this->Fail(pos, tag, "declares " + std::to_string(length) + " bytes where " + std::to_string(end - value) + " remain");
    }
    // Implicit VR has no SQ marker: a value that opens with an item is walked as a sequence.
    const bool looksLikeItems = !this->Explicit && length >= 8 && this->TagAt(value) == ItemTag;
    if (sequence || looksLikeItems)
    {
      this->Items(value, value + length, depth + 1, false, false);
    }
    if (depth == 0)
    {
      this->Record(tag, value, length);
    }
    return value + length;
  }

  /** Walks elements until `end`, or until an item delimiter when `untilItemEnd`. */
  size_t Elements(size_t pos, size_t end, int depth, bool untilItemEnd)
  {
    // A data set holds each tag once, in ascending order. GDCM keeps the first of repeated
    // tags, so a repeat could show it other values than this walk checked.
    uint32_t previous = 0; // no data element has tag (0000,0000)
    while (pos < end)
    {
      if (end - pos >= 8 && this->TagAt(pos) == ItemEndTag)
      {
        if (!untilItemEnd)
        {
          this->Fail(pos, ItemEndTag, "ends an item that was never opened");
        }
        return pos + 8;
      }
      const uint32_t tag = end - pos >= 4 ? this->TagAt(pos) : 0;
      if (tag <= previous)
      {
        this->Fail(pos, tag, "is out of order or repeated (after " + TagText(previous) + ")");
      }
      previous = tag;
      pos = this->Element(pos, end, depth);
    }
    if (untilItemEnd)
    {
      this->Fail(pos, ItemEndTag, "is missing: an item of undefined length is not terminated");
    }
    return pos;
  }

  /** Walks the items of a sequence (or pixel data fragments) in [pos, end). */
  size_t Items(size_t pos, size_t end, int depth, bool undefinedLength, bool fragments)
  {
    if (depth > MaxDepth)
    {
      this->Fail(pos, 0, "is nested more than " + std::to_string(MaxDepth) + " sequences deep");
    }
    while (pos < end)
    {
      if (end - pos < 8)
      {
        this->Fail(pos, ItemTag, "is cut short (" + std::to_string(end - pos) + " bytes left)");
      }
      const uint32_t tag = this->TagAt(pos);
      const uint32_t length = this->U32(pos + 4);
      if (tag == SequenceEndTag && undefinedLength)
      {
        return pos + 8;
      }
      if (tag != ItemTag)
      {
        this->Fail(pos, tag, "stands where a sequence item was expected");
      }
      if (length == UndefinedLength)
      {
        if (fragments)
        {
          this->Fail(pos, tag, "is a pixel data fragment of undefined length");
        }
        pos = this->Elements(pos + 8, end, depth, true);
        continue;
      }
      if (length > end - pos - 8)
      {
        this->Fail(pos, tag, "declares " + std::to_string(length) + " bytes where " + std::to_string(end - pos - 8) + " remain");
      }
      if (!fragments)
      {
        this->Elements(pos + 8, pos + 8 + length, depth, false);
      }
      pos += 8 + length;
    }
    if (undefinedLength)
    {
      this->Fail(pos, SequenceEndTag, "is missing: a sequence of undefined length is not terminated");
    }
    return pos;
  }

  void Record(uint32_t tag, size_t value, uint32_t length)
  {
    const auto us = [&] { return length >= 2 ? this->U16(value) : 0u; };
    switch (tag)
    {
      case Tag(0x0028, 0x0010):
        this->Layout.rows = us();
        break;
      case Tag(0x0028, 0x0011):
        this->Layout.columns = us();
        break;
      case Tag(0x0028, 0x0100):
        this->Layout.bitsAllocated = us();
        break;
      case Tag(0x0028, 0x0101):
        this->Layout.bitsStored = us();
        break;
      case Tag(0x0028, 0x0102):
        this->Layout.highBit = us();
        break;
      case Tag(0x0028, 0x0103):
        this->Layout.pixelRepresentation = us();
        break;
      case Tag(0x0028, 0x0004):
        this->Layout.photometric = this->Text(value, std::min<size_t>(length, 16));
        break;
      case Tag(0x0008, 0x0010):
        this->Layout.recognitionCode = this->Text(value, std::min<size_t>(length, 64));
        break;
      case Tag(0x0028, 0x0002):
        this->Layout.samplesPerPixel = us();
        break;
      case Tag(0x0028, 0x0008):
      {
        const std::string text = this->Text(value, std::min<size_t>(length, 16));
        char* stop = nullptr;
        const long frames = std::strtol(text.c_str(), &stop, 10);
        this->Layout.frames = (stop && *stop == '\0' && frames > 0) ? static_cast<uint32_t>(std::min(frames, 1L << 20)) : 0;
        break;
      }
      case PixelDataTag:
        this->Layout.hasPixelData = true;
        this->Layout.pixelDataBytes = length;
        break;
      default:
        break;
    }
  }

  const std::vector<char>& Bytes;
  const std::string& Path;
  bool Explicit = true;
  bool BigEndian = false;
  uint32_t LastTag = 0;
  size_t LastValue = 0;
  DICOMLayout Layout;
};

} // namespace

uint64_t DICOMLayout::NativePixelBytes() const
{
  const uint64_t bits = static_cast<uint64_t>(this->rows) * this->columns * std::max(1u, this->samplesPerPixel) *
    this->bitsAllocated * std::max(1u, this->frames);
  return (bits + 7) / 8;
}

bool LooksLikeDICOM(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  char magic[132] = {};
  in.read(magic, sizeof(magic));
  const auto has = [&](const char* ext)
  {
    const size_t n = std::strlen(ext);
    return path.size() >= n && strcasecmp(path.c_str() + path.size() - n, ext) == 0;
  };
  return (in.gcount() == 132 && std::memcmp(magic + 128, "DICM", 4) == 0) || has(".dcm") || has(".ima");
}

DICOMLayout CheckDICOMStructure(const std::string& path)
{
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  if (!in)
  {
    throw InputError(path, "cannot open the DICOM file");
  }
  std::vector<char> bytes(static_cast<size_t>(std::max<std::streamoff>(0, in.tellg())));
  if (!in.seekg(0) || !in.read(bytes.data(), static_cast<std::streamsize>(bytes.size())))
  {
    throw InputError(path, "cannot read the DICOM file");
  }
  if (bytes.size() < 8)
  {
    throw InputError(path, "corrupt or truncated DICOM: only " + std::to_string(bytes.size()) + " bytes");
  }
  return ElementWalker(bytes, path).Walk();
}

void CheckPixelDataSize(const DICOMLayout& layout, const std::string& path, uint64_t maxPixels)
{
  if (!layout.hasPixelData)
  {
    throw InputError(path, "no Pixel Data (7FE0,0010)");
  }
  if (layout.rows == 0 || layout.columns == 0)
  {
    throw InputError(path, "Rows (0028,0010) / Columns (0028,0011) missing or zero");
  }
  if (layout.bitsAllocated != 8 && layout.bitsAllocated != 16 && layout.bitsAllocated != 32)
  {
    throw InputError(path, "Bits Allocated (0028,0100) = " + std::to_string(layout.bitsAllocated) + ": expected 8, 16 or 32");
  }
  if (layout.bitsStored < 1 || layout.bitsStored > layout.bitsAllocated || layout.highBit != layout.bitsStored - 1)
  {
    throw InputError(path, "Bits Stored (0028,0101) = " + std::to_string(layout.bitsStored) + " and High Bit (0028,0102) = " +
        std::to_string(layout.highBit) + " do not fit Bits Allocated = " + std::to_string(layout.bitsAllocated));
  }
  if (layout.samplesPerPixel != 1)
  {
    throw InputError(path, "Samples per Pixel (0028,0002) = " + std::to_string(layout.samplesPerPixel) + ": not a grey-scale image");
  }
  if (layout.photometric != "MONOCHROME1" && layout.photometric != "MONOCHROME2")
  {
    throw InputError(path, "Photometric Interpretation (0028,0004) = '" + layout.photometric +
        "': expected a grey-scale image (MONOCHROME1 or MONOCHROME2)");
  }
  if (layout.pixelRepresentation > 1)
  {
    throw InputError(path, "Pixel Representation (0028,0103) = " + std::to_string(layout.pixelRepresentation) +
        ": expected 0 (unsigned) or 1 (signed)");
  }
  const std::string& code = layout.recognitionCode;
  if (!code.empty() && code.rfind("ACR-NEMA", 0) != 0 && code.rfind("ACRNEMA", 0) != 0 && code.rfind("MIPS 2.0", 0) != 0)
  {
    throw InputError(path, "Recognition Code (0008,0010) = '" + code.substr(0, 16) + "' is not an ACR-NEMA code");
  }
  if (layout.frames == 0)
  {
    throw InputError(path, "Number of Frames (0028,0008) is not a positive integer");
  }
  const uint64_t pixels = static_cast<uint64_t>(layout.rows) * layout.columns;
  if (pixels > maxPixels)
  {
    throw InputError(path, "Rows x Columns = " + std::to_string(layout.rows) + " x " + std::to_string(layout.columns) +
        " exceeds the " + std::to_string(maxPixels) + "-pixel limit");
  }
  if (!layout.encapsulated && layout.pixelDataBytes < layout.NativePixelBytes())
  {
    throw InputError(path, "Pixel Data (7FE0,0010) holds " + std::to_string(layout.pixelDataBytes) +
        " bytes; Rows x Columns x Bits Allocated (" + std::to_string(layout.rows) + " x " + std::to_string(layout.columns) +
        " x " + std::to_string(layout.bitsAllocated) + ") need " + std::to_string(layout.NativePixelBytes()) +
        " (truncated file or wrong Rows/Columns)");
  }
}

} // namespace xp
