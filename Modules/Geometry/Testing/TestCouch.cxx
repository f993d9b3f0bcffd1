#include "xpCouch.h"
#include "xpError.h"
#include "xpStereoGeometry.h"

#include <gtest/gtest.h>

#include <cmath>

using Eigen::Vector3d;

namespace
{

constexpr double Radians = M_PI / 180.0;

xp::Pose MakePose(double tx, double ty, double tz, double pitch, double roll, double yaw)
{
  const double parameters[6] = { tx, ty, tz, pitch, roll, yaw };
  return xp::Pose::FromParameters(parameters);
}

xp::CouchDescription Couch(xp::CouchMotions motions, double limit = std::numeric_limits<double>::infinity())
{
  xp::CouchDescription couch;
  couch.motions = motions;
  couch.pitchRollLimitDegrees = limit;
  return couch;
}

/** Where the couch motion puts the target of a patient misaligned by `misalignment`. */
Vector3d TargetAfter(const xp::CouchMotion& plan, const xp::Pose& misalignment, const Vector3d& isocenter)
{
  return plan.Transform() * (misalignment.ToTransform(isocenter) * plan.target);
}

double UncorrectedAngle(const xp::CouchMotion& plan)
{
  return plan.uncorrected.RotationAngle();
}

} // namespace

TEST(Couch, APureTranslationNeedsTheSameMotionOnEveryCouch)
{
  const xp::Pose misalignment = MakePose(4, -3, 2, 0, 0, 0);
  const Vector3d iso(0, 0, 0), target(30, -50, 20);
  xp::CouchDescription offCentre = Couch(xp::CouchMotions::SixDOF, 3.0);
  offCentre.rotationCenter = Vector3d(0, -600, -200);
  for (const xp::CouchDescription& couch :
    { Couch(xp::CouchMotions::SixDOF), Couch(xp::CouchMotions::FourDOF), Couch(xp::CouchMotions::SixDOF, 3.0), offCentre })
  {
    const xp::CouchMotion plan = xp::PlanCouchMotion(misalignment, iso, target, couch, {});
    EXPECT_NEAR((plan.motion.translation - Vector3d(-4, 3, -2)).norm(), 0.0, 1e-9) << couch.Describe();
    EXPECT_NEAR(plan.motion.RotationAngle(), 0.0, 1e-9) << couch.Describe();
    EXPECT_TRUE(plan.limitedBy.empty()) << couch.Describe();
    EXPECT_NEAR(UncorrectedAngle(plan), 0.0, 1e-9);
    EXPECT_EQ(plan.action, xp::CouchAction::Move);
  }
}

TEST(Couch, AnUnlimitedSixDOFCouchCarriesOutTheExactCorrection)
{
  const xp::Pose misalignment = MakePose(3, -2, 5, 2.5, -1.5, 4);
  const Vector3d iso(0, 0, 0);
  const xp::CouchMotion plan = xp::PlanCouchMotion(misalignment, iso, iso, Couch(xp::CouchMotions::SixDOF), {});
  const xp::Pose exact = misalignment.Inverse();
  EXPECT_NEAR((plan.motion.translation - exact.translation).norm(), 0.0, 1e-9);
  EXPECT_NEAR(plan.motion.pitch, exact.pitch, 1e-9);
  EXPECT_NEAR(plan.motion.roll, exact.roll, 1e-9);
  EXPECT_NEAR(plan.motion.yaw, exact.yaw, 1e-9);
  EXPECT_NEAR(UncorrectedAngle(plan), 0.0, 1e-9);
  EXPECT_NEAR(plan.uncorrected.translation.norm(), 0.0, 1e-9);
}

TEST(Couch, AYawOnlyMisalignmentIsFullyCorrectedByAFourDOFCouch)
{
  const xp::Pose misalignment = MakePose(1, 2, -1, 0, 0, 3);
  const Vector3d iso(0, 0, 0), target(20, 40, -10);
  const xp::CouchMotion plan = xp::PlanCouchMotion(misalignment, iso, target, Couch(xp::CouchMotions::FourDOF), {});
  EXPECT_NEAR(plan.motion.yaw, -3.0, 1e-9); // the correction turns back: a sign flip fails here
  EXPECT_EQ(plan.motion.pitch, 0.0);
  EXPECT_EQ(plan.motion.roll, 0.0);
  EXPECT_NEAR(UncorrectedAngle(plan), 0.0, 1e-9);
  EXPECT_TRUE(plan.limitedBy.empty());
  EXPECT_NEAR((TargetAfter(plan, misalignment, iso) - target).norm(), 0.0, 1e-9);
}

