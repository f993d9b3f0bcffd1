/**
 * @file xpCArmGeometry.h
 * @brief An imager in the terms of a DICOM projection X-ray (DX, CR, XA): positioner angles
 *        about the patient, source distances, imager pixel spacing and the image's orientation
 *        letters; and back, for the imagers these terms can describe.
 *
 * The angles are the DICOM X-ray positioner's, in the patient's frame (LPS): at Positioner
 * Primary Angle 0 and Positioner Secondary Angle 0 the beam runs from the patient's back to the
 * chest (panel anterior). The primary angle turns the panel about the head-foot axis towards the
 * patient's left (LAO, positive; RAO negative); the secondary angle then tilts it towards the
 * head (cranial, positive). So the beam direction, source to panel, is
 * (sin p cos s, -cos p cos s, sin s) in LPS. The source lies Distance Source to Patient from the
 * isocentre (the centre of the field, DICOM's definition for C-arms), the panel's plane Distance
 * Source to Detector from the source, normal to the beam, and the central ray meets the panel's
 * centre. Patient Orientation (0020,0020) names the row and column directions (L, R, A, P, H, F;
 * up to three letters, most significant first): of the four panel axes the positioner leaves
 * (turned 0, 90, 180 or 270 degrees about the beam, mirrored or not), the one nearest each. The
 * patient lies on the table as its Patient Position says, with the isocentre in the room's.
 */
#ifndef xpCArmGeometry_h
#define xpCArmGeometry_h

#include "vtkXPGeometryModule.h"
#include "xpXRayView.h"

#include <Eigen/Core>

#include <string>

namespace xp
{

struct CArmGeometry
{
  double primaryAngle = 0.0;   ///< degrees, [-180, 180]: Positioner Primary Angle (0018,1510), LAO positive
  double secondaryAngle = 0.0; ///< degrees, [-90, 90]: Positioner Secondary Angle (0018,1511), cranial positive
  double sourceToPatient = 1000.0;  ///< Distance Source to Patient (0018,1111), mm, to the isocentre
  double sourceToDetector = 1500.0; ///< Distance Source to Detector (0018,1110), mm
  Eigen::Vector2d imagerPixelSpacing = Eigen::Vector2d::Ones(); ///< (0018,1164): [between rows, between columns], mm
  int rows = 1, columns = 1;
  std::string rowOrientation = "L";    ///< Patient Orientation (0020,0020), first value: along a row
  std::string columnOrientation = "F"; ///< second value: down a column
};

/**
 * The imager `geometry` describes, in the room, for a patient whose LPS directions the room sees
 * through `patientToRoom` (PatientToRoomRotation of the patient position), about
 * `roomIsocenter`. Throws xp::InputError naming the tag when the distances contradict each other,
 * an angle is out of range or the orientation letters are not letters of the patient or lie along
 * the beam.
 */
VTKXPGEOMETRY_EXPORT XRayView ViewOfCArm(const CArmGeometry& geometry, const Eigen::Matrix3d& patientToRoom,
  const Eigen::Vector3d& roomIsocenter, const std::string& name);

/**
 * The DX terms of `view`. Throws xp::InputError naming the imager when these terms cannot
 * describe it: a panel tilted against its central ray or off-centre on it (beyond 0.01 degree or
 * 0.01 mm), or turned about the beam by other than a multiple of 90 degrees.
 */
VTKXPGEOMETRY_EXPORT CArmGeometry CArmGeometryOf(
  const XRayView& view, const Eigen::Matrix3d& patientToRoom, const Eigen::Vector3d& roomIsocenter);

/** Patient Orientation letters of an LPS direction: the axes with a component of at least 0.25,
 *  largest first ("L", "RA", "FPL"). */
VTKXPGEOMETRY_EXPORT std::string OrientationLetters(const Eigen::Vector3d& direction);

} // namespace xp

#endif
