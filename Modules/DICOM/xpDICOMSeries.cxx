#include "xpDICOMSeries.h"

#include "xpDICOMDataSet.h"
#include "xpDICOMStructure.h"
#include "xpError.h"

#include <gdcmDirectory.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <type_traits>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

namespace xp
{

namespace
{

// Tags read from every header.
const gdcm::Tag Modality(0x0008, 0x0060);
const gdcm::Tag SeriesUID(0x0020, 0x000e);
const gdcm::Tag SeriesDescription(0x0008, 0x103e);
const gdcm::Tag PositionTag(0x0020, 0x0032);
const gdcm::Tag OrientationTag(0x0020, 0x0037);
const gdcm::Tag PixelSpacingTag(0x0028, 0x0030);
const gdcm::Tag RowsTag(0x0028, 0x0010);
const gdcm::Tag ColumnsTag(0x0028, 0x0011);
const gdcm::Tag PatientPositionTag(0x0018, 0x5100);
const gdcm::Tag GantryTiltTag(0x0018, 0x1120);
const gdcm::Tag FramesTag(0x0028, 0x0008);
const gdcm::Tag SamplesTag(0x0028, 0x0002);
const gdcm::Tag BitsAllocatedTag(0x0028, 0x0100);
const gdcm::Tag RescaleInterceptTag(0x0028, 0x1052);
const gdcm::Tag SOPClassTag(0x0008, 0x0016);
const gdcm::Tag SOPInstanceTag(0x0008, 0x0018);
const gdcm::Tag StudyUIDTag(0x0020, 0x000d);
const gdcm::Tag FrameOfReferenceTag(0x0020, 0x0052);
const gdcm::Tag RescaleSlopeTag(0x0028, 0x1053);
const gdcm::Tag PixelDataTag(0x7fe0, 0x0010);

// Bounds before allocation: 8192^2 pixels a slice, 2^30 voxels (4 GiB of float HU) a volume.
constexpr uint64_t MaxPixelsPerSlice = uint64_t(1) << 26;
constexpr uint64_t MaxVoxels = uint64_t(1) << 30;

struct SliceHeader
{
  std::string file;
  std::string modality, seriesUID, description, patientPosition;
  std::string sopClassUID, sopInstanceUID, studyUID, frameOfReferenceUID;
  Eigen::Vector3d position, rowDirection, columnDirection;
  Eigen::Vector2d pixelSpacing; // DICOM order: between rows, between columns
  int rows = 0, columns = 0, frames = 1, samples = 1;
  double tilt = 0.0;
  double along = 0.0; // position along the slice normal
  int bitsAllocated = 16;
  double slope = 1.0, intercept = 0.0; // Rescale Slope/Intercept, 1 and 0 when absent
};

std::string Trim(const std::string& s)
{
  const size_t b = s.find_first_not_of(" \t\r\n");
  const size_t e = s.find_last_not_of(" \t\r\n");
  std::string t = b == std::string::npos ? "" : s.substr(b, e - b + 1);
  t.erase(std::find(t.begin(), t.end(), '\0'), t.end());
  return t;
}

std::vector<double> Numbers(const std::string& text)
{
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, '\\'))
  {
    double value = 0.0;
    if (!dicom::ParseDecimal(item, value))
    {
      return {};
    }
    values.push_back(value);
  }
  return values;
}

