// The quality gate on numbers alone: each limit fails its own code, at the right side of the
// limit, and NaN evidence never passes.
#include "xpError.h"
#include "xpQualityGate.h"
#include "xpStereoRegistration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace
{

xp::GateEvidence GoodEvidence()
{
  xp::GateEvidence evidence;
  evidence.misalignment = xp::Pose::Parse("3,-2,1,1,-1,0.5", "pose");
  evidence.converged = true;
  evidence.peakMargin = 0.2;
  evidence.uncertainty = { 0.2, 0.3, 0.2, 0.1, 0.2, 0.1 };
  for (const char* name : { "A", "B" })
  {
    xp::ViewEvidence view;
    view.name = name;
    view.validPixels = 20000;
    view.pixels = 196608;
    view.explained = 0.3;
    view.uncovered = 0.01;
    view.residualMM = 0.1;
    view.residualDegrees = 0.1;
    evidence.views.push_back(view);
  }
  return evidence;
}

std::vector<xp::GateCode> Codes(const xp::GateEvidence& evidence, const xp::StereoRegistrationSettings& settings = {})
{
  std::vector<xp::GateCode> codes;
  for (const xp::GateFailure& failure : xp::CheckQuality(evidence, settings))
    codes.push_back(failure.code);
  return codes;
}

using Codes_t = std::vector<xp::GateCode>;

} // namespace

TEST(QualityGate, PassesGoodEvidence)
{
  EXPECT_TRUE(xp::CheckQuality(GoodEvidence(), {}).empty());
}

TEST(QualityGate, FailsAViewWhoseMasksKeepAFewPercent)
{
  xp::GateEvidence e = GoodEvidence();
  e.views[1].validPixels = 9800; // 4.98 % of 512 x 384
  const std::vector<xp::GateFailure> failures = xp::CheckQuality(e, {});
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].code, xp::GateCode::TooFewPixels);
  EXPECT_EQ(failures[0].view, 1);
  e.views[1].validPixels = 9831; // 5.0 %
  EXPECT_TRUE(xp::CheckQuality(e, {}).empty());
}

TEST(QualityGate, FailsAResultThatDoesNotStandOutOrIsUncertain)
{
  xp::GateEvidence e = GoodEvidence();
  e.peakMargin = -0.01; // a neighbour scores 1 % higher on the held-out similarity
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::NotDistinct });
  e.peakMargin = 0.139;  // the result leads its neighbours by less than 14 %
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::NotDistinct });
  e.peakMargin = 0.14;   // on the limit passes
  EXPECT_TRUE(Codes(e).empty());
  e.peakMargin = std::nan("");
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::NotDistinct });

  // Each axis against its own limit: translations in mm (3), rotations in degrees (1.5).
  e = GoodEvidence();
  e.uncertainty[1] = 3.01;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::Uncertain });
  e.uncertainty[1] = 2.99;
  e.uncertainty[4] = 1.51;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::Uncertain });
  e.uncertainty[4] = std::numeric_limits<double>::infinity(); // no maximum along roll
  const std::vector<xp::GateFailure> failures = xp::CheckQuality(e, {});
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_NE(failures[0].message.find("roll the result is no maximum"), std::string::npos) << failures[0].message;
  e.uncertainty[4] = std::nan("");
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::Uncertain });
}

TEST(QualityGate, EachLimitFailsItsOwnCodeAndNamesTheView)
{
  xp::StereoRegistrationSettings settings;
  xp::GateEvidence e = GoodEvidence();
  e.converged = false;
  e.stopReason = "evaluation limit";
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::NotConverged });

  e = GoodEvidence();
  e.misalignment.translation = Eigen::Vector3d(30, 30, 30); // 52 mm long, 30 on each axis
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::TranslationTooLarge });
  e = GoodEvidence();
  e.misalignment.yaw = 10.5;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::RotationTooLarge });
  e = GoodEvidence();
  e.ambiguous = true;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::AmbiguousPose });

  e = GoodEvidence();
  e.views[1].explained = settings.minExplained - 0.001;
  const std::vector<xp::GateFailure> low = xp::CheckQuality(e, settings);
  ASSERT_EQ(low.size(), 1u);
  EXPECT_EQ(low[0].code, xp::GateCode::LowExplained);
  EXPECT_EQ(low[0].view, 1);
  EXPECT_NE(low[0].message.find("view B"), std::string::npos) << low[0].message;
  e.views[1].explained = settings.minExplained; // on the limit passes
  EXPECT_TRUE(Codes(e).empty());

  e = GoodEvidence();
  e.views[0].pixels = 12000;     // a small view: the fraction (5 %) asks for 600
  e.views[0].validPixels = 2047; // 32 x 32 cells, 2 pixels each
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::TooFewPixels });
  e.views[0].validPixels = 2048;
  EXPECT_TRUE(Codes(e).empty());
  settings.bins = 16; // fewer cells, fewer pixels needed
  e.views[0].validPixels = 600;
  EXPECT_TRUE(Codes(e, settings).empty());
  settings = {};

  e = GoodEvidence();
  e.views[0].uncovered = settings.maxUncovered + 0.01;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::UncoveredAnatomy });
  e = GoodEvidence();
  e.views[0].residualMM = settings.maxViewResidual + 0.01;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::ViewDisagrees });
  e = GoodEvidence();
  e.views[0].residualDegrees = -(settings.maxViewResidualDegrees + 0.01); // a turn either way
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::ViewDisagrees });
}

