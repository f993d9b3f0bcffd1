#include "xpXRayGeometryTags.h"

#include "xpCArmGeometry.h"
#include "xpDICOMDataSet.h"
#include "xpError.h"
#include "xpPose.h"
#include "xpRTImage.h"

#include <gdcmReader.h>
#include <gdcmTrace.h>

#include <cmath>
#include <sstream>

namespace xp
{

using dicom::ReadNumbers;
using dicom::Value;

namespace
{

const char* RTImageStorage = "1.2.840.10008.5.1.4.1.1.481.1";

bool IsProjectionRadiograph(const std::string& sopClass)
{
  return sopClass == "1.2.840.10008.5.1.4.1.1.1" // CR
    || sopClass == "1.2.840.10008.5.1.4.1.1.1.1" // DX for presentation
    || sopClass == "1.2.840.10008.5.1.4.1.1.1.1.1" // DX for processing
    || sopClass == "1.2.840.10008.5.1.4.1.1.12.1"; // XA
}

/** The header of a DICOM file, or false when it is none. */
bool ReadHeader(const std::string& path, gdcm::Reader& reader)
{
  gdcm::Trace::WarningOff();
  reader.SetFileName(path.c_str());
  return reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010));
}

/** How the patient lay: the file's Patient Position, else `fallback`. */
Eigen::Matrix3d PatientToRoomOf(const gdcm::DataSet& ds, const std::string& path, const std::string& fallback)
{
  const std::string own = Value(ds, gdcm::Tag(0x0018, 0x5100));
  if (!own.empty())
    return PatientToRoomRotation(ParsePatientPosition(own, path + ": Patient Position (0018,5100)"));
  if (fallback.empty())
    throw InputError(path, "Patient Position (0018,5100) missing: how the patient lay is needed to place the image in the "
                           "room (give it with --patient-position)");
  return PatientToRoomRotation(ParsePatientPosition(fallback, "--patient-position"));
}

/** The positioner terms of a DX, CR or XA data set. */
CArmGeometry CArmTermsOf(const gdcm::DataSet& ds, const std::string& path)
{
  const std::string positioner = Value(ds, gdcm::Tag(0x0018, 0x1508));
  if (!positioner.empty() && positioner != "CARM")
    throw InputError(path, "Positioner Type (0018,1508) = '" + positioner +
        "': only C-arm positioner angles (CARM) are understood; describe this room with a geometry file");
  CArmGeometry g;
  g.sourceToDetector = ReadNumbers(ds, 0x0018, 0x1110, 1, "Distance Source to Detector", path, true)[0];
  g.sourceToPatient = ReadNumbers(ds, 0x0018, 0x1111, 1, "Distance Source to Patient", path, true)[0];
  g.primaryAngle = ReadNumbers(ds, 0x0018, 0x1510, 1, "Positioner Primary Angle", path, true)[0];
  g.secondaryAngle = ReadNumbers(ds, 0x0018, 0x1511, 1, "Positioner Secondary Angle", path, true)[0];
  const std::vector<double> spacing = ReadNumbers(ds, 0x0018, 0x1164, 2, "Imager Pixel Spacing", path, true);
  g.imagerPixelSpacing = Eigen::Vector2d(spacing[0], spacing[1]);
  dicom::ReadRowsAndColumns(ds, path, g.rows, g.columns);
  const std::string orientation = Value(ds, gdcm::Tag(0x0020, 0x0020));
  std::stringstream letters(orientation);
  std::getline(letters, g.rowOrientation, '\\');
  std::getline(letters, g.columnOrientation, '\\');
  std::string extra;
  if (orientation.empty() || g.columnOrientation.empty() || std::getline(letters, extra, '\\'))
    throw InputError(path, "Patient Orientation (0020,0020) = '" + orientation +
        "': two values (the row and column directions, e.g. L\\F) are needed to orient the image");
  return g;
}

/** The message of `error` with the file named first, for errors of the geometry terms. */
InputError InFile(const std::string& path, const InputError& error)
{
  return InputError(path, error.what());
}

} // namespace

