#include "xpCommands.h"

#include "xpError.h"
#include "xpPose.h"
#include "xpRegistrationRecord.h"

#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

/** The volume's placement at the result, or an error naming the file. */
Eigen::Isometry3d PlacementOf(const RegistrationRecord& record, const std::string& path)
{
  if (!record.volumeToRoom)
    throw InputError(path, "has no volume_to_room (written by an older xpose register?)");
  return *record.volumeToRoom;
}

double AngleDegrees(const Eigen::Matrix3d& rotation)
{
  return Eigen::AngleAxisd(rotation).angle() * 180.0 / M_PI;
}

} // namespace

int RunRelative(const RelativeOptions& options)
{
  if (options.reference.empty() || options.reference.size() != options.moving.size())
    throw InputError("--moving", "give one result.json per --reference result.json (" + std::to_string(options.reference.size()) +
        " against " + std::to_string(options.moving.size()) + ")");
  std::printf("The moving volume in the reference volume's coordinates, per frame (R = Rz(yaw) Ry(roll) Rx(pitch) "
              "about the reference's axes; its centre in the reference's mm); change: from the first frame.\n");
  std::printf("| frame | status (reference, moving) | pitch roll yaw (deg) | moving centre x y z (mm) | turned since frame 1 (deg) | "
              "centre moved since frame 1 (mm) |\n|---|---|---|---|---|---|\n");
  Eigen::Isometry3d first = Eigen::Isometry3d::Identity();
  Eigen::Vector3d firstCenter = Eigen::Vector3d::Zero();
  for (size_t f = 0; f < options.reference.size(); ++f)
  {
    const RegistrationRecord reference = ReadRegistrationRecord(options.reference[f]);
    const RegistrationRecord moving = ReadRegistrationRecord(options.moving[f]);
    const Eigen::Isometry3d referenceToRoom = PlacementOf(reference, options.reference[f]);
    const Eigen::Isometry3d movingToRoom = PlacementOf(moving, options.moving[f]);
    const Eigen::Isometry3d relative = referenceToRoom.inverse() * movingToRoom;
    const Pose angles = Pose::FromTransform(relative, Eigen::Vector3d::Zero());
    const Eigen::Vector3d center = relative * moving.volumeCenter;
    if (f == 0)
    {
      first = relative;
      firstCenter = center;
    }
    std::printf("| %zu | %s, %s | %.2f %.2f %.2f | %.2f %.2f %.2f | %.2f | %.2f |\n", f + 1, reference.ok ? "ok" : "failed",
      moving.ok ? "ok" : "failed", angles.pitch, angles.roll, angles.yaw, center.x(), center.y(), center.z(),
      AngleDegrees(first.linear().transpose() * relative.linear()), (center - firstCenter).norm());
  }
  return ExitOk;
}

} // namespace xp
