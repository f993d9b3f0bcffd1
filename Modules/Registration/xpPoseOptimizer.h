/**
 * @file xpPoseOptimizer.h
 * @brief Maximises a pose objective with NLopt's downhill simplex (Nelder-Mead), in mm and degrees.
 */
#ifndef xpPoseOptimizer_h
#define xpPoseOptimizer_h

#include "vtkXPRegistrationModule.h"

#include "xpPose.h"

#include <functional>

namespace xp
{

struct PoseOptimizerSettings
{
  double initialStepMM = 2.0;       ///< simplex size for translations
  double initialStepDegrees = 1.0;  ///< and for rotations
  double toleranceMM = 0.02;        ///< stop when a step changes every parameter less than this
  double toleranceDegrees = 0.01;
  int maxEvaluations = 300;
  double boundMM = 60.0;            ///< search box around the start
  double boundDegrees = 15.0;
  /** Fresh simplexes started from the optimum while they still improve it: Nelder-Mead stalls in
   *  narrow valleys (roll against lateral shift, the direction two views see least). */
  int maxRestarts = 3;
  /** When set, the search ends as soon as an evaluated pose satisfies it (the target is reached);
   *  that pose is the result. */
  std::function<bool(const Pose&, double)> stopWhen;
};

struct PoseOptimizerResult
{
  Pose pose;
  double value = 0.0;
  int evaluations = 0;
  bool converged = false;  ///< stopped on the tolerances or at stopWhen, not on the evaluation limit
  bool reachedTarget = false; ///< stopped at stopWhen
  std::string stopReason;
};

/** Maximises `objective` from `start` with a 6-parameter simplex. */
VTKXPREGISTRATION_EXPORT PoseOptimizerResult MaximizePose(
  const std::function<double(const Pose&)>& objective, const Pose& start, const PoseOptimizerSettings& settings = {});

} // namespace xp

#endif
