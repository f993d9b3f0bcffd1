#include "xpCouch.h"

#include "xpError.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

constexpr double DegreesPerRadian = 180.0 / M_PI;

/** The angle of a rotation, degrees. */
double AngleOf(const Eigen::Matrix3d& rotation)
{
  return Eigen::AngleAxisd(rotation).angle() * DegreesPerRadian;
}

/** The yaw (degrees) that leaves the smallest rotation in Rz(yaw) A, and that rotation's trace:
 *  trace(Rz(g) A) = cos g (a00 + a11) + sin g (a01 - a10) + a22 is largest at
 *  g = atan2(a01 - a10, a00 + a11). */
double BestYaw(const Eigen::Matrix3d& a, double* trace = nullptr)
{
  const double c = a(0, 0) + a(1, 1), s = a(0, 1) - a(1, 0);
  if (trace)
    *trace = std::hypot(c, s) + a(2, 2);
  return std::atan2(s, c) * DegreesPerRadian;
}

/** The trace left by pitch and roll (degrees) with the best yaw: larger is a smaller rotation. */
double TraceLeft(double pitch, double roll, const Eigen::Matrix3d& misalignment)
{
  double trace = 0.0;
  BestYaw(RotationFromAngles(pitch, roll, 0.0) * misalignment, &trace);
  return trace;
}

/** The largest of f on [low, high] for a function with one maximum there (golden sections). */
template <typename F>
double Maximise(F f, double low, double high)
{
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double a = low, b = high;
  double x1 = b - ratio * (b - a), x2 = a + ratio * (b - a);
  double f1 = f(x1), f2 = f(x2);
  while (b - a > 1e-9)
  {
    if (f1 < f2)
    {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + ratio * (b - a);
      f2 = f(x2);
    }
    else
    {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - ratio * (b - a);
      f1 = f(x1);
    }
  }
  return (a + b) / 2.0;
}

} // namespace

CouchMotions ParseCouchMotions(const std::string& text, const std::string& field)
{
  if (text == "6dof")
    return CouchMotions::SixDOF;
  if (text == "4dof")
    return CouchMotions::FourDOF;
  throw InputError(field, "expected 6dof or 4dof, got '" + text + "'");
}

std::string CouchMotionsName(CouchMotions motions)
{
  return motions == CouchMotions::FourDOF ? "4dof" : "6dof";
}

std::vector<std::string> CouchMotionList(CouchMotions motions)
{
  if (motions == CouchMotions::FourDOF)
    return { "lateral", "longitudinal", "vertical", "yaw" };
  return { "lateral", "longitudinal", "vertical", "pitch", "roll", "yaw" };
}

void CouchDescription::Validate(const std::string& field) const
{
  if (!(this->pitchRollLimitDegrees >= 0.0 && this->pitchRollLimitDegrees <= 180.0) && !std::isinf(this->pitchRollLimitDegrees))
    throw InputError(field, "the pitch and roll limit must be from 0 to 180 degrees (got " +
        std::to_string(this->pitchRollLimitDegrees) + ")");
  if (this->pitchRollLimitDegrees < 0.0)
    throw InputError(field, "the pitch and roll limit must be 0 degrees or more");
  if (this->rotationCenter && !this->rotationCenter->allFinite())
    throw InputError(field, "the rotation centre must be three finite numbers (Room mm)");
}

std::string CouchDescription::Describe() const
{
  std::string text = CouchMotionsName(this->motions);
  char buffer[160];
  if (this->motions == CouchMotions::SixDOF)
  {
    if (std::isfinite(this->pitchRollLimitDegrees))
    {
      std::snprintf(buffer, sizeof buffer, ", pitch and roll within +-%g deg", this->pitchRollLimitDegrees);
      text += buffer;
    }
    else
      text += ", pitch and roll unlimited";
  }
  if (this->rotationCenter)
  {
    std::snprintf(buffer, sizeof buffer, ", rotating about (%.1f, %.1f, %.1f) mm", (*this->rotationCenter)[0],
      (*this->rotationCenter)[1], (*this->rotationCenter)[2]);
    text += buffer;
  }
  else
    text += ", rotating about the isocentre";
  return text;
}

