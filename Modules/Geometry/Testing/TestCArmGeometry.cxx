// DX/CR terms of an imager: each positioner angle moves the source the way DICOM names it (LAO to
// the patient's left, cranial towards the head), for a supine and a prone patient, and the
// reference views survive the round trip.
#include "xpReferenceGeometry.h"

#include "xpCArmGeometry.h"
#include "xpError.h"
#include "xpPose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>

namespace
{

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

const Eigen::Matrix3d Supine = xp::PatientToRoomRotation(xp::PatientPosition::HFS);

xp::CArmGeometry Upright(double primary, double secondary)
{
  xp::CArmGeometry g;
  g.primaryAngle = primary;
  g.secondaryAngle = secondary;
  g.sourceToPatient = 1000.0;
  g.sourceToDetector = 1500.0;
  g.imagerPixelSpacing = Eigen::Vector2d(0.4, 0.3); // between rows, between columns
  g.rows = 300;
  g.columns = 400;
  g.rowOrientation = "L";
  g.columnOrientation = "F";
  return g;
}

std::string MessageOf(const xp::CArmGeometry& g)
{
  try
  {
    xp::ViewOfCArm(g, Supine, Eigen::Vector3d::Zero(), "X");
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}

} // namespace

TEST(CArmGeometry, AnglesMoveTheSourceAsDICOMNamesThem)
{
  const Eigen::Vector3d iso(5.0, -10.0, 20.0);
  // 0, 0 on a supine patient: the beam runs up (posterior to anterior), source 1000 mm below.
  const xp::XRayView ap = xp::ViewOfCArm(Upright(0.0, 0.0), Supine, iso, "AP");
  EXPECT_LT((ap.source - (iso - Eigen::Vector3d(0.0, 0.0, 1000.0))).norm(), 1e-9);
  EXPECT_LT((ap.detectorCenter - (iso + Eigen::Vector3d(0.0, 0.0, 500.0))).norm(), 1e-9);
  // Row "L": along the patient's left, Room +X; column "F": towards the feet, Room -Y.
  EXPECT_LT((ap.rowDirection - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  EXPECT_LT((ap.columnDirection + Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_NEAR(ap.pixelSpacing[0], 0.3, 1e-12); // between columns
  EXPECT_NEAR(ap.pixelSpacing[1], 0.4, 1e-12);
  // A point to the patient's left of the isocentre lands right of the panel's centre.
  EXPECT_GT(ap.Project(iso + Eigen::Vector3d(10.0, 0.0, 0.0))[0], 0.5 * (400 - 1) + 1.0);
  // LAO 90: the panel at the patient's left (+X), the source at the right.
  xp::CArmGeometry lateral = Upright(90.0, 0.0);
  lateral.rowOrientation = "P"; // "L" would lie along this beam
  const xp::XRayView lao = xp::ViewOfCArm(lateral, Supine, iso, "LAO");
  EXPECT_LT((lao.source - (iso - Eigen::Vector3d(1000.0, 0.0, 0.0))).norm(), 1e-9);
  // Cranial 30: the panel tilts towards the head (+Y), the source towards the feet.
  const xp::XRayView cranial = xp::ViewOfCArm(Upright(0.0, 30.0), Supine, iso, "CRA");
  EXPECT_LT((cranial.source - (iso - 1000.0 * Eigen::Vector3d(0.0, 0.5, std::sqrt(0.75)))).norm(), 1e-9);
  // Prone: the patient's anterior faces the floor, so 0, 0 puts the source above.
  const xp::XRayView prone = xp::ViewOfCArm(Upright(0.0, 0.0), xp::PatientToRoomRotation(xp::PatientPosition::HFP), iso, "P");
  EXPECT_GT(prone.source.z() - iso.z(), 999.0);
}

TEST(CArmGeometry, ReferenceViewsAreLAO45AndRAO45AndSurviveTheRoundTrip)
{
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  const xp::CArmGeometry a = xp::CArmGeometryOf(reference.views[0], Supine, reference.isocenter);
  EXPECT_NEAR(a.primaryAngle, 45.0, 1e-9);
  EXPECT_NEAR(a.secondaryAngle, 0.0, 1e-9);
  EXPECT_NEAR(a.sourceToPatient, 1000.0, 1e-2);
  EXPECT_NEAR(a.sourceToDetector, 1500.0, 1e-2);
  EXPECT_EQ(a.rowOrientation, "RA");
  EXPECT_EQ(a.columnOrientation, "F");
  EXPECT_NEAR(xp::CArmGeometryOf(reference.views[1], Supine, reference.isocenter).primaryAngle, -45.0, 1e-9);
  for (const xp::XRayView& view : reference.views)
  {
    const xp::XRayView back =
      xp::ViewOfCArm(xp::CArmGeometryOf(view, Supine, reference.isocenter), Supine, reference.isocenter, view.name);
    EXPECT_LT((back.source - view.source).norm(), 0.1);
    EXPECT_LT((back.detectorCenter - view.detectorCenter).norm(), 0.1);
    EXPECT_LT(DegreesApart(back.rowDirection, view.rowDirection), 0.01);
    EXPECT_LT(DegreesApart(back.columnDirection, view.columnDirection), 0.01);
    EXPECT_EQ(back.size, view.size);
    EXPECT_NEAR(back.pixelSpacing[0], view.pixelSpacing[0], 1e-12);
  }
}

TEST(CArmGeometry, OrientationLettersPickTheTurnOfThePanel)
{
  // The same positioner, the image turned 90 degrees: rows towards the head, columns to the left.
  xp::CArmGeometry g = Upright(20.0, -15.0);
  g.rowOrientation = "H";
  g.columnOrientation = "L";
  const xp::XRayView turned = xp::ViewOfCArm(g, Supine, Eigen::Vector3d::Zero(), "T");
  EXPECT_GT(turned.rowDirection.y(), 0.9);
  EXPECT_GT(turned.columnDirection.x(), 0.9);
  const xp::CArmGeometry back = xp::CArmGeometryOf(turned, Supine, Eigen::Vector3d::Zero());
  EXPECT_NEAR(back.primaryAngle, 20.0, 1e-9);
  EXPECT_NEAR(back.secondaryAngle, -15.0, 1e-9);
  EXPECT_EQ(back.rowOrientation.front(), 'H');
  EXPECT_EQ(back.columnOrientation.front(), 'L');
  EXPECT_EQ(xp::OrientationLetters(Eigen::Vector3d(-0.6, -0.8, 0.0)), "AR");
  EXPECT_EQ(xp::OrientationLetters(Eigen::Vector3d(0.1, 0.0, -0.995)), "F");
}

TEST(CArmGeometry, ContradictoryTagsAreNamed)
{
  xp::CArmGeometry g = Upright(0.0, 0.0);
  g.sourceToDetector = 900.0;
  EXPECT_NE(MessageOf(g).find("Distance Source to Detector (0018,1110)"), std::string::npos) << MessageOf(g);
  g = Upright(0.0, 95.0);
  EXPECT_NE(MessageOf(g).find("Positioner Secondary Angle (0018,1511)"), std::string::npos);
  g = Upright(0.0, 0.0);
  g.rowOrientation = "Q";
  EXPECT_NE(MessageOf(g).find("Patient Orientation (0020,0020)"), std::string::npos);
  g.rowOrientation = "A"; // along the beam at 0, 0
  EXPECT_NE(MessageOf(g).find("along the beam"), std::string::npos);
  g.rowOrientation = "LH"; // midway between two axes of the panel
  EXPECT_NE(MessageOf(g).find("between two axes"), std::string::npos);
  g.rowOrientation = "L";
  g.columnOrientation = "R"; // not across the rows
  EXPECT_NE(MessageOf(g).find("Patient Orientation (0020,0020)"), std::string::npos);
}

TEST(CArmGeometry, ImagersDXCannotDescribeAreRefused)
{
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  xp::XRayView turned = reference.views[0];
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(30.0 * M_PI / 180.0, turned.NormalTowardsSource()).toRotationMatrix();
  turned.rowDirection = turn * turned.rowDirection;
  turned.columnDirection = turn * turned.columnDirection;
  EXPECT_THROW(xp::CArmGeometryOf(turned, Supine, reference.isocenter), xp::InputError);
  xp::XRayView offCentre = reference.views[0];
  offCentre.detectorCenter += 20.0 * offCentre.rowDirection;
  EXPECT_THROW(xp::CArmGeometryOf(offCentre, Supine, reference.isocenter), xp::InputError);
}
