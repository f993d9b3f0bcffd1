#include "xpPlastimatchRenderer.h"

#include "xpError.h"
#include "xpImageGeometry.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkType.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

std::string Triple(const Eigen::Vector3d& v)
{
  char text[160];
  std::snprintf(text, sizeof(text), "%.9g %.9g %.9g", v[0], v[1], v[2]);
  return text;
}

/** The CT's HU in its voxel frame: origin at voxel (0, 0, 0), axes along the index axes. */
void WriteVoxelFrameMetaImage(vtkImageData* ct, const std::string& path)
{
  int dims[3];
  ct->GetDimensions(dims);
  const double* spacing = ct->GetSpacing();
  const bool shorts = ct->GetScalarType() == VTK_SHORT;
  std::ofstream out(path, std::ios::binary);
  out << "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\nCompressedData = False\n"
      << "TransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = 0 0 0\nCenterOfRotation = 0 0 0\n"
      << "ElementSpacing = " << spacing[0] << " " << spacing[1] << " " << spacing[2] << "\nDimSize = " << dims[0] << " "
      << dims[1] << " " << dims[2] << "\nElementType = " << (shorts ? "MET_SHORT" : "MET_FLOAT") << "\nElementDataFile = LOCAL\n";
  const size_t count = static_cast<size_t>(dims[0]) * dims[1] * dims[2];
  if (shorts)
  {
    out.write(static_cast<const char*>(ct->GetScalarPointer()), static_cast<std::streamsize>(count * sizeof(short)));
  }
  else
  {
    std::vector<float> hu(count);
    for (size_t i = 0; i < count; ++i)
      hu[i] = static_cast<float>(ct->GetPointData()->GetScalars()->GetComponent(static_cast<vtkIdType>(i), 0));
    out.write(reinterpret_cast<const char*>(hu.data()), static_cast<std::streamsize>(count * sizeof(float)));
  }
  if (!out)
    throw InputError(path, "cannot write the CT for plastimatch");
}

} // namespace

bool PlastimatchRenderer::Available()
{
  return std::system("command -v plastimatch > /dev/null 2>&1") == 0;
}

PlastimatchRenderer::PlastimatchRenderer(
  vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomIsocenter)
  : Planned(plannedCTToRoom)
  , Isocenter(roomIsocenter)
{
  if (!Available())
    throw InputError("--scenario plastimatch", "plastimatch is not installed (apt-get install plastimatch)");
  char folder[] = "/tmp/xpose-plastimatch-XXXXXX";
  if (!mkdtemp(folder))
    throw InputError("/tmp", std::string("cannot make a folder for plastimatch: ") + std::strerror(errno));
  this->Folder = folder;
  const double* spacing = ct->GetSpacing();
  this->VoxelFrameToCT = IndexToPhysical(ct) * Eigen::Scaling(1.0 / spacing[0], 1.0 / spacing[1], 1.0 / spacing[2]);
  WriteVoxelFrameMetaImage(ct, this->Folder + "/ct.mha");
}

PlastimatchRenderer::~PlastimatchRenderer()
{
  std::error_code ignored;
  std::filesystem::remove_all(this->Folder, ignored);
}

std::vector<float> PlastimatchRenderer::LineIntegrals(const XRayView& view, const Pose& misalignment) const
{
  // Room -> the file's frame, through the misaligned set-up.
  const Eigen::Affine3d roomToFile =
    this->VoxelFrameToCT.inverse() * MisalignedCTToRoom(this->Planned, misalignment, this->Isocenter).inverse();
  const Eigen::Matrix3d turn = roomToFile.linear();
  const Eigen::Vector3d source = roomToFile * view.source, center = roomToFile * view.detectorCenter;
  const Eigen::Vector3d along = turn * view.rowDirection, down = turn * view.columnDirection;
  const Eigen::Vector3d normal = turn * view.NormalTowardsSource();
  const double sid = (source - center).dot(normal);
  // plastimatch's central ray is the panel's normal through the source; its foot is the image
  // centre, in pixels, and its isocentre any point on it (here at the room isocentre's depth).
  const Eigen::Vector3d foot = source - sid * normal;
  const double column = 0.5 * (view.Columns() - 1) + (foot - center).dot(along) / view.pixelSpacing[0];
  const double row = 0.5 * (view.Rows() - 1) + (foot - center).dot(down) / view.pixelSpacing[1];
  const double sad = (source - roomToFile * this->Isocenter).dot(normal);
  const Eigen::Vector3d isocenter = source - sad * normal;
  char size[200], center2[100], scalars[100];
  // Its help says "row col" for -r, -z and -c; plastimatch 1.9 reads columns first in each (the
  // bead test pins the order).
  std::snprintf(size, sizeof(size), "-r \"%d %d\" -z \"%.9g %.9g\"", view.Columns(), view.Rows(),
    view.Columns() * view.pixelSpacing[0], view.Rows() * view.pixelSpacing[1]);
  std::snprintf(center2, sizeof(center2), "-c \"%.9g %.9g\"", column, row);
  std::snprintf(scalars, sizeof(scalars), "--sad %.9g --sid %.9g", sad, sid);
  const std::string prefix = this->Folder + "/view_";
  const std::string command = "plastimatch drr -I '" + this->Folder + "/ct.mha' -O '" + prefix + "' -i exact " + size +
    " " + center2 + " " + scalars + " -o \"" + Triple(isocenter) + "\" -n \"" + Triple(normal) + "\" --vup \"" +
    Triple(-down) + "\" -t pfm -a 1 > '" + this->Folder + "/log.txt' 2>&1";
  if (std::system(command.c_str()) != 0)
    throw Error("plastimatch drr", "failed; its output is in " + this->Folder + "/log.txt (command: " + command + ")");
  int columns = 0, rows = 0;
  std::vector<float> integrals = ReadPFM(prefix + "0000.pfm", columns, rows);
  if (columns != view.Columns() || rows != view.Rows())
    throw Error("plastimatch drr", "gave " + std::to_string(columns) + "x" + std::to_string(rows) + " pixels for a " +
        std::to_string(view.Columns()) + "x" + std::to_string(view.Rows()) + " view");
  // plastimatch's integrals are a tenth of mu (1/mm) times mm: 100 mm of water give 0.2178 with
  // its mu of water, 0.02178 / mm (the test of a water cube pins this).
  for (float& value : integrals)
    value *= 10.0f;
  return integrals;
}

std::vector<float> ReadPFM(const std::string& path, int& columns, int& rows)
{
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  double scale = 0.0;
  if (!(in >> magic >> columns >> rows >> scale) || magic != "Pf" || columns <= 0 || rows <= 0)
    throw InputError(path, "not a grey PFM image");
  in.get(); // the single whitespace before the data
  std::vector<float> values(static_cast<size_t>(columns) * rows);
  in.read(reinterpret_cast<char*>(values.data()), static_cast<std::streamsize>(values.size() * sizeof(float)));
  if (!in)
    throw InputError(path, "PFM data cut short");
  if (scale > 0.0) // big-endian data
    for (float& v : values)
    {
      char* bytes = reinterpret_cast<char*>(&v);
      std::swap(bytes[0], bytes[3]);
      std::swap(bytes[1], bytes[2]);
    }
  return values;
}

} // namespace xp
