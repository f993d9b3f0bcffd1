#include "xpDICOMSeriesWriter.h"

#include "xpError.h"

#include <gdcmImageWriter.h>
#include <gdcmTrace.h>
#include <gdcmUIDGenerator.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

/** Sets a text element (UI values are padded with NUL, others with a space, to even length). */
void Put(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr, std::string value)
{
  if (value.size() % 2)
  {
    value += vr == gdcm::VR::UI ? '\0' : ' ';
  }
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  ds.Replace(de);
}

constexpr double Intercept = -1024.0;
std::string FormatDS(double value)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

const char* CTImageStorage = "1.2.840.10008.5.1.4.1.1.2";

} // namespace

std::vector<std::string> WriteCTSeries(
  const CTVolumeData& volume, const std::string& directory, const CTSeriesWriteOptions& options)
{
  const Eigen::Vector3i& dims = volume.dimensions;
  if (dims.minCoeff() < 1 || volume.hounsfield.size() != static_cast<size_t>(dims.prod()))
  {
    throw Error(directory, "CT volume dimensions do not match its voxel count");
  }
  gdcm::Trace::WarningOff(); // xpose reports its own errors; GDCM's notes go to stderr otherwise
  gdcm::UIDGenerator uids;
  const std::string studyUID = options.studyInstanceUID.empty() ? uids.Generate() : options.studyInstanceUID;
  const std::string seriesUID = options.seriesInstanceUID.empty() ? uids.Generate() : options.seriesInstanceUID;
  const std::string frameUID = uids.Generate();
  const Eigen::Vector3d rowDir = volume.direction.col(0), colDir = volume.direction.col(1),
                        sliceDir = volume.direction.col(2);
  const double shear = std::tan(options.gantryTiltDegrees * M_PI / 180.0) * volume.spacing[2];

  std::vector<std::string> files;
  const size_t sliceSize = static_cast<size_t>(dims[0]) * dims[1];
  std::vector<uint16_t> stored(sliceSize);
  for (int k = 0; k < dims[2]; ++k)
  {
    const float* hu = volume.hounsfield.data() + k * sliceSize;
    for (size_t i = 0; i < sliceSize; ++i)
    {
      stored[i] = static_cast<uint16_t>(std::clamp(std::lround(hu[i] - Intercept), 0L, 65535L));
    }
    gdcm::ImageWriter writer;
    gdcm::Image& image = writer.GetImage();
    image.SetNumberOfDimensions(2);
    image.SetDimension(0, dims[0]);
    image.SetDimension(1, dims[1]);
    image.SetPixelFormat(gdcm::PixelFormat(gdcm::PixelFormat::UINT16));
    image.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
    image.SetSpacing(0, volume.spacing[0]);
    image.SetSpacing(1, volume.spacing[1]);
    image.SetIntercept(Intercept);
    image.SetSlope(1.0);
    const Eigen::Vector3d position = volume.origin + k * volume.spacing[2] * sliceDir + k * shear * colDir;
    const double origin[3] = { position[0], position[1], position[2] };
    image.SetOrigin(origin);
    image.SetOrigin(2, origin[2]); // SetOrigin(const double*) keeps only NumberOfDimensions values
    const double cosines[6] = { rowDir[0], rowDir[1], rowDir[2], colDir[0], colDir[1], colDir[2] };
    image.SetDirectionCosines(cosines);
    gdcm::DataElement pixels(gdcm::Tag(0x7fe0, 0x0010));
    pixels.SetByteValue(reinterpret_cast<const char*>(stored.data()), static_cast<uint32_t>(sliceSize * 2));
    image.SetDataElement(pixels);

    gdcm::DataSet& ds = writer.GetFile().GetDataSet();
    Put(ds, 0x0008, 0x0016, gdcm::VR::UI, CTImageStorage);
    Put(ds, 0x0008, 0x0018, gdcm::VR::UI, uids.Generate());
    Put(ds, 0x0008, 0x0060, gdcm::VR::CS, options.modality);
    Put(ds, 0x0008, 0x103e, gdcm::VR::LO, options.seriesDescription);
    Put(ds, 0x0010, 0x0010, gdcm::VR::PN, options.patientName);
    Put(ds, 0x0010, 0x0020, gdcm::VR::LO, options.patientID);
    Put(ds, 0x0018, 0x0050, gdcm::VR::DS, FormatDS(volume.spacing[2]));
    Put(ds, 0x0018, 0x5100, gdcm::VR::CS, options.patientPosition);
    Put(ds, 0x0020, 0x000d, gdcm::VR::UI, studyUID);
    Put(ds, 0x0020, 0x000e, gdcm::VR::UI, seriesUID);
    Put(ds, 0x0020, 0x0052, gdcm::VR::UI, frameUID);
    Put(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(k + 1));
    if (options.gantryTiltDegrees != 0.0)
    {
      Put(ds, 0x0018, 0x1120, gdcm::VR::DS, FormatDS(options.gantryTiltDegrees));
    }
    char name[64];
    std::snprintf(name, sizeof(name), "%s-%04d.dcm", options.filePrefix.c_str(), k + 1);
    const std::string path = directory + "/" + name;
    writer.SetFileName(path.c_str());
    if (!writer.Write())
    {
      throw Error(path, "cannot write DICOM file");
    }
    files.push_back(path);
  }
  return files;
}

} // namespace xp
