#include "xpRTImage.h"

#include "xpDICOMDataSet.h"
#include "xpError.h"
#include "xpPNG.h"
#include "xpRTImageGeometry.h"
#include "xpSpatialRegistration.h"

#include <gdcmReader.h>
#include <gdcmTrace.h>
#include <gdcmWriter.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace xp
{

using dicom::DS;
using dicom::Put;
using dicom::PutSequence;
using dicom::ReadNumbers;
using dicom::Value;

namespace
{

const char* RTImageStorage = "1.2.840.10008.5.1.4.1.1.481.1";

std::string Numbers(std::initializer_list<double> values)
{
  std::string text;
  for (double v : values)
    text += (text.empty() ? "" : "\\") + DS(v);
  return text;
}

/** The Image Pixel module's numbers: unsigned samples, `stored` of `allocated` bits each. */
void PutImagePixel(gdcm::DataSet& ds, int rows, int columns, int samples, uint16_t allocated, uint16_t stored)
{
  dicom::PutUS(ds, 0x0028, 0x0002, static_cast<uint16_t>(samples));
  dicom::PutUS(ds, 0x0028, 0x0010, static_cast<uint16_t>(rows));
  dicom::PutUS(ds, 0x0028, 0x0011, static_cast<uint16_t>(columns));
  dicom::PutUS(ds, 0x0028, 0x0100, allocated);
  dicom::PutUS(ds, 0x0028, 0x0101, stored);
  dicom::PutUS(ds, 0x0028, 0x0102, static_cast<uint16_t>(stored - 1));
  dicom::PutUS(ds, 0x0028, 0x0103, 0);
}

} // namespace

std::string WriteRTImageDRR(
  const CTSeriesInfo& ct, const RTImageDRR& drr, const std::string& seriesUID, int instanceNumber, const std::string& path)
{
  const RTImageGeometry g = RTImageGeometryOf(drr.view, drr.roomIsocenter);
  const size_t pixelCount = static_cast<size_t>(drr.view.Columns()) * drr.view.Rows();
  if (drr.pixels.size() != pixelCount)
    throw Error(path, "internal: the DRR's pixels do not match its imager's size");
  if (ct.frameOfReferenceUID.empty())
    throw InputError(ct.directory, "the CT series has no Frame of Reference UID to link the DRR to");
  gdcm::Writer writer;
  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  const std::string sopInstanceUID = dicom::BeginInstance(ds, ct, RTImageStorage, "RTIMAGE", "xpose DRRs", seriesUID);
  Put(ds, 0x0008, 0x0008, gdcm::VR::CS, "DERIVED\\SECONDARY\\DRR");
  Put(ds, 0x0008, 0x0064, gdcm::VR::CS, "WSD"); // Conversion Type: workstation
  Put(ds, 0x0008, 0x1070, gdcm::VR::PN, "");    // Operators' Name: none, software
  Put(ds, 0x3002, 0x0020, gdcm::VR::SH, "");    // Radiation Machine Name: an imaging room, not a linac
  Put(ds, 0x300a, 0x00b3, gdcm::VR::CS, "");    // Primary Dosimeter Unit: no beam was delivered
  Put(ds, 0x0018, 0x5100, gdcm::VR::CS, drr.patientPosition);
  Put(ds, 0x0020, 0x0013, gdcm::VR::IS, std::to_string(instanceNumber));
  Put(ds, 0x0020, 0x0020, gdcm::VR::CS, "");    // Patient Orientation: given by the geometry below
  Put(ds, 0x0020, 0x0052, gdcm::VR::UI, ct.frameOfReferenceUID);
  Put(ds, 0x0020, 0x1040, gdcm::VR::LO, "");
  // Derived from the CT: every image it was rendered from.
  std::vector<gdcm::DataSet> sources;
  for (const std::string& uid : ct.sopInstanceUIDs)
  {
    gdcm::DataSet source;
    Put(source, 0x0008, 0x1150, gdcm::VR::UI, ct.sopClassUID);
    Put(source, 0x0008, 0x1155, gdcm::VR::UI, uid);
    sources.push_back(source);
  }
  PutSequence(ds, 0x0008, 0x2112, sources); // Source Image Sequence
  Put(ds, 0x0008, 0x2111, gdcm::VR::ST, "DRR rendered by xpose from the CT"); // Derivation Description

  // RT Image geometry (xpRTImageGeometry.h).
  Put(ds, 0x3002, 0x0002, gdcm::VR::SH, drr.view.name.substr(0, 16)); // RT Image Label
  Put(ds, 0x3002, 0x0004, gdcm::VR::ST, drr.description);
  Put(ds, 0x3002, 0x000c, gdcm::VR::CS, "NORMAL");
  Put(ds, 0x3002, 0x000d, gdcm::VR::DS,
    Numbers({ g.receptorTranslation.x(), g.receptorTranslation.y(), g.receptorTranslation.z() }));
  Put(ds, 0x3002, 0x000e, gdcm::VR::DS, DS(g.receptorAngle));
  Put(ds, 0x3002, 0x0011, gdcm::VR::DS, Numbers({ g.pixelSpacing[0], g.pixelSpacing[1] }));
  Put(ds, 0x3002, 0x0012, gdcm::VR::DS, Numbers({ g.imagePosition.x(), g.imagePosition.y() }));
  Put(ds, 0x3002, 0x0022, gdcm::VR::DS, DS(g.sad));
  Put(ds, 0x3002, 0x0026, gdcm::VR::DS, DS(g.sid));
  Put(ds, 0x300a, 0x011e, gdcm::VR::DS, DS(g.gantryAngle));
  {
    // Gantry Pitch Angle is binary (FL), little-endian as the transfer syntax.
    const float pitch = static_cast<float>(g.gantryPitch);
    gdcm::DataElement de(gdcm::Tag(0x300a, 0x014a));
    de.SetVR(gdcm::VR::FL);
    de.SetByteValue(reinterpret_cast<const char*>(&pitch), 4);
    ds.Replace(de);
  }
  Put(ds, 0x300a, 0x0122, gdcm::VR::DS, "0"); // Patient Support Angle
  Put(ds, 0x300a, 0x012c, gdcm::VR::DS, Numbers({ drr.isocenterInCT.x(), drr.isocenterInCT.y(), drr.isocenterInCT.z() }));

  // 12-bit pixels, bone dark as in a transmission image.
  Put(ds, 0x0028, 0x0004, gdcm::VR::CS, "MONOCHROME2");
  PutImagePixel(ds, drr.view.Rows(), drr.view.Columns(), 1, 16, 12);
  Put(ds, 0x0028, 0x1050, gdcm::VR::DS, "2048"); // Window Center
  Put(ds, 0x0028, 0x1051, gdcm::VR::DS, "4096"); // Window Width
  dicom::PutPixelData(ds, gdcm::VR::OW, drr.pixels.data(), pixelCount * 2);

  dicom::WriteFile(writer, path, "RT Image");
  return sopInstanceUID;
}

XRayView ReadRTImageView(const std::string& path, const Eigen::Vector3d& roomIsocenter)
{
  gdcm::Trace::WarningOff();
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  if (!reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010)))
    throw InputError(path, "not a readable DICOM file");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (Value(ds, gdcm::Tag(0x0008, 0x0016)) != RTImageStorage)
    throw InputError(path, "SOP Class UID (0008,0016) is not RT Image Storage");
  const std::string plane = Value(ds, gdcm::Tag(0x3002, 0x000c));
  if (plane != "NORMAL")
    throw InputError(path, "RT Image Plane (3002,000C) = '" + plane + "': only NORMAL panels are supported");
  RTImageGeometry g;
  g.sad = ReadNumbers(ds, 0x3002, 0x0022, 1, "Radiation Machine SAD", path, true)[0];
  g.sid = ReadNumbers(ds, 0x3002, 0x0026, 1, "RT Image SID", path, true)[0];
  if (!(g.sad > 0.0) || !(g.sid > g.sad))
    throw InputError(path, "RT Image SID (3002,0026) must exceed Radiation Machine SAD (3002,0022), both positive");
  const std::vector<double> spacing = ReadNumbers(ds, 0x3002, 0x0011, 2, "Image Plane Pixel Spacing", path, true);
  if (!(spacing[0] > 0.0) || !(spacing[1] > 0.0))
    throw InputError(path, "Image Plane Pixel Spacing (3002,0011) must be positive");
  g.pixelSpacing = Eigen::Vector2d(spacing[0], spacing[1]);
  g.gantryAngle = ReadNumbers(ds, 0x300a, 0x011e, 1, "Gantry Angle", path, true)[0];
  float pitch = 0.0f;
  if (dicom::GetFL(ds, gdcm::Tag(0x300a, 0x014a), pitch))
  {
    if (!std::isfinite(pitch) || std::abs(pitch) >= 90.0f)
      throw InputError(path, "Gantry Pitch Angle (300A,014A) must be finite and within +-90 degrees");
    g.gantryPitch = pitch;
  }
  const std::vector<double> angle = ReadNumbers(ds, 0x3002, 0x000e, 1, "X-Ray Image Receptor Angle", path, false);
  g.receptorAngle = angle.empty() ? 0.0 : angle[0];
  dicom::ReadRowsAndColumns(ds, path, g.rows, g.columns);
  const int rows = g.rows, columns = g.columns;
  const std::vector<double> translation = ReadNumbers(ds, 0x3002, 0x000d, 3, "X-Ray Image Receptor Translation", path, false);
  g.receptorTranslation = translation.empty() ? Eigen::Vector3d(0.0, 0.0, g.sad - g.sid)
                                              : Eigen::Vector3d(translation[0], translation[1], translation[2]);
  if (std::abs(g.receptorTranslation.z() - (g.sad - g.sid)) > 0.1)
    throw InputError(path, "X-Ray Image Receptor Translation (3002,000D) z = " + DS(g.receptorTranslation.z()) +
        " mm contradicts Radiation Machine SAD - RT Image SID = " + DS(g.sad - g.sid) + " mm");
  const std::vector<double> position = ReadNumbers(ds, 0x3002, 0x0012, 2, "RT Image Position", path, false);
  g.imagePosition = position.empty()
    ? Eigen::Vector2d(-0.5 * (columns - 1) * g.pixelSpacing[1], 0.5 * (rows - 1) * g.pixelSpacing[0])
    : Eigen::Vector2d(position[0], position[1]);
  std::string name = Value(ds, gdcm::Tag(0x3002, 0x0002));
  return ViewOfRTImage(g, roomIsocenter, name.empty() ? path : name);
}

