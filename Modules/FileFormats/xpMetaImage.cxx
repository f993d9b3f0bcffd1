// MetaImage (.mha/.mhd) reading with every header field and the data length checked.
#include "xpError.h"
#include "xpVolumeFormats.h"

#include <zlib.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace xp
{

namespace
{

const std::array<std::string, 4> MetaFields{ "DimSize", "ElementSpacing", "Offset", "TransformMatrix" };
// A header is a few hundred bytes; anything far longer is not a MetaImage header.
constexpr size_t MaxHeaderBytes = 1 << 16;

/** The header's "Key = value" lines up to ElementDataFile, and where the data starts. */
struct MetaHeaderText
{
  std::map<std::string, std::string> fields;
  uint64_t dataOffset = 0; // for ElementDataFile = LOCAL
};

std::string Trim(const std::string& s)
{
  const size_t b = s.find_first_not_of(" \t\r");
  const size_t e = s.find_last_not_of(" \t\r");
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

MetaHeaderText ReadHeaderText(std::istream& in, const std::string& path)
{
  MetaHeaderText header;
  std::string line;
  uint64_t consumed = 0;
  while (std::getline(in, line))
  {
    consumed += line.size() + (in.eof() ? 0 : 1);
    if (consumed > MaxHeaderBytes)
    {
      throw InputError(path, "no ElementDataFile line in the first 64 KiB: not a MetaImage header");
    }
    const size_t equals = line.find('=');
    if (equals == std::string::npos)
    {
      if (Trim(line).empty())
        continue;
      throw InputError(path, "header line '" + Trim(line).substr(0, 40) + "' is not 'Key = value'");
    }
    const std::string key = Trim(line.substr(0, equals));
    header.fields[key] = Trim(line.substr(equals + 1));
    if (key == "ElementDataFile")
    {
      header.dataOffset = consumed;
      return header;
    }
  }
  throw InputError(path, "ElementDataFile: missing (the header ends without it)");
}

std::vector<double> Numbers(const MetaHeaderText& header, const std::string& key, size_t count, const std::string& path)
{
  const auto it = header.fields.find(key);
  if (it == header.fields.end())
  {
    return {};
  }
  std::istringstream words(it->second);
  std::vector<double> values;
  std::string word;
  while (words >> word)
  {
    char* end = nullptr;
    const double value = std::strtod(word.c_str(), &end);
    if (*end != '\0' || end == word.c_str() || !std::isfinite(value))
    {
      throw InputError(path, key + ": '" + word + "' is not a finite number");
    }
    values.push_back(value);
  }
  if (values.size() != count)
  {
    throw InputError(path, key + ": expected " + std::to_string(count) + " numbers, found " + std::to_string(values.size()));
  }
  return values;
}

bool Flag(const MetaHeaderText& header, const std::string& key, const std::string& path)
{
  const auto it = header.fields.find(key);
  if (it == header.fields.end())
    return false;
  if (it->second == "True" || it->second == "true" || it->second == "1")
    return true;
  if (it->second == "False" || it->second == "false" || it->second == "0")
    return false;
  throw InputError(path, key + ": expected True or False, found '" + it->second + "'");
}

VoxelType ElementType(const std::string& name, const std::string& path)
{
  static const std::map<std::string, VoxelType> types{ { "MET_CHAR", VoxelType::Int8 }, { "MET_UCHAR", VoxelType::UInt8 },
    { "MET_SHORT", VoxelType::Int16 }, { "MET_USHORT", VoxelType::UInt16 }, { "MET_INT", VoxelType::Int32 },
    { "MET_UINT", VoxelType::UInt32 }, { "MET_LONG", VoxelType::Int32 }, { "MET_ULONG", VoxelType::UInt32 },
    { "MET_FLOAT", VoxelType::Float32 }, { "MET_DOUBLE", VoxelType::Float64 } };
  const auto it = types.find(name);
  if (it == types.end())
  {
    throw InputError(path, "ElementType: '" + name + "' is not supported (MET_CHAR ... MET_DOUBLE, one channel)");
  }
  return it->second;
}

/** Inflates a zlib (or gzip) stream piece by piece into exactly the bytes the header declares;
 *  a stream that ends early, is corrupt or holds more is an error. */
class Inflater
{
public:
  Inflater(const std::vector<char>& compressed, uint64_t expected, const std::string& path)
    : Expected(expected)
    , Path(path)
  {
    if (inflateInit2(&this->Stream, 15 + 32) != Z_OK)
    {
      throw Error(path, "cannot start zlib");
    }
    this->Stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data()));
    this->InLeft = compressed.size();
  }
  ~Inflater() { inflateEnd(&this->Stream); }
  Inflater(const Inflater&) = delete;
  Inflater& operator=(const Inflater&) = delete;

  /** The next `count` bytes of the inflated data. */
  void Read(char* out, uint64_t count)
  {
    this->Stream.next_out = reinterpret_cast<Bytef*>(out);
    while (count > 0)
    {
      // zlib counts in 32-bit chunks; feed it piecewise so volumes over 4 GiB would work too.
      const uInt outChunk = static_cast<uInt>(std::min<uint64_t>(count, 1u << 30));
      const uInt produced = this->Step(outChunk);
      count -= produced;
      if (count > 0 && (this->Status != Z_OK || produced == 0))
      {
        this->CheckStatus();
        throw InputError(this->Path, "compressed data ends after " + std::to_string(this->Produced) + " of the " +
            std::to_string(this->Expected) + " bytes that DimSize and ElementType need (truncated file)");
      }
    }
  }

  /** After the last Read: the stream must end here. */
  void CheckEnd()
  {
    while (this->Status == Z_OK)
    {
      const uint64_t inBefore = this->InLeft;
      unsigned char extra = 0;
      this->Stream.next_out = &extra;
      if (this->Step(1) > 0 || (this->Status == Z_OK && this->InLeft == inBefore))
        break; // more output, or no progress: the stream does not end where the header says
    }
    this->CheckStatus();
    if (this->Status != Z_STREAM_END)
    {
      throw InputError(this->Path, "compressed data holds more than DimSize and ElementType declare");
    }
  }

private:
  /** One inflate call with room for `room` bytes; returns the bytes produced. */
  uInt Step(uInt room)
  {
    const uInt inChunk = static_cast<uInt>(std::min<uint64_t>(this->InLeft, 1u << 30));
    this->Stream.avail_in = inChunk;
    this->Stream.avail_out = room;
    this->Status = inflate(&this->Stream, Z_NO_FLUSH);
    this->InLeft -= inChunk - this->Stream.avail_in;
    const uInt produced = room - this->Stream.avail_out;
    this->Produced += produced;
    return produced;
  }

  void CheckStatus() const
  {
    // Z_BUF_ERROR: no progress was possible, the input ended first.
    if (this->Status != Z_STREAM_END && this->Status != Z_OK && this->Status != Z_BUF_ERROR)
    {
      throw InputError(this->Path,
        std::string("compressed data is corrupt (zlib: ") + (this->Stream.msg ? this->Stream.msg : "error") + ")");
    }
  }

  z_stream Stream{};
  uint64_t InLeft = 0;
  uint64_t Produced = 0;
  const uint64_t Expected;
  const std::string Path;
  int Status = Z_OK;
};

/** The volume's size, spacing, placement and voxel type from a MetaImage header, checked. */
VolumeHeader MetaVolumeHeader(const MetaHeaderText& text, const std::string& path)
{
  const auto it = text.fields.find("ElementType");
  const std::string elementType = it == text.fields.end() ? std::string() : it->second;
  VolumeHeader header;
  const std::vector<double> dims = Numbers(text, "DimSize", 3, path);
  if (dims.empty())
  {
    throw InputError(path, "DimSize: missing");
  }
  for (int a = 0; a < 3; ++a)
  {
    if (dims[a] != std::floor(dims[a]) || dims[a] < 1 || dims[a] > 1e9)
    {
      throw InputError(path, "DimSize: expected three whole numbers of at least 1");
    }
    header.dimensions[a] = static_cast<int64_t>(dims[a]);
  }
  std::vector<double> spacing = Numbers(text, "ElementSpacing", 3, path);
  if (spacing.empty())
    spacing = Numbers(text, "ElementSize", 3, path);
  if (!spacing.empty())
    header.spacing = Eigen::Vector3d(spacing[0], spacing[1], spacing[2]);
  for (const char* key : { "Offset", "Position", "Origin" })
  {
    const std::vector<double> origin = Numbers(text, key, 3, path);
    if (!origin.empty())
      header.origin = Eigen::Vector3d(origin[0], origin[1], origin[2]);
  }
  for (const char* key : { "TransformMatrix", "Rotation", "Orientation" })
  {
    // ITK writes axis i as the i-th triple, in LPS.
    const std::vector<double> m = Numbers(text, key, 9, path);
    for (size_t k = 0; k < m.size(); ++k)
      header.direction(k % 3, k / 3) = m[k];
  }
  header.type = ElementType(elementType, path);
  header.bigEndian = Flag(text, "BinaryDataByteOrderMSB", path) || Flag(text, "ElementByteOrderMSB", path);
  CheckVolumeHeader(header, path, MetaFields);
  return header;
}

} // namespace