bool CouchDescription::operator==(const CouchDescription& other) const
{
  const bool limitsEqual = this->pitchRollLimitDegrees == other.pitchRollLimitDegrees;
  const bool centresEqual = this->rotationCenter.has_value() == other.rotationCenter.has_value() &&
    (!this->rotationCenter || this->rotationCenter->isApprox(*other.rotationCenter, 1e-12));
  return this->motions == other.motions && limitsEqual && centresEqual;
}

void ActionLevels::Validate() const
{
  const auto check = [](double value, const char* option, bool zeroAllowed)
  {
    if (!(value >= 0.0) || (!zeroAllowed && value == 0.0) || (std::isinf(value) && zeroAllowed))
      throw InputError(option, std::string("must be ") + (zeroAllowed ? "0 or more (and finite)" : "more than 0") +
          " (got " + std::to_string(value) + ")");
  };
  check(this->actionMM, "--action-level-mm", true);
  check(this->actionDegrees, "--action-level-deg", true);
  check(this->maxUncorrectedMM, "--max-uncorrected-mm", false);
  check(this->maxUncorrectedDegrees, "--max-uncorrected-deg", false);
}

std::string CouchActionName(CouchAction action)
{
  switch (action)
  {
    case CouchAction::NoneNeeded:
      return "none_needed";
    case CouchAction::SetUpAgain:
      return "set_up_again";
    case CouchAction::Move:
      break;
  }
  return "move";
}

Eigen::Isometry3d CouchMotion::Transform() const
{
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = this->motion.Rotation();
  transform.translation() = this->rotationCenter + this->motion.translation - transform.linear() * this->rotationCenter;
  return transform;
}

std::string CouchMotion::Describe() const
{
  char text[600];
  std::string limits;
  for (const std::string& limit : this->limitedBy)
    limits += (limits.empty() ? "; limited by " : ", ") + limit;
  std::snprintf(text, sizeof text,
    "couch (%s): %s: translation (%.2f, %.2f, %.2f) mm, pitch %.2f roll %.2f yaw %.2f deg\n"
    "  uncorrected: pitch %.2f roll %.2f yaw %.2f deg (%.2f mm at 50 mm, %.2f mm at 100 mm from the target)%s",
    this->couch.Describe().c_str(), CouchActionName(this->action).c_str(), this->motion.translation[0],
    this->motion.translation[1], this->motion.translation[2], this->motion.pitch, this->motion.roll, this->motion.yaw,
    this->uncorrected.pitch, this->uncorrected.roll, this->uncorrected.yaw, this->uncorrectedAt50MM,
    this->uncorrectedAt100MM, limits.c_str());
  return text;
}

std::string CouchMotion::Summary() const
{
  char text[300];
  std::snprintf(text, sizeof text, "%s %s (%.2f, %.2f, %.2f) mm, pitch %.2f roll %.2f yaw %.2f deg, %.2f deg uncorrected",
    CouchMotionsName(this->couch.motions).c_str(), CouchActionName(this->action).c_str(), this->motion.translation[0],
    this->motion.translation[1], this->motion.translation[2], this->motion.pitch, this->motion.roll, this->motion.yaw,
    this->uncorrected.RotationAngle());
  return text;
}

