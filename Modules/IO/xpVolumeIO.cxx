#include "xpVolumeIO.h"

#include "vtkXPDICOMCTReader.h"
#include "xpError.h"

#include <vtkCallbackCommand.h>
#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkMatrix3x3.h>
#include <vtkMatrix4x4.h>
#include <vtkMetaImageReader.h>
#include <vtkNIFTIImageReader.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <Eigen/Core>
#include <fstream>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

namespace
{

bool EndsWith(const std::string& s, const std::string& suffix)
{
  return s.size() >= suffix.size() && std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
    [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
}

/** Copies any scalar type into a float HU image with the given index-to-LPS geometry. */
vtkSmartPointer<vtkImageData> ToFloatImage(vtkImageData* source, const Eigen::Vector3d& origin,
  const Eigen::Vector3d& spacing, const Eigen::Matrix3d& direction, const std::string& path)
{
  vtkDataArray* in = source->GetPointData()->GetScalars();
  if (!in || in->GetNumberOfComponents() != 1)
  {
    throw InputError(path, "expected a single-component CT volume");
  }
  int dims[3];
  source->GetDimensions(dims);
  if (dims[2] < 2)
  {
    throw InputError(path, "a CT volume needs at least two slices");
  }
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(dims);
  image->SetOrigin(origin.data());
  image->SetSpacing(spacing.data());
  image->SetDirectionMatrix(direction(0, 0), direction(0, 1), direction(0, 2), direction(1, 0), direction(1, 1),
    direction(1, 2), direction(2, 0), direction(2, 1), direction(2, 2));
  vtkNew<vtkFloatArray> hu;
  hu->SetName("HU");
  hu->SetNumberOfValues(in->GetNumberOfTuples());
  for (vtkIdType i = 0; i < in->GetNumberOfTuples(); ++i)
  {
    hu->SetValue(i, static_cast<float>(in->GetTuple1(i)));
  }
  image->GetPointData()->SetScalars(hu);
  return image;
}

CTVolume ReadMetaImage(const std::string& path)
{
  vtkNew<vtkMetaImageReader> reader;
  if (!reader->CanReadFile(path.c_str()))
  {
    throw InputError(path, "not a readable MetaImage file");
  }
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  if (!image || image->GetNumberOfPoints() == 0)
  {
    throw InputError(path, "MetaImage has no voxels (missing or truncated data file)");
  }
  // vtkMetaImageReader ignores the direction; read TransformMatrix (ITK: triple i = axis i, LPS).
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();
  std::ifstream header(path);
  std::string line;
  while (std::getline(header, line) && line.rfind("ElementDataFile", 0) != 0)
  {
    std::istringstream words(line);
    std::string key, equals;
    words >> key >> equals;
    if (key == "TransformMatrix" || key == "Rotation" || key == "Orientation")
    {
      for (int axis = 0; axis < 3; ++axis)
      {
        for (int r = 0; r < 3; ++r)
        {
          if (!(words >> direction(r, axis)))
          {
            throw InputError(path, key + ": expected 9 numbers");
          }
        }
      }
    }
  }
  double origin[3], spacing[3];
  image->GetOrigin(origin);
  image->GetSpacing(spacing);
  CTVolume volume;
  volume.image = ToFloatImage(image, Eigen::Vector3d(origin), Eigen::Vector3d(spacing), direction, path);
  return volume;
}

CTVolume ReadNIfTI(const std::string& path)
{
  vtkNew<vtkNIFTIImageReader> reader;
  if (!reader->CanReadFile(path.c_str()))
  {
    throw InputError(path, "not a readable NIfTI file");
  }
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  if (!image || image->GetNumberOfPoints() == 0)
  {
    throw InputError(path, "NIfTI file has no voxels");
  }
  vtkMatrix4x4* form = reader->GetQFormMatrix() ? reader->GetQFormMatrix() : reader->GetSFormMatrix();
  // index -> VTK data coordinates (origin + spacing) -> RAS (q/sform) -> LPS.
  double origin[3], spacing[3];
  image->GetOrigin(origin);
  image->GetSpacing(spacing);
  Eigen::Matrix4d indexToData = Eigen::Matrix4d::Identity();
  for (int a = 0; a < 3; ++a)
  {
    indexToData(a, a) = spacing[a];
    indexToData(a, 3) = origin[a];
  }
  Eigen::Matrix4d dataToRAS = Eigen::Matrix4d::Identity();
  if (form)
  {
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        dataToRAS(r, c) = form->GetElement(r, c);
  }
  const Eigen::Matrix4d indexToLPS = Eigen::Vector4d(-1, -1, 1, 1).asDiagonal() * dataToRAS * indexToData;
  Eigen::Vector3d lpsSpacing;
  Eigen::Matrix3d direction;
  for (int a = 0; a < 3; ++a)
  {
    lpsSpacing[a] = indexToLPS.block<3, 1>(0, a).norm();
    direction.col(a) = indexToLPS.block<3, 1>(0, a) / lpsSpacing[a];
  }
  CTVolume volume;
  volume.image = ToFloatImage(image, indexToLPS.block<3, 1>(0, 3), lpsSpacing, direction, path);
  return volume;
}

} // namespace

CTVolume ReadCTVolume(const std::string& path, const std::string& seriesUID)
{
  struct stat status;
  if (stat(path.c_str(), &status) != 0)
  {
    throw InputError(path, "no such file or folder");
  }
  if (S_ISDIR(status.st_mode))
  {
    vtkNew<vtkXPDICOMCTReader> reader;
    reader->SetDirectoryName(path.c_str());
    reader->SetSeriesInstanceUID(seriesUID.c_str());
    // The error text is rethrown below; a silent observer keeps VTK from printing it too.
    vtkNew<vtkCallbackCommand> silent;
    reader->AddObserver(vtkCommand::ErrorEvent, silent);
    reader->Update();
    if (!reader->GetErrorText().empty())
    {
      throw InputError(reader->GetErrorText());
    }
    CTVolume volume;
    volume.image = reader->GetOutput();
    volume.patientPosition = reader->GetPatientPosition();
    return volume;
  }
  if (EndsWith(path, ".mha") || EndsWith(path, ".mhd"))
  {
    return ReadMetaImage(path);
  }
  if (EndsWith(path, ".nii") || EndsWith(path, ".nii.gz"))
  {
    return ReadNIfTI(path);
  }
  throw InputError(path, "unknown CT format (expected a DICOM folder, .mha/.mhd or .nii/.nii.gz)");
}

} // namespace xp
