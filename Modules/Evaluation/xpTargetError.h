/**
 * @file xpTargetError.h
 * @brief How far a registration ends from the truth: the mean target registration error (mTRE)
 *        over the bone around the isocentre, and the seeded misalignments an evaluation draws.
 */
#ifndef xpTargetError_h
#define xpTargetError_h

#include "vtkXPEvaluationModule.h"

#include "xpPose.h"

#include <Eigen/Geometry>

#include <random>
#include <vector>

class vtkImageData;

namespace xp
{

/** The target region: CT voxels above this (HU, bone) within this radius (mm) of the isocentre. */
constexpr double TargetHU = 150.0;
constexpr double TargetRadiusMM = 60.0;

/**
 * The target region of the mTRE in planned room coordinates, thinned evenly to at most
 * `maximum` points. Throws xp::InputError naming --ct when the region is empty.
 */
VTKXPEVALUATION_EXPORT std::vector<Eigen::Vector3d> TargetPoints(
  vtkImageData* ct, const Eigen::Vector3d& isocenterInCT, const Eigen::Isometry3d& planned, size_t maximum = 20000);

/** Mean distance between the targets moved by two misalignments (about the room isocentre). */
VTKXPEVALUATION_EXPORT double MeanTRE(
  const std::vector<Eigen::Vector3d>& targets, const Pose& a, const Pose& b, const Eigen::Vector3d& isocenter);

/** The range misalignments are drawn from. */
struct MisalignmentRange
{
  double minTranslation = 1.0;  ///< mm, length of the translation
  double maxTranslation = 30.0;
  double maxRotation = 5.0;     ///< degrees, each angle in [-max, max]
};

/**
 * The misalignment of trial `trial`: a translation of length uniform in the range, in a uniform
 * direction, and each angle uniform. Depends only on the seed and the trial number, so an
 * interrupted evaluation resumes with the same trials; `random` is reseeded and left to draw the
 * trial's noise.
 */
VTKXPEVALUATION_EXPORT Pose DrawMisalignment(unsigned seed, int trial, const MisalignmentRange& range, std::mt19937& random);

} // namespace xp

#endif
