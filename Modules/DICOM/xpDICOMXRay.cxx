#include "xpDICOMXRay.h"

#include "xpDICOMStructure.h"
#include "xpError.h"
#include "xpTIFF.h"
#include "xpImageIO.h"

#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTrace.h>

#include <vtkImageData.h>

#include <algorithm>
#include <fstream>
#include <vector>

namespace xp
{

namespace
{

constexpr uint64_t MaxXRayPixels = uint64_t(1) << 26; // 8192 x 8192

bool IsPNG(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in.gcount() == 8 && magic[1] == 'P' && magic[2] == 'N' && magic[3] == 'G';
}

std::string Trim(std::string s)
{
  s.erase(std::find(s.begin(), s.end(), '\0'), s.end());
  while (!s.empty() && s.back() == ' ')
    s.pop_back();
  return s;
}

} // namespace

vtkSmartPointer<vtkImageData> ReadXRayDICOM(const std::string& path)
{
  gdcm::Trace::WarningOff();
  // GDCM aborts on some damaged headers and pads short pixel data: check the structure first.
  const DICOMLayout layout = CheckDICOMStructure(path);
  CheckPixelDataSize(layout, path, MaxXRayPixels);
  if (layout.frames != 1)
  {
    throw InputError(path, "Number of Frames (0028,0008) = " + std::to_string(layout.frames) + ": expected one X-ray image");
  }
  gdcm::ImageReader reader;
  reader.SetFileName(path.c_str());
  if (!reader.Read())
  {
    throw InputError(path, "not a readable DICOM image");
  }
  gdcm::StringFilter strings;
  strings.SetFile(reader.GetFile());
  const std::string modality = Trim(strings.ToString(gdcm::Tag(0x0008, 0x0060)));
  if (modality != "DX" && modality != "CR" && modality != "RTIMAGE" && modality != "RF" && modality != "XA")
  {
    throw InputError(path, "Modality (0008,0060) = '" + modality + "' is not a projection X-ray (DX, CR, RTIMAGE)");
  }
  const gdcm::Image& image = reader.GetImage();
  const unsigned int* dims = image.GetDimensions();
  const gdcm::PixelFormat format = image.GetPixelFormat();
  if (image.GetNumberOfDimensions() != 2 || format.GetSamplesPerPixel() != 1)
  {
    throw InputError(path, "expected a single-frame grey-scale X-ray");
  }
  if (dims[0] != layout.columns || dims[1] != layout.rows)
  {
    throw InputError(path, "the decoded image size differs from Rows (0028,0010) / Columns (0028,0011)");
  }
  if (format.GetBitsStored() < 1 || format.GetBitsStored() > format.GetBitsAllocated())
  {
    throw InputError(path, "Bits Stored (0028,0101) = " + std::to_string(format.GetBitsStored()) + " is not within 1..Bits Allocated");
  }
  std::vector<char> raw(image.GetBufferLength());
  if (raw.size() < static_cast<size_t>(dims[0]) * dims[1] * format.GetPixelSize())
  {
    throw InputError(path, "pixel data is shorter than Rows x Columns");
  }
  if (!image.GetBuffer(raw.data()))
  {
    throw InputError(path, "cannot decode the pixel data (corrupt or truncated)");
  }
  const size_t count = static_cast<size_t>(dims[0]) * dims[1];
  std::vector<double> values(count);
  switch (format.GetScalarType())
  {
    case gdcm::PixelFormat::UINT8:
      for (size_t i = 0; i < count; ++i)
        values[i] = reinterpret_cast<const uint8_t*>(raw.data())[i];
      break;
    case gdcm::PixelFormat::UINT16:
      for (size_t i = 0; i < count; ++i)
        values[i] = reinterpret_cast<const uint16_t*>(raw.data())[i];
      break;
    case gdcm::PixelFormat::INT16:
      for (size_t i = 0; i < count; ++i)
        values[i] = std::max<int16_t>(0, reinterpret_cast<const int16_t*>(raw.data())[i]);
      break;
    default:
      throw InputError(path, "unsupported pixel representation for an X-ray (8 or 16 bits expected)");
  }
  const double top = static_cast<double>((1u << std::min<unsigned>(format.GetBitsStored(), 16)) - 1);
  const bool inverted = image.GetPhotometricInterpretation() == gdcm::PhotometricInterpretation::MONOCHROME1;
  auto out = vtkSmartPointer<vtkImageData>::New();
  out->SetDimensions(static_cast<int>(dims[0]), static_cast<int>(dims[1]), 1);
  out->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  auto* p = static_cast<uint16_t*>(out->GetScalarPointer());
  for (unsigned row = 0; row < dims[1]; ++row) // DICOM row 0 first -> VTK rows run up
  {
    for (unsigned column = 0; column < dims[0]; ++column)
    {
      double v = std::min(values[static_cast<size_t>(row) * dims[0] + column], top);
      v = inverted ? top - v : v;
      p[static_cast<size_t>(dims[1] - 1 - row) * dims[0] + column] = static_cast<uint16_t>(v + 0.5);
    }
  }
  return out;
}

vtkSmartPointer<vtkImageData> ReadXRayImage(const std::string& path)
{
  if (!std::ifstream(path))
  {
    throw InputError(path, "no such X-ray file");
  }
  if (IsPNG(path))
    return ReadXRayPNG(path);
  return IsTIFF(path) ? ReadXRayTIFF(path) : ReadXRayDICOM(path);
}

} // namespace xp
