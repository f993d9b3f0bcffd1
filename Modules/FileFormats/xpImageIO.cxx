#include "xpImageIO.h"

#include "xpError.h"
#include "xpPNG.h"
#include "xpTIFF.h"
#include "xpXRayView.h"

#include <png.h>

#include <Eigen/Geometry>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkDataArray.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <dirent.h>
#include <fnmatch.h>
#include <sys/stat.h>
#include <unistd.h>
#include <vtksys/MD5.h>

namespace xp
{

void WritePNG(vtkImageData* image, const std::string& path)
{
  const int type = image->GetScalarType();
  if (type != VTK_UNSIGNED_CHAR && type != VTK_UNSIGNED_SHORT)
  {
    throw Error(path, "PNG needs 8- or 16-bit unsigned pixels");
  }
  int dims[3];
  image->GetDimensions(dims);
  if (dims[2] != 1 || image->GetNumberOfPoints() == 0)
  {
    throw Error(path, "PNG needs a 2D image");
  }
  // VTK row 0 is the bottom row; PNG's first row is the top (detector row 0).
  const int channels = image->GetNumberOfScalarComponents();
  const std::ptrdiff_t rowBytes = static_cast<std::ptrdiff_t>(dims[0]) * channels * image->GetScalarSize();
  const auto* bottom = static_cast<const unsigned char*>(image->GetScalarPointer());
  EncodePNG(path, bottom + rowBytes * (dims[1] - 1), -rowBytes, dims[0], dims[1], channels, type == VTK_UNSIGNED_SHORT ? 16 : 8);
}

vtkSmartPointer<vtkImageData> ReadMaskPNG(const std::string& path, int columns, int rows)
{
  const DecodedPNG png = DecodePNG(path);
  if (png.columns != columns || png.rows != rows)
  {
    throw InputError(path, "mask is " + std::to_string(png.columns) + "x" + std::to_string(png.rows) + " pixels, the image is " +
        std::to_string(columns) + "x" + std::to_string(rows));
  }
  auto mask = vtkSmartPointer<vtkImageData>::New();
  mask->SetDimensions(columns, rows, 1);
  mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  uint8_t* out = static_cast<uint8_t*>(mask->GetScalarPointer());
  // Any non-zero colour channel marks a valid pixel; alpha (grey+alpha: channel 1, RGBA: 3) does not.
  const int colours = png.channels >= 3 ? 3 : 1;
  long long valid = 0;
  for (int row = 0; row < rows; ++row) // PNG row 0 (detector row 0) -> VTK row rows-1
  {
    for (int column = 0; column < columns; ++column)
    {
      const uint16_t* pixel = png.samples.data() + (static_cast<size_t>(row) * columns + column) * png.channels;
      bool any = false;
      for (int c = 0; c < colours; ++c)
        any = any || pixel[c] != 0;
      out[static_cast<size_t>(rows - 1 - row) * columns + column] = any ? 1 : 0;
      valid += any;
    }
  }
  if (valid == 0)
  {
    throw InputError(path, "the mask is empty (no pixel is valid)");
  }
  return mask;
}

vtkSmartPointer<vtkImageData> ReadXRayPNG(const std::string& path)
{
  const DecodedPNG png = DecodePNG(path);
  // Any grey depth is an X-ray: a panel's raw 14-16 bits, xpose's 12, a processed 8. Their
  // values are kept as they are; the registration ranks them (xpStereoRegistration.h).
  if (png.colorType != PNG_COLOR_TYPE_GRAY || png.channels != 1)
  {
    throw InputError(path, "expected a grey PNG X-ray (8 or 16 bits, one channel), found " + std::to_string(png.bitDepth) +
        "-bit with " + std::to_string(png.channels) + " channel(s)");
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(png.columns, png.rows, 1);
  image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  uint16_t* out = static_cast<uint16_t*>(image->GetScalarPointer());
  for (int row = 0; row < png.rows; ++row) // PNG row 0 (detector row 0) -> VTK row rows-1
  {
    const uint16_t* in = png.samples.data() + static_cast<size_t>(row) * png.columns;
    std::copy(in, in + png.columns, out + static_cast<size_t>(png.rows - 1 - row) * png.columns);
  }
  return image;
}

vtkSmartPointer<vtkImageData> ReadXRayTIFF(const std::string& path)
{
  const DecodedTIFF tiff = DecodeTIFF(path);
  if (tiff.pages.size() != 1)
  {
    throw InputError(path, std::to_string(tiff.pages.size()) + " pages: an X-ray is one page (a volume is read with --voxel-size)");
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(tiff.columns, tiff.rows, 1);
  image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  uint16_t* out = static_cast<uint16_t*>(image->GetScalarPointer());
  for (int row = 0; row < tiff.rows; ++row) // TIFF row 0 (detector row 0) -> VTK row rows-1
  {
    const uint16_t* in = tiff.pages[0].data() + static_cast<size_t>(row) * tiff.columns;
    std::copy(in, in + tiff.columns, out + static_cast<size_t>(tiff.rows - 1 - row) * tiff.columns);
  }
  return image;
}

void WriteDetectorMetaImage(vtkImageData* image, const XRayView& view, const std::string& path)
{
  int dims[3];
  image->GetDimensions(dims);
  if (image->GetScalarType() != VTK_FLOAT || dims[0] != view.Columns() || dims[1] != view.Rows())
  {
    throw Error(path, "detector image does not match the view's panel size, or is not float");
  }
  std::ofstream out(path, std::ios::binary);
  const auto& o = view.PixelCenter(0, 0);
  const auto normal = view.rowDirection.cross(view.columnDirection);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
      << "CompressedData = False\n"
      << "TransformMatrix = " << view.rowDirection.transpose() << " " << view.columnDirection.transpose() << " "
      << normal.transpose() << "\n"
      << "Offset = " << o.transpose() << "\nCenterOfRotation = 0 0 0\nAnatomicalOrientation = ???\n"
      << "ElementSpacing = " << view.pixelSpacing[0] << " " << view.pixelSpacing[1] << " 1\n"
      << "DimSize = " << dims[0] << " " << dims[1] << " 1\nElementType = MET_FLOAT\n"
      << "ElementDataFile = LOCAL\n";
  // Detector row 0 (VTK row rows-1) first; one write, as many small ones cost more than the copy.
  const float* pixels = static_cast<const float*>(image->GetScalarPointer());
  std::vector<float> detectorOrder(static_cast<size_t>(dims[0]) * dims[1]);
  for (int row = 0; row < dims[1]; ++row)
  {
    std::copy_n(pixels + static_cast<size_t>(dims[1] - 1 - row) * dims[0], dims[0],
      detectorOrder.data() + static_cast<size_t>(row) * dims[0]);
  }
  out.write(reinterpret_cast<const char*>(detectorOrder.data()), static_cast<std::streamsize>(sizeof(float) * detectorOrder.size()));
  if (!out)
  {
    throw Error(path, "cannot write MetaImage");
  }
}

StagedOutputDirectory::StagedOutputDirectory(const std::string& directory)
  : Final(directory)
{
  // Create missing parents too (mkdir -p), so "--out demo/ct" works in a fresh checkout.
  for (size_t slash = directory.find('/', 1); slash != std::string::npos; slash = directory.find('/', slash + 1))
  {
    mkdir(directory.substr(0, slash).c_str(), 0755);
  }
  if (mkdir(directory.c_str(), 0755) != 0 && errno != EEXIST)
  {
    throw InputError(directory, std::string("cannot create the output folder: ") + std::strerror(errno));
  }
  std::string pattern = directory + "/.xpose-partial-XXXXXX";
  if (!mkdtemp(pattern.data()))
  {
    throw InputError(directory, std::string("cannot write into the output folder: ") + std::strerror(errno));
  }
  this->Staging = pattern;
}

void StagedOutputDirectory::CheckWritable(const std::string& directory)
{
  // Walk up to the first part of the path that exists: it must be a folder we may write into.
  std::string existing = directory.empty() ? "." : directory;
  struct stat status;
  while (stat(existing.c_str(), &status) != 0)
  {
    if (existing == "." || existing == "/")
    {
      throw InputError(directory, "no part of the path exists, not even the working folder");
    }
    const size_t slash = existing.find_last_of('/', existing.size() > 1 ? existing.size() - 2 : 0);
    existing = slash == std::string::npos ? "." : (slash == 0 ? "/" : existing.substr(0, slash));
  }
  if (!S_ISDIR(status.st_mode))
  {
    throw InputError(directory, existing == directory ? "exists and is not a folder"
                                                      : existing + " is not a folder, so the output folder cannot be made");
  }
  if (access(existing.c_str(), W_OK | X_OK) != 0)
  {
    throw InputError(directory, "cannot write into " + existing + ": " + std::strerror(errno));
  }
}

StagedOutputDirectory::~StagedOutputDirectory()
{
  if (!this->Committed)
  {
    for (const std::string& name : this->Names)
    {
      std::remove((this->Staging + "/" + name).c_str());
    }
  }
  rmdir(this->Staging.c_str());
}

std::string StagedOutputDirectory::Path(const std::string& fileName)
{
  this->Names.push_back(fileName);
  return this->Staging + "/" + fileName;
}

void StagedOutputDirectory::Commit()
{
  if (!this->Names.empty())
  {
    std::remove((this->Final + "/" + this->Names.back()).c_str());
  }
  for (const std::string& name : this->Names)
  {
    const std::string from = this->Staging + "/" + name, to = this->Final + "/" + name;
    struct stat status;
    if (stat(from.c_str(), &status) == 0 && std::rename(from.c_str(), to.c_str()) != 0)
    {
      throw Error(to, std::string("cannot move the output into place: ") + std::strerror(errno));
    }
  }
  this->Committed = true;
  if (this->EarlierPatterns.empty())
  {
    return;
  }
  DIR* folder = opendir(this->Final.c_str());
  while (dirent* entry = folder ? readdir(folder) : nullptr)
  {
    const std::string name = entry->d_name;
    const bool ours = std::find(this->Names.begin(), this->Names.end(), name) != this->Names.end();
    const bool earlier = std::any_of(this->EarlierPatterns.begin(), this->EarlierPatterns.end(),
      [&](const std::string& pattern) { return fnmatch(pattern.c_str(), name.c_str(), 0) == 0; });
    if (earlier && !ours)
    {
      std::remove((this->Final + "/" + name).c_str());
    }
  }
  if (folder)
  {
    closedir(folder);
  }
}

std::string FileMD5(const std::string& path)
{
  std::ifstream in(path, std::ios::binary);
  if (!in)
  {
    throw InputError(path, "cannot be read");
  }
  vtksysMD5* md5 = vtksysMD5_New();
  vtksysMD5_Initialize(md5);
  std::vector<char> buffer(1 << 20);
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0)
  {
    vtksysMD5_Append(md5, reinterpret_cast<const unsigned char*>(buffer.data()), static_cast<int>(in.gcount()));
  }
  char hex[33] = {};
  vtksysMD5_FinalizeHex(md5, hex);
  vtksysMD5_Delete(md5);
  return hex;
}

} // namespace xp