/** Reads the header of one file; returns false for files that are not DICOM at all. */
bool ReadHeader(const std::string& file, SliceHeader& h)
{
  if (!LooksLikeDICOM(file))
  {
    return false;
  }
  // GDCM aborts on some damaged headers: it sees only files whose structure is intact.
  CheckPixelDataSize(CheckDICOMStructure(file), file, MaxPixelsPerSlice);
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  if (!reader.ReadUpToTag(PixelDataTag))
  {
    throw InputError(file, "unreadable DICOM file (corrupt or truncated header)");
  }
  gdcm::StringFilter sf;
  sf.SetFile(reader.GetFile());
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const auto get = [&](const gdcm::Tag& t) { return ds.FindDataElement(t) ? Trim(sf.ToString(t)) : std::string(); };
  h.file = file;
  h.modality = get(Modality);
  h.seriesUID = get(SeriesUID);
  h.description = get(SeriesDescription);
  h.patientPosition = get(PatientPositionTag);
  h.sopClassUID = get(SOPClassTag);
  h.sopInstanceUID = get(SOPInstanceTag);
  h.studyUID = get(StudyUIDTag);
  h.frameOfReferenceUID = get(FrameOfReferenceTag);
  const std::vector<double> ipp = Numbers(get(PositionTag)), iop = Numbers(get(OrientationTag)),
                            ps = Numbers(get(PixelSpacingTag));
  if (h.modality != "CT")
  {
    throw InputError(file, "not a CT image (Modality (0008,0060) = '" + h.modality + "')");
  }
  if (ipp.size() != 3)
  {
    throw InputError(file, "Image Position (Patient) (0020,0032) missing, malformed or not finite");
  }
  if (iop.size() != 6)
  {
    throw InputError(file, "Image Orientation (Patient) (0020,0037) missing, malformed or not finite");
  }
  if (ps.size() != 2 || !(ps[0] > 0) || !(ps[1] > 0))
  {
    throw InputError(file, "Pixel Spacing (0028,0030) missing, not positive or not finite");
  }
  if (Eigen::Vector3d(iop[0], iop[1], iop[2]).norm() < 0.5 || Eigen::Vector3d(iop[3], iop[4], iop[5]).norm() < 0.5)
  {
    throw InputError(file, "Image Orientation (Patient) (0020,0037) holds a zero direction");
  }
  h.position = { ipp[0], ipp[1], ipp[2] };
  h.rowDirection = Eigen::Vector3d(iop[0], iop[1], iop[2]).normalized();
  h.columnDirection = Eigen::Vector3d(iop[3], iop[4], iop[5]).normalized();
  h.pixelSpacing = { ps[0], ps[1] };
  h.rows = std::atoi(get(RowsTag).c_str());
  h.columns = std::atoi(get(ColumnsTag).c_str());
  if (h.rows <= 0 || h.columns <= 0)
  {
    throw InputError(file, "Rows (0028,0010) / Columns (0028,0011) missing");
  }
  const std::string frames = get(FramesTag), samples = get(SamplesTag), tilt = get(GantryTiltTag);
  h.frames = frames.empty() ? 1 : std::atoi(frames.c_str());
  h.samples = samples.empty() ? 1 : std::atoi(samples.c_str());
  h.tilt = tilt.empty() ? 0.0 : std::atof(tilt.c_str());
  const std::string bits = get(BitsAllocatedTag), slope = get(RescaleSlopeTag), intercept = get(RescaleInterceptTag);
  h.bitsAllocated = bits.empty() ? 16 : std::atoi(bits.c_str());
  h.slope = slope.empty() ? 1.0 : std::atof(slope.c_str());
  h.intercept = intercept.empty() ? 0.0 : std::atof(intercept.c_str());
  if (h.frames > 1)
  {
    throw InputError(file, "multi-frame CT (Number of Frames (0028,0008) = " + frames + ") is not supported");
  }
  if (h.samples != 1)
  {
    throw InputError(file, "Samples per Pixel (0028,0002) = " + samples + ": not a grey-scale CT image");
  }
  return true;
}

std::string ListSeries(const std::map<std::string, std::vector<SliceHeader>>& bySeries)
{
  std::string list;
  for (const auto& [uid, slices] : bySeries)
  {
    list += "\n  " + uid + " (" + std::to_string(slices.size()) + " files" +
      (slices.front().description.empty() ? "" : ", '" + slices.front().description + "'") + ")";
  }
  return list;
}

void CheckConsistent(const SliceHeader& first, const SliceHeader& h)
{
  if (h.rows != first.rows || h.columns != first.columns)
  {
    throw InputError(h.file, "image size " + std::to_string(h.columns) + "x" + std::to_string(h.rows) +
        " differs from " + first.file + " (" + std::to_string(first.columns) + "x" + std::to_string(first.rows) + ")");
  }
  if ((h.rowDirection - first.rowDirection).norm() > 1e-4 || (h.columnDirection - first.columnDirection).norm() > 1e-4)
  {
    throw InputError(h.file, "Image Orientation (Patient) differs from " + first.file);
  }
  if ((h.pixelSpacing - first.pixelSpacing).norm() > 1e-4)
  {
    throw InputError(h.file, "Pixel Spacing differs from " + first.file);
  }
}