XRayView ReadProjectionXRayView(const std::string& path, const Eigen::Vector3d& roomIsocenter, const std::string& patientPosition)
{
  gdcm::Reader reader;
  if (!ReadHeader(path, reader))
    throw InputError(path, "not a readable DICOM file");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const std::string sopClass = Value(ds, gdcm::Tag(0x0008, 0x0016));
  if (!IsProjectionRadiograph(sopClass))
    throw InputError(path, "SOP Class UID (0008,0016) = '" + sopClass + "' is not DX, CR or XA");
  const CArmGeometry terms = CArmTermsOf(ds, path);
  const Eigen::Matrix3d patientToRoom = PatientToRoomOf(ds, path, patientPosition);
  try
  {
    return ViewOfCArm(terms, patientToRoom, roomIsocenter, path);
  }
  catch (const InputError& e)
  {
    throw InFile(path, e);
  }
}

XRayView ReadXRayViewFromTags(const std::string& path, const Eigen::Vector3d& roomIsocenter, const std::string& patientPosition)
{
  gdcm::Reader reader;
  if (!ReadHeader(path, reader))
    throw InputError(path, "not a readable DICOM file");
  const std::string sopClass = Value(reader.GetFile().GetDataSet(), gdcm::Tag(0x0008, 0x0016));
  if (sopClass == RTImageStorage)
    return ReadRTImageView(path, roomIsocenter);
  if (IsProjectionRadiograph(sopClass))
    return ReadProjectionXRayView(path, roomIsocenter, patientPosition);
  throw InputError(path, "SOP Class UID (0008,0016) = '" + sopClass + "': the geometry is read from RT Image, DX, CR or XA files");
}

std::vector<std::string> XRayTagDisagreements(const std::string& path, const XRayView& view, const Eigen::Vector3d& roomIsocenter,
  const std::string& patientPosition, XRayTagSubset subset)
{
  gdcm::Reader reader;
  if (!ReadHeader(path, reader))
    return {};
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  const std::string sopClass = Value(ds, gdcm::Tag(0x0008, 0x0016));
  if (sopClass == RTImageStorage)
    return RTImageDisagreements(path, view, roomIsocenter, subset);
  if (!IsProjectionRadiograph(sopClass))
    return {};
  CArmGeometry expected;
  Eigen::Matrix3d patientToRoom;
  try
  {
    patientToRoom = PatientToRoomOf(ds, path, patientPosition);
    expected = CArmGeometryOf(view, patientToRoom, roomIsocenter);
  }
  catch (const InputError& e)
  {
    if (subset == XRayTagSubset::PixelSpacing)
      return {}; // the spacing alone is compared only where the file's kind can describe the imager
    return { std::string("cannot be compared: ") + e.what() };
  }
  dicom::TagComparison tags(ds, path, view.name);
  tags.Compare(0x0018, 0x1164, "Imager Pixel Spacing", { expected.imagerPixelSpacing[0], expected.imagerPixelSpacing[1] }, 1e-3,
    "mm", false);
  if (subset == XRayTagSubset::PixelSpacing)
    return tags.Differences();
  tags.Compare(0x0018, 0x1510, "Positioner Primary Angle", { expected.primaryAngle }, 0.1, "deg", true);
  tags.Compare(0x0018, 0x1511, "Positioner Secondary Angle", { expected.secondaryAngle }, 0.1, "deg", false);
  tags.Compare(0x0018, 0x1110, "Distance Source to Detector", { expected.sourceToDetector }, 0.5, "mm", false);
  tags.Compare(0x0018, 0x1111, "Distance Source to Patient", { expected.sourceToPatient }, 0.5, "mm", false);
  // The orientation letters: compared through the row and column directions they pick.
  CArmGeometry file;
  try
  {
    file = CArmTermsOf(ds, path);
  }
  catch (const InputError&)
  {
    return tags.Differences(); // a missing or malformed tag is reported when the file's geometry is read
  }
  const std::string found = "Patient Orientation (0020,0020) = " + file.rowOrientation + "\\" + file.columnOrientation;
  const std::string imager = "the geometry file's imager " + view.name;
  const std::string letters = expected.rowOrientation + "\\" + expected.columnOrientation;
  try
  {
    CArmGeometry own = expected;
    own.rowOrientation = file.rowOrientation;
    own.columnOrientation = file.columnOrientation;
    const XRayView oriented = ViewOfCArm(own, patientToRoom, roomIsocenter, view.name);
    if (oriented.rowDirection.dot(view.rowDirection) < 0.999 || oriented.columnDirection.dot(view.columnDirection) < 0.999)
      tags.Add(found + ", " + imager + " has " + letters);
  }
  catch (const InputError&)
  {
    tags.Add(found + " does not fit the beam of " + imager + ", which has " + letters);
  }
  return tags.Differences();
}

} // namespace xp