TEST(QualityGate, HalvesMayEndFartherApartOnlyWhereTheHeldOutPeakIsClear)
{
  // Halves 1.1 mm apart: over the 1 mm limit, under the clear peak's 1.25 mm.
  xp::GateEvidence e = GoodEvidence();
  e.peakMargin = 0.169; // a lead above the 14 % limit but not clear
  e.views[1].halvesApartMM = 1.1;
  const std::vector<xp::GateFailure> failures = xp::CheckQuality(e, {});
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].code, xp::GateCode::HalvesDisagree);
  EXPECT_EQ(failures[0].view, 1);
  EXPECT_NE(failures[0].message.find("1.10 mm apart (> 1.00 mm)"), std::string::npos) << failures[0].message;
  e.peakMargin = 0.17; // clear: on the limit passes
  EXPECT_TRUE(Codes(e).empty());
  e.views[1].halvesApartMM = 1.25;
  EXPECT_TRUE(Codes(e).empty());
  e.views[1].halvesApartMM = 1.26; // beyond the clear peak's limit: the message says why it was wider
  const std::vector<xp::GateFailure> far = xp::CheckQuality(e, {});
  ASSERT_EQ(far.size(), 1u);
  EXPECT_EQ(far[0].code, xp::GateCode::HalvesDisagree);
  EXPECT_NE(far[0].message.find("1.26 mm apart (> 1.25 mm, with the held-out peak leading by 17.0 %)"), std::string::npos)
    << far[0].message;
  e.views[1].halvesApartMM = 1.1;
  e.peakMargin = std::nan(""); // no lead measured: neither clear nor distinct
  EXPECT_EQ(Codes(e), (Codes_t{ xp::GateCode::NotDistinct, xp::GateCode::HalvesDisagree }));
  e.views[1].halvesApartMM = std::nan("");
  e.peakMargin = 0.3;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::HalvesDisagree });

  // The settings: a clear limit under the plain one never narrows it; a clear margin of 1 never
  // widens it (no lead reaches 100 %).
  xp::StereoRegistrationSettings settings;
  e = GoodEvidence();
  e.views[0].halvesApartMM = 1.4;
  settings.maxHalvesApartMM = 1.5;
  settings.maxHalvesApartClearPeakMM = 1.2;
  EXPECT_TRUE(Codes(e, settings).empty());
  settings = {};
  settings.clearPeakMargin = 1.0;
  e.views[0].halvesApartMM = 1.1;
  EXPECT_EQ(Codes(e, settings), Codes_t{ xp::GateCode::HalvesDisagree });
}

TEST(QualityGate, NaNEvidenceFails)
{
  xp::GateEvidence e = GoodEvidence();
  e.misalignment.translation[2] = std::nan("");
  e.misalignment.pitch = std::nan("");
  e.views[0].explained = std::nan("");
  e.views[0].uncovered = std::nan("");
  e.views[1].residualMM = std::nan("");
  EXPECT_EQ(Codes(e), (Codes_t{ xp::GateCode::TranslationTooLarge, xp::GateCode::RotationTooLarge, xp::GateCode::LowExplained,
                        xp::GateCode::UncoveredAnatomy, xp::GateCode::ViewDisagrees }));
}