TEST(Couch, APitchOfTwoDegreesWithTheTarget80mmAwayOnAFourDOFCouch)
{
  // By hand: the target (0, 80, 0) pitched by 2 degrees about X through the isocentre moves to
  // (0, 80 cos 2, 80 sin 2) = (0, 79.95127, 2.79196); the couch cannot pitch, so it translates
  // by the difference, (0, +0.04873, -2.79196) mm, and leaves the 2 degrees.
  const xp::Pose misalignment = MakePose(0, 0, 0, 2, 0, 0);
  const Vector3d iso(0, 0, 0), target(0, 80, 0);
  const xp::CouchMotion plan = xp::PlanCouchMotion(misalignment, iso, target, Couch(xp::CouchMotions::FourDOF), {});
  EXPECT_NEAR(plan.motion.translation.x(), 0.0, 1e-6);
  EXPECT_NEAR(plan.motion.translation.y(), 0.04873, 1e-5);
  EXPECT_NEAR(plan.motion.translation.z(), -2.79196, 1e-5);
  EXPECT_NEAR(plan.motion.yaw, 0.0, 1e-9);
  EXPECT_NEAR((TargetAfter(plan, misalignment, iso) - target).norm(), 0.0, 0.01);
  EXPECT_NEAR(plan.uncorrected.pitch, 2.0, 1e-9);
  EXPECT_NEAR(plan.uncorrected.roll, 0.0, 1e-9);
  EXPECT_NEAR(plan.uncorrectedAt50MM, 2 * 50 * std::sin(1.0 * Radians), 1e-9);
  EXPECT_NEAR(plan.uncorrectedAt100MM, 2 * 100 * std::sin(1.0 * Radians), 1e-9);
  ASSERT_EQ(plan.limitedBy.size(), 1u);
  EXPECT_EQ(plan.limitedBy[0], "no_pitch");
}

TEST(Couch, TheRotationCentreChangesTheTranslationNotWhereTheTargetEnds)
{
  const xp::Pose misalignment = MakePose(2, -1, 3, 0, 0, 4);
  const Vector3d iso(0, 0, 0), target(10, 60, 0);
  xp::CouchDescription eccentric = Couch(xp::CouchMotions::FourDOF);
  eccentric.rotationCenter = Vector3d(0, -800, 0); // a couch turning 800 mm towards its foot
  const xp::CouchMotion about = xp::PlanCouchMotion(misalignment, iso, target, Couch(xp::CouchMotions::FourDOF), {});
  const xp::CouchMotion away = xp::PlanCouchMotion(misalignment, iso, target, eccentric, {});
  EXPECT_NEAR((TargetAfter(about, misalignment, iso) - target).norm(), 0.0, 1e-9);
  EXPECT_NEAR((TargetAfter(away, misalignment, iso) - target).norm(), 0.0, 1e-9);
  EXPECT_NEAR(about.motion.yaw, away.motion.yaw, 1e-12);
  // Turning by yaw -4 degrees about c = (0, -800, 0) instead of the isocentre swings the
  // isocentre to R_c (0 - c) + c = (800 sin 4, 800 cos 4 - 800, 0), 55.8 mm towards +X: the
  // translation takes it back.
  const Vector3d swing = eccentric.rotationCenter.value() - about.motion.Rotation() * eccentric.rotationCenter.value();
  EXPECT_NEAR((away.motion.translation - (about.motion.translation - swing)).norm(), 0.0, 1e-9);
  EXPECT_GT(swing.norm(), 50.0);
  EXPECT_NEAR(swing.x(), 800 * std::sin(4 * Radians), 1e-6); // a sign flip of the centre fails here
}

