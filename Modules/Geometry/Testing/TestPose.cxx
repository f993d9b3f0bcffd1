#include "xpPose.h"

#include "xpError.h"

#include <gtest/gtest.h>

using Eigen::Vector3d;

namespace
{
void ExpectNear(const Vector3d& a, const Vector3d& b, double tol = 1e-9)
{
  EXPECT_NEAR((a - b).norm(), 0.0, tol) << a.transpose() << " vs " << b.transpose();
}
} // namespace

TEST(Pose, AnglesRotateAboutTheRightAxesWithTheRightHand)
{
  ExpectNear(xp::RotationFromAngles(90, 0, 0) * Vector3d::UnitY(), Vector3d::UnitZ()); // pitch: Y -> Z
  ExpectNear(xp::RotationFromAngles(0, 90, 0) * Vector3d::UnitZ(), Vector3d::UnitX()); // roll: Z -> X
  ExpectNear(xp::RotationFromAngles(0, 0, 90) * Vector3d::UnitX(), Vector3d::UnitY()); // yaw: X -> Y
}

TEST(Pose, OrderIsYawRollPitch)
{
  const Eigen::Matrix3d expected = xp::RotationFromAngles(0, 0, 30) * xp::RotationFromAngles(0, 20, 0) *
    xp::RotationFromAngles(10, 0, 0);
  EXPECT_TRUE(xp::RotationFromAngles(10, 20, 30).isApprox(expected, 1e-12));
  EXPECT_FALSE(xp::RotationFromAngles(10, 20, 30).isApprox(
    xp::RotationFromAngles(10, 0, 0) * xp::RotationFromAngles(0, 20, 0) * xp::RotationFromAngles(0, 0, 30), 1e-3));
}

TEST(Pose, RotatesAboutTheIsocentre)
{
  xp::Pose pose;
  pose.yaw = 90;
  pose.translation = { 1, 2, 3 };
  const Vector3d iso(10, 0, 0);
  ExpectNear(pose.ToTransform(iso) * iso, iso + pose.translation);
  ExpectNear(pose.ToTransform(iso) * Vector3d(11, 0, 0), Vector3d(10, 1, 0) + pose.translation);
}

TEST(Pose, FromTransformRecoversAngles)
{
  xp::Pose pose;
  pose.translation = { -4, 5.5, 2 };
  pose.pitch = 3.5;
  pose.roll = -7;
  pose.yaw = 12;
  const Vector3d iso(3, -2, 1);
  const xp::Pose back = xp::Pose::FromTransform(pose.ToTransform(iso), iso);
  EXPECT_NEAR(back.pitch, 3.5, 1e-9);
  EXPECT_NEAR(back.roll, -7, 1e-9);
  EXPECT_NEAR(back.yaw, 12, 1e-9);
  ExpectNear(back.translation, pose.translation);
}

TEST(Pose, CorrectionOfALateralShiftIsTheOppositeShift)
{
  const xp::Pose misalignment = xp::Pose::Parse("5,0,0,0,0,0", "--pose");
  const xp::Pose correction = misalignment.Inverse();
  EXPECT_NEAR(correction.translation[0], -5.0, 1e-12);
  EXPECT_NEAR(correction.translation[1], 0.0, 1e-12);
  const xp::Pose rotated = xp::Pose::Parse("0,0,0,0,0,4", "--pose");
  EXPECT_NEAR(rotated.Inverse().yaw, -4.0, 1e-12);
  // Correction composed with misalignment is the identity.
  const xp::Pose m = xp::Pose::Parse("3,-2,7,1.5,-2.5,4", "--pose");
  const Eigen::Isometry3d both = m.Inverse().ToTransform(Vector3d::Zero()) * m.ToTransform(Vector3d::Zero());
  EXPECT_TRUE(both.isApprox(Eigen::Isometry3d::Identity(), 1e-12));
}

TEST(Pose, ParseRejectsBadText)
{
  EXPECT_THROW(xp::Pose::Parse("1,2,3", "--pose"), xp::InputError);
  EXPECT_THROW(xp::Pose::Parse("1,2,3,4,5,x", "--pose"), xp::InputError);
  EXPECT_THROW(xp::Pose::Parse("1,2,3,4,5,6abc", "--pose"), xp::InputError);
  EXPECT_NO_THROW(xp::Pose::Parse("1, 2,3,4,5,-6.5", "--pose"));
}

TEST(PatientPosition, HeadFirstSupineMapsLeftSuperiorAnterior)
{
  const Eigen::Isometry3d ctToRoom =
    xp::PlannedCTToRoom(xp::PatientPosition::HFS, Vector3d(100, 200, 300), Vector3d::Zero());
  ExpectNear(ctToRoom * Vector3d(100, 200, 300), Vector3d::Zero());
  ExpectNear(ctToRoom * Vector3d(110, 200, 300), Vector3d(10, 0, 0)); // patient left -> +X
  ExpectNear(ctToRoom * Vector3d(100, 200, 310), Vector3d(0, 10, 0)); // superior -> +Y (gantry)
  ExpectNear(ctToRoom * Vector3d(100, 190, 300), Vector3d(0, 0, 10)); // anterior -> +Z (up)
}