std::string WriteSecondaryCapture(
  const CTSeriesInfo& ct, const std::string& png, const std::string& description, const std::string& path)
{
  const DecodedPNG picture = DecodePNG(png);
  if (picture.bitDepth > 8 || picture.columns > 65535 || picture.rows > 65535)
    throw InputError(png, "a Secondary Capture of the report needs an 8-bit picture");
  const bool colour = picture.channels >= 3;
  const size_t pixels = static_cast<size_t>(picture.columns) * picture.rows;
  std::vector<uint8_t> samples(pixels * (colour ? 3 : 1));
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < (colour ? 3 : 1); ++c)
      samples[i * (colour ? 3 : 1) + c] = static_cast<uint8_t>(picture.samples[i * picture.channels + c]);
  gdcm::Writer writer;
  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  const std::string sopInstanceUID = dicom::BeginInstance(
    ds, ct, "1.2.840.10008.5.1.4.1.1.7", "OT", "xpose registration report", NewDICOMUID()); // Secondary Capture
  Put(ds, 0x0008, 0x0008, gdcm::VR::CS, "DERIVED\\SECONDARY");
  Put(ds, 0x0008, 0x0064, gdcm::VR::CS, "WSD");
  Put(ds, 0x0020, 0x4000, gdcm::VR::LT, description); // Image Comments
  Put(ds, 0x0020, 0x0013, gdcm::VR::IS, "1");
  Put(ds, 0x0020, 0x0020, gdcm::VR::CS, "");
  Put(ds, 0x0020, 0x0060, gdcm::VR::CS, "");
  Put(ds, 0x0028, 0x0004, gdcm::VR::CS, colour ? "RGB" : "MONOCHROME2");
  PutImagePixel(ds, picture.rows, picture.columns, colour ? 3 : 1, 8, 8);
  if (colour)
    dicom::PutUS(ds, 0x0028, 0x0006, 0); // Planar Configuration: colour by pixel
  dicom::PutPixelData(ds, gdcm::VR::OB, samples.data(), samples.size());
  dicom::WriteFile(writer, path, "Secondary Capture");
  return sopInstanceUID;
}