TEST(Couch, RotationsBeyondTheLimitsAreClippedAndTheLimitNamed)
{
  const xp::Pose misalignment = MakePose(1, 1, 1, 5, 1, 2);
  const Vector3d iso(0, 0, 0), target(0, 40, 10);
  const xp::CouchMotion plan = xp::PlanCouchMotion(misalignment, iso, target, Couch(xp::CouchMotions::SixDOF, 3.0), {});
  EXPECT_NEAR(plan.motion.pitch, -3.0, 1e-6); // the correction's -5 clipped to -3
  EXPECT_LT(std::abs(plan.motion.roll), 3.0);
  ASSERT_EQ(plan.limitedBy.size(), 1u);
  EXPECT_EQ(plan.limitedBy[0], "pitch_limit");
  EXPECT_NEAR(UncorrectedAngle(plan), 2.0, 0.05);
  EXPECT_NEAR((TargetAfter(plan, misalignment, iso) - target).norm(), 0.0, 1e-9);
  // No other pitch, roll and yaw within the limits leaves less.
  const Eigen::Matrix3d rotation = misalignment.Rotation();
  for (double dp : { 0.0, 0.2 }) // -3.2 is beyond the limit
    for (double dr : { -0.2, 0.2 })
      for (double dy : { -0.2, 0.2 })
      {
        const Eigen::Matrix3d other =
          xp::RotationFromAngles(plan.motion.pitch + dp, plan.motion.roll + dr, plan.motion.yaw + dy) * rotation;
        EXPECT_GT(Eigen::AngleAxisd(other).angle() / Radians, UncorrectedAngle(plan));
      }
  // Both beyond: both named.
  const xp::CouchMotion both =
    xp::PlanCouchMotion(MakePose(0, 0, 0, -6, 4, 0), iso, target, Couch(xp::CouchMotions::SixDOF, 3.0), {});
  EXPECT_NEAR(both.motion.pitch, 3.0, 1e-6);
  EXPECT_NEAR(both.motion.roll, -3.0, 1e-6);
  EXPECT_EQ(both.limitedBy, (std::vector<std::string>{ "pitch_limit", "roll_limit" }));
}

TEST(Couch, TheFourDOFYawLeavesTheSmallestRotation)
{
  const xp::Pose misalignment = MakePose(0, 0, 0, 3, -2, 5);
  const xp::CouchMotion plan =
    xp::PlanCouchMotion(misalignment, Vector3d::Zero(), Vector3d::Zero(), Couch(xp::CouchMotions::FourDOF), {});
  for (double dy : { -0.05, 0.05 })
    EXPECT_GT(Eigen::AngleAxisd(xp::RotationFromAngles(0, 0, plan.motion.yaw + dy) * misalignment.Rotation()).angle(),
      Eigen::AngleAxisd(plan.uncorrected.Rotation()).angle());
  EXPECT_NEAR(plan.motion.yaw, -5.0, 0.2);
  EXPECT_EQ(plan.limitedBy, (std::vector<std::string>{ "no_pitch", "no_roll" }));
}

TEST(Couch, ActionLevelsAndUncorrectedLimitsDecide)
{
  const Vector3d iso(0, 0, 0);
  xp::ActionLevels levels;
  levels.actionMM = 1.0;
  levels.actionDegrees = 1.0;
  const xp::CouchDescription fourDOF = Couch(xp::CouchMotions::FourDOF);
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0.5, 0.5, 0, 0, 0, 0.5), iso, iso, fourDOF, levels).action, xp::CouchAction::NoneNeeded);
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(1.5, 0, 0, 0, 0, 0), iso, iso, fourDOF, levels).action, xp::CouchAction::Move);
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0, 0, 0, 0, 0, 1.5), iso, iso, fourDOF, levels).action, xp::CouchAction::Move);
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0.5, 0, 0, 0, 0, 0), iso, iso, fourDOF, {}).action, xp::CouchAction::Move)
    << "default levels: every motion is a move";
  // A pitch of 2 degrees the couch cannot do: 3.49 mm at 100 mm from the target.
  levels.maxUncorrectedDegrees = 1.5;
  const xp::CouchMotion pitched = xp::PlanCouchMotion(MakePose(0.2, 0, 0, 2, 0, 0), iso, iso, fourDOF, levels);
  EXPECT_EQ(pitched.action, xp::CouchAction::SetUpAgain) << "whatever the action levels say";
  levels.maxUncorrectedDegrees = 2.5;
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0.2, 0, 0, 2, 0, 0), iso, iso, fourDOF, levels).action, xp::CouchAction::NoneNeeded);
  levels.maxUncorrectedMM = 3.0;
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0.2, 0, 0, 2, 0, 0), iso, iso, fourDOF, levels).action, xp::CouchAction::SetUpAgain);
  levels.maxUncorrectedMM = 3.6;
  EXPECT_EQ(xp::PlanCouchMotion(MakePose(0.2, 0, 0, 2, 0, 0), iso, iso, fourDOF, levels).action, xp::CouchAction::NoneNeeded);
  EXPECT_EQ(xp::CouchActionName(xp::CouchAction::SetUpAgain), "set_up_again");
}