TEST(PatientSetup, PlacesItsIsocentreOrTheCTCentreAtTheRoomIsocentre)
{
  xp::PatientSetup setup;
  setup.roomIsocenter = Vector3d(1, 2, 3);
  const Vector3d ctCenter(100, 200, 300);
  // No isocentre given: the CT's centre goes to the room isocentre, HFS axes.
  ExpectNear(setup.PlannedCTToRoom(ctCenter) * ctCenter, Vector3d(1, 2, 3));
  ExpectNear(setup.PlannedCTToRoom(ctCenter) * Vector3d(100, 190, 300), Vector3d(1, 2, 13)); // anterior -> +Z
  // A given isocentre wins over the centre, and the position turns the axes.
  setup.isocenterInCT = Vector3d(50, 60, 70);
  setup.position = xp::PatientPosition::FFS;
  const Eigen::Isometry3d planned = setup.PlannedCTToRoom(ctCenter);
  ExpectNear(planned * Vector3d(50, 60, 70), Vector3d(1, 2, 3));
  ExpectNear(planned * Vector3d(50, 60, 80), Vector3d(1, -8, 3)); // superior -> -Y, feet first
  ExpectNear(setup.IsocenterInCT(ctCenter), Vector3d(50, 60, 70));
  xp::PatientSetup other = setup;
  EXPECT_EQ(other, setup);
  other.isocenterInCT.reset();
  EXPECT_NE(other, setup) << "the filters' modification time depends on this";
  EXPECT_NE(setup.Describe().find("FFS"), std::string::npos);
}

TEST(PatientPosition, OtherPositionsAreProperRotations)
{
  using P = xp::PatientPosition;
  const Vector3d anterior(0, -1, 0), superior(0, 0, 1), left(1, 0, 0);
  const Eigen::Matrix3d hfp = xp::PatientToRoomRotation(P::HFP), ffs = xp::PatientToRoomRotation(P::FFS),
                        ffp = xp::PatientToRoomRotation(P::FFP);
  ExpectNear(hfp * anterior, -Vector3d::UnitZ()); // prone: face down
  ExpectNear(hfp * superior, Vector3d::UnitY());
  ExpectNear(ffs * superior, -Vector3d::UnitY()); // feet first: head away from gantry
  ExpectNear(ffs * anterior, Vector3d::UnitZ());
  ExpectNear(ffs * left, -Vector3d::UnitX());
  ExpectNear(ffp * anterior, -Vector3d::UnitZ());
  ExpectNear(ffp * left, Vector3d::UnitX());
  for (P p : { P::HFS, P::HFP, P::FFS, P::FFP })
  {
    EXPECT_NEAR(xp::PatientToRoomRotation(p).determinant(), 1.0, 1e-12) << xp::ToString(p);
    EXPECT_EQ(xp::ParsePatientPosition(xp::ToString(p), "x"), p);
  }
  EXPECT_THROW(xp::ParsePatientPosition("HFDR", "ct/1.dcm"), xp::InputError);
}

TEST(PatientPosition, MisalignmentActsInTheRoomAfterThePlan)
{
  const Eigen::Isometry3d planned = xp::PlannedCTToRoom(xp::PatientPosition::HFS, Vector3d(0, 0, 0), Vector3d::Zero());
  const xp::Pose lateral = xp::Pose::Parse("5,0,0,0,0,0", "--pose");
  // The CT point at iso_ct ends 5 mm lateral (+X) in the room.
  ExpectNear(xp::MisalignedCTToRoom(planned, lateral, Vector3d::Zero()) * Vector3d::Zero(), Vector3d(5, 0, 0));
}

TEST(Pose, ParametersRoundTripInTheOrderOfThePoseOption)
{
  const xp::Pose pose = xp::Pose::Parse("1,2,3,4,5,6", "--pose");
  const std::array<double, 6> p = pose.Parameters();
  EXPECT_EQ(p[0], 1.0);
  EXPECT_EQ(p[3], 4.0) << "pitch";
  EXPECT_EQ(p[5], 6.0) << "yaw";
  EXPECT_EQ(xp::Pose::FromParameters(p.data()).roll, 5.0);
}

TEST(Pose, RotationAngleIsTheWholeTurnAboutItsOwnAxis)
{
  xp::Pose pose;
  EXPECT_NEAR(pose.RotationAngle(), 0.0, 1e-12);
  pose.yaw = -7.0;
  EXPECT_NEAR(pose.RotationAngle(), 7.0, 1e-9) << "an angle, never negative";
  // 3 and 4 degrees about two axes turn about 5 degrees in all: more than either limit per axis.
  pose.yaw = 0.0;
  pose.pitch = 3.0;
  pose.roll = 4.0;
  EXPECT_NEAR(pose.RotationAngle(), 5.0, 0.01);
}