TEST(QualityGate, InvalidLimitsAreRefusedAndCodesHaveStableNames)
{
  xp::StereoRegistrationSettings settings;
  settings.maxViewResidualDegrees = std::nan("");
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.minExplained = 1.5;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.minValidPixelsPerCell = -1.0;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.coverageMinExcess = std::nan("");
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.boneCorrelationHighPassMM = -1.0;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.maxRefinedApartDegrees = std::nan("");
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.maxSearchDisagreementDegrees = 0.0;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.maxSearchDisagreementMM = -0.5;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings = {};
  settings.maxSearchDisagreementMM = 0.0; // one search
  EXPECT_NO_THROW(xp::ValidateGateLimits(settings));
  settings = {};
  settings.maxHalvesApartClearPeakMM = -1.0;
  try
  {
    xp::ValidateGateLimits(settings);
    ADD_FAILURE() << "a negative clear-peak halves limit was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("maxHalvesApartClearPeakMM"), std::string::npos) << e.what();
  }
  settings = {};
  settings.clearPeakMargin = std::nan("");
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  EXPECT_NO_THROW(xp::ValidateGateLimits({}));
  EXPECT_STREQ(xp::GateCodeName(xp::GateCode::LowExplained), "low_explained");
  EXPECT_STREQ(xp::GateCodeName(xp::GateCode::AmbiguousPose), "ambiguous_pose");
  EXPECT_STREQ(xp::GateCodeName(xp::GateCode::TooFewPixels), "too_few_pixels");
}

// From an initial pose, the limits bound the change from it, not the distance from zero: a
// bone 180 mm from the isocentre that moved 2 mm passes, a result 52 mm from its start fails.
TEST(QualityGate, MotionLimitsCountFromTheInitialPose)
{
  xp::GateEvidence e = GoodEvidence();
  e.start = xp::Pose::Parse("150,-60,40,80,-30,120", "start");
  e.misalignment = xp::Pose::Parse("151,-61,41.5,80.5,-30,119", "result");
  EXPECT_TRUE(Codes(e).empty());
  e.misalignment = xp::Pose::Parse("180,-30,70,80,-30,120", "result"); // 52 mm from the start
  const std::vector<xp::GateFailure> failures = xp::CheckQuality(e, {});
  ASSERT_EQ(failures.size(), 1u);
  EXPECT_EQ(failures[0].code, xp::GateCode::TranslationTooLarge);
  EXPECT_NE(failures[0].message.find("initial pose"), std::string::npos) << failures[0].message;
  e.misalignment = xp::Pose::Parse("150,-60,40,80,-30,131", "result"); // 11 degrees about z from the start
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::RotationTooLarge });
  e.start = xp::Pose{};
  e.misalignment = xp::Pose::Parse("151,-61,41.5,80.5,-30,119", "result");
  EXPECT_EQ(Codes(e), (Codes_t{ xp::GateCode::TranslationTooLarge, xp::GateCode::RotationTooLarge }));
}

// A bone's refinements restarted around the result must come back within 0.5 mm and 0.5
// degrees; not run (negative) for a body.
TEST(QualityGate, RestartsThatDoNotComeBackFail)
{
  xp::GateEvidence e = GoodEvidence();
  e.restartsApartMM = 0.3;
  e.restartsApartDegrees = 0.45;
  EXPECT_TRUE(Codes(e).empty());
  e.restartsApartMM = 0.6;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::RestartsDisagree });
  e.restartsApartMM = 0.3;
  e.restartsApartDegrees = 0.55;
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::RestartsDisagree });
  e.restartsApartDegrees = std::nan("");
  EXPECT_EQ(Codes(e), Codes_t{ xp::GateCode::RestartsDisagree });
  EXPECT_STREQ(xp::GateCodeName(xp::GateCode::RestartsDisagree), "restarts_disagree");
}


TEST(QualityGate, HeldOutCheckSettingsOutOfRangeAreRefusedByName)
{
  xp::StereoRegistrationSettings settings;
  EXPECT_NO_THROW(xp::ValidateGateLimits(settings));
  settings.heldOutShadowMarginMM = std::nan("");
  try
  {
    xp::ValidateGateLimits(settings);
    FAIL() << "a NaN margin was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("heldOutShadowMarginMM"), std::string::npos) << e.what();
  }
  settings.heldOutShadowMarginMM = 5.0;
  settings.heldOutHighPassMM = -1.0;
  EXPECT_THROW(xp::ValidateGateLimits(settings), xp::InputError);
  settings.heldOutHighPassMM = 20.0;
  settings.boneMinPeakMargin = 1.5;
  try
  {
    xp::ValidateGateLimits(settings);
    FAIL() << "a bone's peak margin above 1 was accepted";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("boneMinPeakMargin"), std::string::npos) << e.what();
  }
}