double SliceSpacing(const std::vector<SliceHeader>& slices, const Eigen::Vector3d& normal)
{
  // The median gap is the series' spacing: a single missing or extra slice cannot shift it.
  std::vector<double> gaps;
  for (size_t k = 1; k < slices.size(); ++k)
  {
    gaps.push_back(slices[k].along - slices[k - 1].along);
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  const double spacing = gaps[gaps.size() / 2];
  for (size_t k = 1; k < slices.size(); ++k)
  {
    const double gap = slices[k].along - slices[k - 1].along;
    if (gap < 1e-3)
    {
      throw InputError(slices[k].file, "same slice position as " + slices[k - 1].file + " (duplicate slice)");
    }
    if (std::abs(gap - spacing) > 0.01 * spacing + 1e-3)
    {
      const bool missing = gap > 1.5 * spacing;
      throw InputError(slices[k].file,
        std::string(missing ? "missing slice" : "non-uniform slice spacing") + ": " + std::to_string(gap) +
          " mm after " + slices[k - 1].file + " where the series has " + std::to_string(spacing) + " mm");
    }
    // Positions must advance along the normal; an in-plane drift means a tilted gantry.
    const Eigen::Vector3d step = slices[k].position - slices[k - 1].position;
    if ((step - step.dot(normal) * normal).norm() > 0.01 * gap + 1e-3)
    {
      throw InputError(slices[k].file, "slice positions do not follow the slice normal (gantry tilt or sheared series)");
    }
  }
  return spacing;
}

/** HU from stored values: as float, or (16-bit HU) the stored integer plus the intercept,
 *  clamped to the 16-bit range. */
template <typename T>
void Rescale(const char* raw, size_t count, double slope, double intercept, float* out)
{
  const T* values = reinterpret_cast<const T*>(raw);
  for (size_t i = 0; i < count; ++i)
  {
    out[i] = static_cast<float>(values[i] * slope + intercept);
  }
}

template <typename T>
void Rescale(const char* raw, size_t count, double, double intercept, int16_t* out)
{
  const T* values = reinterpret_cast<const T*>(raw);
  const int64_t offset = static_cast<int64_t>(intercept);
  for (size_t i = 0; i < count; ++i)
  {
    out[i] = static_cast<int16_t>(std::clamp<int64_t>(values[i] + offset, -32768, 32767));
  }
}

template <typename Out>
void ReadSlices(const CTSeriesInfo& info, Out* hounsfield)
{
  const size_t sliceSize = static_cast<size_t>(info.columns) * info.rows;
  std::vector<char> raw;
  for (size_t k = 0; k < info.files.size(); ++k)
  {
    const std::string& file = info.files[k];
    gdcm::ImageReader reader;
    reader.SetFileName(file.c_str());
    if (!reader.Read())
    {
      throw InputError(file, "cannot read the pixel data (corrupt, truncated or unsupported encoding)");
    }
    const gdcm::Image& image = reader.GetImage();
    const unsigned int* dims = image.GetDimensions();
    if (dims[0] != static_cast<unsigned>(info.columns) || dims[1] != static_cast<unsigned>(info.rows))
    {
      throw InputError(file, "pixel data size differs from the series");
    }
    raw.resize(image.GetBufferLength());
    if (!image.GetBuffer(raw.data()))
    {
      throw InputError(file, "cannot decode the pixel data (truncated or corrupt)");
    }
    const gdcm::PixelFormat format = image.GetPixelFormat();
    if (format.GetSamplesPerPixel() != 1 || raw.size() < sliceSize * format.GetPixelSize())
    {
      throw InputError(file, "pixel data is shorter than Rows x Columns");
    }
    Out* out = hounsfield + k * sliceSize;
    const double slope = image.GetSlope(), intercept = image.GetIntercept();
    if (std::is_same<Out, int16_t>::value && (slope != 1.0 || intercept != std::floor(intercept) || format.GetBitsAllocated() > 16))
    {
      throw InputError(file, "Rescale Slope/Intercept or Bits Allocated of the pixel data differ from the header's");
    }
    switch (format.GetScalarType())
    {
      case gdcm::PixelFormat::INT16:
        Rescale<int16_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      case gdcm::PixelFormat::UINT16:
        Rescale<uint16_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      case gdcm::PixelFormat::INT32:
        Rescale<int32_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      case gdcm::PixelFormat::UINT32:
        Rescale<uint32_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      case gdcm::PixelFormat::INT8:
        Rescale<int8_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      case gdcm::PixelFormat::UINT8:
        Rescale<uint8_t>(raw.data(), sliceSize, slope, intercept, out);
        break;
      default:
        throw InputError(file, "unsupported pixel representation (Bits Allocated / Pixel Representation)");
    }
  }
}

} // namespace

