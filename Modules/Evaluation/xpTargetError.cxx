#include "xpTargetError.h"

#include "xpError.h"
#include "xpImageGeometry.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

namespace xp
{

std::vector<Eigen::Vector3d> TargetPoints(
  vtkImageData* ct, const Eigen::Vector3d& isocenterInCT, const Eigen::Isometry3d& planned, size_t maximum)
{
  const Eigen::Affine3d toPhysical = IndexToPhysical(ct);
  int dims[3];
  ct->GetDimensions(dims);
  vtkDataArray* hu = ct->GetPointData()->GetScalars();
  std::vector<Eigen::Vector3d> targets;
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const Eigen::Vector3d p = toPhysical * Eigen::Vector3d(i, j, k);
        if ((p - isocenterInCT).norm() <= TargetRadiusMM &&
          hu->GetComponent(i + static_cast<vtkIdType>(dims[0]) * (j + static_cast<vtkIdType>(dims[1]) * k), 0) > TargetHU)
          targets.push_back(planned * p);
      }
  if (targets.empty())
  {
    throw InputError("--ct", "has no voxel above 150 HU within 60 mm of the isocentre: no target region for the mTRE");
  }
  const size_t stride = (targets.size() + maximum - 1) / maximum;
  std::vector<Eigen::Vector3d> thinned;
  for (size_t n = 0; n < targets.size(); n += stride)
    thinned.push_back(targets[n]);
  return thinned;
}

double MeanTRE(const std::vector<Eigen::Vector3d>& targets, const Pose& a, const Pose& b, const Eigen::Vector3d& isocenter)
{
  const Eigen::Isometry3d ta = a.ToTransform(isocenter), tb = b.ToTransform(isocenter);
  double sum = 0.0;
  for (const Eigen::Vector3d& q : targets)
    sum += (ta * q - tb * q).norm();
  return sum / targets.size();
}

Pose DrawMisalignment(unsigned seed, int trial, const MisalignmentRange& range, std::mt19937& random)
{
  std::seed_seq sequence{ seed, static_cast<unsigned>(trial) };
  random.seed(sequence);
  std::normal_distribution<double> gaussian;
  std::uniform_real_distribution<double> length(range.minTranslation, range.maxTranslation);
  std::uniform_real_distribution<double> angle(-range.maxRotation, range.maxRotation);
  Eigen::Vector3d direction(gaussian(random), gaussian(random), gaussian(random));
  Pose pose;
  pose.translation = direction.normalized() * length(random);
  pose.pitch = angle(random);
  pose.roll = angle(random);
  pose.yaw = angle(random);
  return pose;
}

} // namespace xp