TEST(Couch, BadLevelsAndDescriptionsAreRefusedByName)
{
  xp::ActionLevels levels;
  levels.actionMM = -1;
  try
  {
    levels.Validate();
    FAIL() << "a negative action level passed";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("--action-level-mm"), std::string::npos) << e.what();
  }
  levels = {};
  levels.maxUncorrectedDegrees = std::nan("");
  EXPECT_THROW(levels.Validate(), xp::InputError);
  levels = {};
  levels.maxUncorrectedMM = 0.0;
  EXPECT_THROW(levels.Validate(), xp::InputError);
  EXPECT_NO_THROW(xp::ActionLevels{}.Validate());
  EXPECT_THROW(xp::ParseCouchMotions("5dof", "--couch"), xp::InputError);
  EXPECT_THROW(Couch(xp::CouchMotions::SixDOF, -1.0).Validate("--couch-rotation-limit"), xp::InputError);
  EXPECT_THROW(Couch(xp::CouchMotions::SixDOF, std::nan("")).Validate("--couch-rotation-limit"), xp::InputError);
  EXPECT_NO_THROW(Couch(xp::CouchMotions::SixDOF).Validate("--couch-rotation-limit"));
}

namespace
{
const char* Imagers = R"("imagers": [
    { "name": "A", "source": [-707.107, 0, -707.107],
      "detector": { "center": [353.553, 0, 353.553], "row_direction": [-0.707107, 0, 0.707107],
        "column_direction": [0, -1, 0], "pixel_spacing": [0.390625, 0.390625], "size": [1024, 768] } },
    { "name": "B", "source": [707.107, 0, -707.107],
      "detector": { "center": [-353.553, 0, 353.553], "row_direction": [-0.707107, 0, -0.707107],
        "column_direction": [0, -1, 0], "pixel_spacing": [0.390625, 0.390625], "size": [1024, 768] } } ])";

std::string RefusalOf(const std::string& text)
{
  try
  {
    xp::ParseStereoGeometry(text, "room.json");
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}
} // namespace

TEST(Couch, TheGeometryFileCarriesACouchFromVersionTwo)
{
  const xp::StereoGeometry old = xp::ParseStereoGeometry(std::string("{") + Imagers + "}", "room.json");
  EXPECT_FALSE(old.couch.has_value());
  const xp::StereoGeometry room = xp::ParseStereoGeometry(std::string(R"({ "format_version": 2,
    "couch": { "motions": "4dof", "rotation_limit_deg": 3, "rotation_center": [0, -10, 5] }, )") + Imagers + "}",
    "room.json");
  ASSERT_TRUE(room.couch.has_value());
  EXPECT_EQ(room.couch->motions, xp::CouchMotions::FourDOF);
  EXPECT_EQ(room.couch->pitchRollLimitDegrees, 3.0);
  EXPECT_EQ(room.couch->rotationCenter.value(), Vector3d(0, -10, 5));
  // Written and read back.
  const xp::StereoGeometry again = xp::ParseStereoGeometry(xp::FormatStereoGeometry(room), "again.json");
  ASSERT_TRUE(again.couch.has_value());
  EXPECT_TRUE(*again.couch == *room.couch);
  EXPECT_EQ(xp::FormatStereoGeometry(old).find("format_version"), std::string::npos);

  EXPECT_NE(RefusalOf(std::string(R"({ "format_version": 3, )") + Imagers + "}").find("room.json: format_version"),
    std::string::npos);
  EXPECT_NE(RefusalOf(std::string(R"({ "couch": { "motions": "4dof" }, )") + Imagers + "}").find("room.json: couch"),
    std::string::npos);
  EXPECT_NE(RefusalOf(std::string(R"({ "format_version": 2, "couch": { "motions": "5dof" }, )") + Imagers + "}")
              .find("room.json: couch.motions"),
    std::string::npos);
  EXPECT_NE(RefusalOf(std::string(R"({ "format_version": 2, "couch": { "motions": "6dof", "rotation_limit_deg": -3 }, )") +
              Imagers + "}")
              .find("room.json: couch.rotation_limit_deg"),
    std::string::npos);
  EXPECT_NE(RefusalOf(std::string(R"({ "format_version": 2, "couch": { "motions": "6dof", "pitch_limit": 3 }, )") + Imagers +
              "}")
              .find("room.json: couch.pitch_limit"),
    std::string::npos);
}