CTSeriesInfo ScanCTSeries(const std::string& directory, const std::string& seriesUID)
{
  gdcm::Trace::WarningOff(); // problems are reported as xp::InputError naming the file
  gdcm::Directory dir;
  if (dir.Load(directory, false) == 0)
  {
    throw InputError(directory, "no files found (expected a folder with one DICOM CT series)");
  }
  std::map<std::string, std::vector<SliceHeader>> bySeries;
  for (const std::string& file : dir.GetFilenames())
  {
    const std::string base = file.substr(file.find_last_of('/') + 1);
    if (base.empty() || base[0] == '.' || base == "DICOMDIR")
    {
      continue;
    }
    SliceHeader h;
    if (ReadHeader(file, h))
    {
      bySeries[h.seriesUID].push_back(h);
    }
  }
  if (bySeries.empty())
  {
    throw InputError(directory, "no DICOM CT files found");
  }
  std::vector<SliceHeader> slices;
  if (!seriesUID.empty())
  {
    auto it = bySeries.find(seriesUID);
    if (it == bySeries.end())
    {
      throw InputError(directory, "series " + seriesUID + " not found; the folder holds:" + ListSeries(bySeries));
    }
    slices = it->second;
  }
  else if (bySeries.size() > 1)
  {
    throw InputError(directory, "several series in one folder; choose one with --series UID:" + ListSeries(bySeries));
  }
  else
  {
    slices = bySeries.begin()->second;
  }
  if (slices.size() < 2)
  {
    throw InputError(slices.front().file, "a CT volume needs at least two slices");
  }
  if (static_cast<uint64_t>(slices.front().rows) * slices.front().columns * slices.size() > MaxVoxels)
  {
    throw InputError(directory, std::to_string(slices.size()) + " slices of " + std::to_string(slices.front().columns) + "x" +
        std::to_string(slices.front().rows) + " exceed the " + std::to_string(MaxVoxels) + "-voxel limit");
  }

  const SliceHeader& first = slices.front();
  const Eigen::Vector3d normal = first.rowDirection.cross(first.columnDirection).normalized();
  if (std::abs(first.rowDirection.dot(first.columnDirection)) > 1e-3)
  {
    throw InputError(first.file, "Image Orientation (Patient) row and column directions are not orthogonal");
  }
  for (SliceHeader& h : slices)
  {
    CheckConsistent(first, h);
    if (!(std::abs(h.tilt) <= 1e-3))
    {
      throw InputError(h.file, "Gantry/Detector Tilt (0018,1120) = " + std::to_string(h.tilt) + " degrees is not supported");
    }
    h.along = normal.dot(h.position);
  }
  std::sort(slices.begin(), slices.end(), [](const SliceHeader& a, const SliceHeader& b) { return a.along < b.along; });

  CTSeriesInfo info;
  info.directory = directory;
  info.seriesInstanceUID = first.seriesUID;
  info.seriesDescription = first.description;
  info.patientPosition = first.patientPosition.empty() ? "HFS" : first.patientPosition;
  info.columns = first.columns;
  info.rows = first.rows;
  info.spacing = { first.pixelSpacing[1], first.pixelSpacing[0], SliceSpacing(slices, normal) };
  info.origin = slices.front().position;
  info.direction.col(0) = first.rowDirection;
  info.direction.col(1) = first.columnDirection;
  info.direction.col(2) = normal;
  info.wholeHU16 = true;
  info.studyInstanceUID = first.studyUID;
  info.frameOfReferenceUID = first.frameOfReferenceUID;
  info.sopClassUID = first.sopClassUID;
  for (const SliceHeader& h : slices)
  {
    info.files.push_back(h.file);
    info.sopInstanceUIDs.push_back(h.sopInstanceUID);
    info.wholeHU16 = info.wholeHU16 && h.bitsAllocated <= 16 && h.slope == 1.0 && h.intercept == std::floor(h.intercept) &&
      std::abs(h.intercept) <= 65536.0;
  }
  return info;
}

void ReadCTSeriesVoxels(const CTSeriesInfo& info, float* hounsfield)
{
  ReadSlices(info, hounsfield);
}

void ReadCTSeriesVoxels(const CTSeriesInfo& info, int16_t* hounsfield)
{
  if (!info.wholeHU16)
  {
    throw Error(info.directory, "internal: the series' HU are not whole 16-bit numbers");
  }
  ReadSlices(info, hounsfield);
}

} // namespace xp