std::vector<std::string> RTImageDisagreements(
  const std::string& path, const XRayView& view, const Eigen::Vector3d& roomIsocenter, XRayTagSubset subset)
{
  gdcm::Trace::WarningOff();
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  if (!reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010)))
    return {};
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (Value(ds, gdcm::Tag(0x0008, 0x0016)) != RTImageStorage)
    return {};
  RTImageGeometry expected;
  try
  {
    expected = RTImageGeometryOf(view, roomIsocenter);
  }
  catch (const InputError& e)
  {
    if (subset == XRayTagSubset::PixelSpacing)
      return {}; // the spacing alone is compared only where the file's kind can describe the imager
    return { std::string("cannot be compared: ") + e.what() };
  }
  dicom::TagComparison tags(ds, path, view.name);
  tags.Compare(0x3002, 0x0011, "Image Plane Pixel Spacing", { expected.pixelSpacing[0], expected.pixelSpacing[1] }, 1e-3, "mm", false);
  if (subset == XRayTagSubset::PixelSpacing)
    return tags.Differences();
  tags.Compare(0x300a, 0x011e, "Gantry Angle", { expected.gantryAngle }, 0.1, "deg", true);
  float pitch = 0.0f;
  if (dicom::GetFL(ds, gdcm::Tag(0x300a, 0x014a), pitch))
  {
    if (!(std::abs(pitch - expected.gantryPitch) <= 0.1))
      tags.Add("Gantry Pitch Angle (300A,014A) = " + DS(pitch) + " deg, the geometry file's imager " + view.name + " has " +
        DS(expected.gantryPitch) + " deg");
  }
  tags.Compare(0x3002, 0x000e, "X-Ray Image Receptor Angle", { expected.receptorAngle }, 0.1, "deg", true);
  tags.Compare(0x3002, 0x0022, "Radiation Machine SAD", { expected.sad }, 0.5, "mm", false);
  tags.Compare(0x3002, 0x0026, "RT Image SID", { expected.sid }, 0.5, "mm", false);
  const Eigen::Vector3d& t = expected.receptorTranslation;
  tags.Compare(0x3002, 0x000d, "X-Ray Image Receptor Translation", { t.x(), t.y(), t.z() }, 0.5, "mm", false);
  tags.Compare(0x3002, 0x0012, "RT Image Position", { expected.imagePosition.x(), expected.imagePosition.y() }, 0.5, "mm", false);
  return tags.Differences();
}

} // namespace xp