CouchMotion PlanCouchMotion(const Pose& misalignment, const Eigen::Vector3d& isocenter, const Eigen::Vector3d& target,
  const CouchDescription& couch, const ActionLevels& levels)
{
  CouchMotion plan;
  plan.couch = couch;
  plan.rotationCenter = couch.rotationCenter.value_or(isocenter);
  plan.target = target;
  const Eigen::Matrix3d rotation = misalignment.Rotation();
  const Pose exact = misalignment.Inverse();
  // The couch's rotation: the exact correction's where the couch has it, else the one that
  // leaves the smallest rotation (largest trace of R_c R) within its motions and limits.
  double pitch = exact.pitch, roll = exact.roll, yaw = exact.yaw;
  constexpr double Unneeded = 1e-9; // degrees: an angle the correction does not need
  if (couch.motions == CouchMotions::FourDOF)
  {
    pitch = roll = 0.0;
    yaw = BestYaw(rotation);
    if (std::abs(exact.pitch) > Unneeded)
      plan.limitedBy.push_back("no_pitch");
    if (std::abs(exact.roll) > Unneeded)
      plan.limitedBy.push_back("no_roll");
  }
  else if (std::abs(exact.pitch) > couch.pitchRollLimitDegrees || std::abs(exact.roll) > couch.pitchRollLimitDegrees)
  {
    // Within the box of pitch and roll, one at a time from the clipped angles: the trace is
    // smooth with one maximum there, and a few rounds settle it to far below a thousandth of
    // a degree.
    const double limit = couch.pitchRollLimitDegrees;
    pitch = std::clamp(exact.pitch, -limit, limit);
    roll = std::clamp(exact.roll, -limit, limit);
    for (int round = 0; round < 30; ++round)
    {
      const double lastPitch = pitch, lastRoll = roll;
      pitch = Maximise([&](double p) { return TraceLeft(p, roll, rotation); }, -limit, limit);
      roll = Maximise([&](double r) { return TraceLeft(pitch, r, rotation); }, -limit, limit);
      if (std::abs(pitch - lastPitch) < 1e-8 && std::abs(roll - lastRoll) < 1e-8)
        break;
    }
    yaw = BestYaw(RotationFromAngles(pitch, roll, 0.0) * rotation);
    const double atLimit = limit - 1e-6;
    if (std::abs(pitch) >= atLimit && std::abs(exact.pitch) > limit)
      plan.limitedBy.push_back("pitch_limit");
    if (std::abs(roll) >= atLimit && std::abs(exact.roll) > limit)
      plan.limitedBy.push_back("roll_limit");
    if (plan.limitedBy.empty()) // the other angle took the whole shortfall
      plan.limitedBy.push_back(std::abs(exact.pitch) > limit ? "pitch_limit" : "roll_limit");
  }
  plan.motion.pitch = pitch;
  plan.motion.roll = roll;
  plan.motion.yaw = yaw;
  // The translation that puts the misaligned target back: t_c = target - c - R_c (target' - c).
  const Eigen::Vector3d misplaced = misalignment.ToTransform(isocenter) * target;
  const Eigen::Matrix3d couchRotation = plan.motion.Rotation();
  plan.motion.translation = target - plan.rotationCenter - couchRotation * (misplaced - plan.rotationCenter);
  plan.uncorrected = Pose::FromTransform(plan.Transform() * misalignment.ToTransform(isocenter), isocenter);
  const double left = AngleOf(plan.uncorrected.Rotation());
  const auto chord = [left](double radius) { return 2.0 * radius * std::sin(left / DegreesPerRadian / 2.0); };
  plan.uncorrectedAt50MM = chord(50.0);
  plan.uncorrectedAt100MM = chord(100.0);

  char because[200];
  const double turn = plan.motion.RotationAngle(), length = plan.TranslationLength();
  if (plan.uncorrectedAt100MM > levels.maxUncorrectedMM || left > levels.maxUncorrectedDegrees)
  {
    plan.action = CouchAction::SetUpAgain;
    std::snprintf(because, sizeof because,
      "the couch leaves %.2f deg uncorrected (%.2f mm at 100 mm from the target), beyond %g deg or %g mm", left,
      plan.uncorrectedAt100MM, levels.maxUncorrectedDegrees, levels.maxUncorrectedMM);
  }
  else if (length <= levels.actionMM && turn <= levels.actionDegrees)
  {
    plan.action = CouchAction::NoneNeeded;
    std::snprintf(because, sizeof because, "the motion (%.2f mm, %.2f deg) is within the action levels (%g mm, %g deg)",
      length, turn, levels.actionMM, levels.actionDegrees);
  }
  else
  {
    plan.action = CouchAction::Move;
    std::snprintf(because, sizeof because, "the motion (%.2f mm, %.2f deg) is beyond the action levels (%g mm, %g deg)",
      length, turn, levels.actionMM, levels.actionDegrees);
  }
  plan.actionReason = because;
  return plan;
}

} // namespace xp
