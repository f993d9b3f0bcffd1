#include "xpVolumeIO.h"

#include "vtkXPDICOMCTReader.h"
#include "xpError.h"
#include "xpVolumeFormats.h"

#include <vtkCallbackCommand.h>
#include <vtkImageData.h>
#include <vtkNew.h>

#include <algorithm>
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
