#include "xpPose.h"

#include "xpError.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <vector>

namespace xp
{

namespace
{
constexpr double DegreesPerRadian = 180.0 / M_PI;
}

Eigen::Matrix3d RotationFromAngles(double pitch, double roll, double yaw)
{
  using Eigen::AngleAxisd;
  return (AngleAxisd(yaw / DegreesPerRadian, Eigen::Vector3d::UnitZ()) *
    AngleAxisd(roll / DegreesPerRadian, Eigen::Vector3d::UnitY()) *
    AngleAxisd(pitch / DegreesPerRadian, Eigen::Vector3d::UnitX()))
    .toRotationMatrix();
}

Eigen::Matrix3d Pose::Rotation() const
{
  return RotationFromAngles(this->pitch, this->roll, this->yaw);
}

double Pose::RotationAngle() const
{
  return Eigen::AngleAxisd(this->Rotation()).angle() * DegreesPerRadian;
}

Eigen::Isometry3d Pose::ToTransform(const Eigen::Vector3d& isocenter) const
{
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = this->Rotation();
  transform.translation() = isocenter + this->translation - transform.linear() * isocenter;
  return transform;
}

Pose Pose::FromTransform(const Eigen::Isometry3d& transform, const Eigen::Vector3d& isocenter)
{
  const Eigen::Matrix3d& r = transform.linear();
  Pose pose;
  // R = Rz(c) Ry(b) Rx(a): r20 = -sin b, r21 = cos b sin a, r22 = cos b cos a, r10 = sin c cos b.
  pose.roll = std::asin(std::clamp(-r(2, 0), -1.0, 1.0)) * DegreesPerRadian;
  pose.pitch = std::atan2(r(2, 1), r(2, 2)) * DegreesPerRadian;
  pose.yaw = std::atan2(r(1, 0), r(0, 0)) * DegreesPerRadian;
  pose.translation = transform * isocenter - isocenter;
  return pose;
}

Pose Pose::Inverse() const
{
  // Inverse of p -> R(p - iso) + iso + t is p -> R^T (p - iso) + iso - R^T t, independent of iso.
  const Eigen::Isometry3d inverse = this->ToTransform(Eigen::Vector3d::Zero()).inverse();
  return FromTransform(inverse, Eigen::Vector3d::Zero());
}

Pose Pose::Parse(const std::string& text, const std::string& field)
{
  std::vector<double> values;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ','))
  {
    try
    {
      size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (item.find_first_not_of(" \t", used) != std::string::npos)
      {
        throw std::invalid_argument(item);
      }
    }
    catch (const std::exception&)
    {
      throw InputError(field, "'" + item + "' is not a number");
    }
  }
  if (values.size() != 6)
  {
    throw InputError(field, "expected six numbers tx,ty,tz,pitch,roll,yaw (mm, degrees), got '" + text + "'");
  }
  for (double v : values)
  {
    if (!std::isfinite(v))
    {
      throw InputError(field, "values must be finite");
    }
  }
  return FromParameters(values.data());
}

Pose Pose::FromParameters(const double parameters[6])
{
  Pose pose;
  pose.translation = { parameters[0], parameters[1], parameters[2] };
  pose.pitch = parameters[3];
  pose.roll = parameters[4];
  pose.yaw = parameters[5];
  return pose;
}

std::array<double, 6> Pose::Parameters() const
{
  return { this->translation[0], this->translation[1], this->translation[2], this->pitch, this->roll, this->yaw };
}

std::string Pose::ToString() const
{
  char text[160];
  std::snprintf(text, sizeof(text), "t = (%.3f, %.3f, %.3f) mm, pitch %.3f, roll %.3f, yaw %.3f deg",
    this->translation[0], this->translation[1], this->translation[2], this->pitch, this->roll, this->yaw);
  return text;
}

PatientPosition ParsePatientPosition(const std::string& text, const std::string& origin)
{
  std::string code;
  for (char c : text)
  {
    if (!std::isspace(static_cast<unsigned char>(c)))
    {
      code += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    }
  }
  if (code == "HFS")
    return PatientPosition::HFS;
  if (code == "HFP")
    return PatientPosition::HFP;
  if (code == "FFS")
    return PatientPosition::FFS;
  if (code == "FFP")
    return PatientPosition::FFP;
  throw InputError(origin, "Patient Position '" + text + "' is not supported (HFS, HFP, FFS, FFP)");
}

std::string ToString(PatientPosition position)
{
  switch (position)
  {
    case PatientPosition::HFS:
      return "HFS";
    case PatientPosition::HFP:
      return "HFP";
    case PatientPosition::FFS:
      return "FFS";
    case PatientPosition::FFP:
      return "FFP";
  }
  return "?";
}

Eigen::Matrix3d PatientToRoomRotation(PatientPosition position)
{
  // Rows give Room X, Y, Z in LPS components. Head first: superior towards the gantry (+Y);
  // supine: anterior (-y) up (+Z); the patient's left follows from a proper rotation.
  Eigen::Matrix3d r;
  switch (position)
  {
    case PatientPosition::HFS:
      r << 1, 0, 0, 0, 0, 1, 0, -1, 0;
      break;
    case PatientPosition::HFP:
      r << -1, 0, 0, 0, 0, 1, 0, 1, 0;
      break;
    case PatientPosition::FFS:
      r << -1, 0, 0, 0, 0, -1, 0, -1, 0;
      break;
    case PatientPosition::FFP:
      r << 1, 0, 0, 0, 0, -1, 0, 1, 0;
      break;
  }
  return r;
}

Eigen::Isometry3d PlannedCTToRoom(
  PatientPosition position, const Eigen::Vector3d& isoInCT, const Eigen::Vector3d& roomIsocenter)
{
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = PatientToRoomRotation(position);
  transform.translation() = roomIsocenter - transform.linear() * isoInCT;
  return transform;
}

Eigen::Vector3d PatientSetup::IsocenterInCT(const Eigen::Vector3d& ctCenter) const
{
  return this->isocenterInCT ? *this->isocenterInCT : ctCenter;
}

Eigen::Isometry3d PatientSetup::PlannedCTToRoom(const Eigen::Vector3d& ctCenter) const
{
  return xp::PlannedCTToRoom(this->position, this->IsocenterInCT(ctCenter), this->roomIsocenter);
}

std::string PatientSetup::Describe() const
{
  std::ostringstream text;
  const auto point = [&](const Eigen::Vector3d& p) { text << "(" << p[0] << ", " << p[1] << ", " << p[2] << ")"; };
  text << ToString(this->position) << ", ";
  if (this->isocenterInCT)
  {
    text << "CT point ";
    point(*this->isocenterInCT);
  }
  else
    text << "the CT's centre";
  text << " at room ";
  point(this->roomIsocenter);
  return text.str();
}

bool PatientSetup::operator==(const PatientSetup& other) const
{
  return this->position == other.position && this->isocenterInCT == other.isocenterInCT &&
    this->roomIsocenter == other.roomIsocenter;
}

Eigen::Isometry3d MisalignedCTToRoom(const Eigen::Isometry3d& plannedCTToRoom, const Pose& misalignment,
  const Eigen::Vector3d& roomIsocenter)
{
  return misalignment.ToTransform(roomIsocenter) * plannedCTToRoom;
}

Eigen::Isometry3d MisalignmentInCT(const Eigen::Isometry3d& plannedCTToRoom, const Pose& misalignment,
  const Eigen::Vector3d& roomIsocenter)
{
  return plannedCTToRoom.inverse() * MisalignedCTToRoom(plannedCTToRoom, misalignment, roomIsocenter);
}

} // namespace xp