CTVolume ReadMetaImage(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
  {
    throw InputError(path, "cannot open the MetaImage file");
  }
  const MetaHeaderText text = ReadHeaderText(in, path);
  const auto field = [&](const std::string& key) {
    const auto it = text.fields.find(key);
    return it == text.fields.end() ? std::string() : it->second;
  };
  if (!field("ObjectType").empty() && field("ObjectType") != "Image")
  {
    throw InputError(path, "ObjectType: '" + field("ObjectType") + "' is not Image");
  }
  if (field("NDims") != "3")
  {
    throw InputError(path, "NDims: '" + field("NDims") + "', a CT volume needs 3");
  }
  if (!field("ElementNumberOfChannels").empty() && field("ElementNumberOfChannels") != "1")
  {
    throw InputError(path, "ElementNumberOfChannels: a CT volume has one channel");
  }
  if (!field("BinaryData").empty() && !Flag(text, "BinaryData", path))
  {
    throw InputError(path, "BinaryData: text (ASCII) voxel data is not supported");
  }

  const VolumeHeader header = MetaVolumeHeader(text, path);

  // The voxel data: after the header (LOCAL) or in a file beside it.
  const std::string dataFile = field("ElementDataFile");
  std::string dataPath = path;
  uint64_t offset = text.dataOffset;
  if (dataFile != "LOCAL" && dataFile != "Local" && dataFile != "local")
  {
    if (dataFile.empty() || dataFile == "LIST" || dataFile.find('%') != std::string::npos)
    {
      throw InputError(path, "ElementDataFile: '" + dataFile + "': lists and file patterns are not supported");
    }
    const size_t slash = path.find_last_of('/');
    dataPath = dataFile[0] == '/' || slash == std::string::npos ? dataFile : path.substr(0, slash + 1) + dataFile;
    offset = 0;
  }
  const bool compressed = Flag(text, "CompressedData", path);
  const uint64_t expected = header.DataBytes();
  if (dataPath != path && !field("HeaderSize").empty())
  {
    // A data file with a header of its own: skip HeaderSize bytes, or (-1) take its last bytes.
    const std::vector<double> skip = Numbers(text, "HeaderSize", 1, path);
    if (skip[0] == -1 && !compressed)
      offset = FileSize(dataPath) > expected ? FileSize(dataPath) - expected : 0;
    else if (skip[0] >= 0 && skip[0] == std::floor(skip[0]) && skip[0] < 1e12)
      offset = static_cast<uint64_t>(skip[0]);
    else
      throw InputError(path, "HeaderSize: expected a whole number of bytes, or -1 for uncompressed data");
  }
  const uint64_t available = FileSize(dataPath) > offset ? FileSize(dataPath) - offset : 0;
  if (!compressed && available != expected)
  {
    throw InputError(dataPath, "holds " + std::to_string(available) + " bytes of voxel data; DimSize x ElementType (" +
        field("DimSize") + ", " + field("ElementType") + ") need " + std::to_string(expected) +
        (available < expected ? " (truncated file)" : " (DimSize smaller than the data)"));
  }
  if (compressed && expected / 1032 > available + 64)
  {
    // zlib cannot compress beyond about 1032:1: the data cannot hold what the header declares.
    throw InputError(dataPath, "holds " + std::to_string(available) + " compressed bytes, too few for DimSize x ElementType (" +
        std::to_string(expected) + " bytes)");
  }
  std::ifstream data(dataPath, std::ios::binary);
  if (!data || !data.seekg(static_cast<std::streamoff>(offset)))
  {
    throw InputError(dataPath, "cannot open the voxel data (ElementDataFile)");
  }
  if (!compressed)
  {
    return MakeCTVolume(header, path,
      [&](char* voxels, uint64_t count)
      {
        if (!data.read(voxels, static_cast<std::streamsize>(count)))
        {
          throw InputError(dataPath, "cannot read the voxel data");
        }
      });
  }
  std::vector<char> packed(available);
  if (!data.read(packed.data(), static_cast<std::streamsize>(available)))
  {
    throw InputError(dataPath, "cannot read the voxel data");
  }
  Inflater inflater(packed, expected, dataPath);
  CTVolume volume = MakeCTVolume(header, path, [&](char* voxels, uint64_t count) { inflater.Read(voxels, count); });
  inflater.CheckEnd();
  return volume;
}

} // namespace xp
