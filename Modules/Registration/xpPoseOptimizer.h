/**
 * @file xpPoseOptimizer.h
 * @brief The optimiser component: maximises an objective over bounded parameters with NLopt's
 *        downhill simplex (Nelder-Mead, the paper's) or another of its derivative-free local
 *        optimisers (MaximizeParameters: the pre-alignment's 2D registrations), and a pose
 *        objective over the 6 pose parameters in mm and degrees (MaximizePose: the 6-DOF stages).
 */
#ifndef xpPoseOptimizer_h
#define xpPoseOptimizer_h

#include "vtkXPRegistrationModule.h"

#include "xpPose.h"

#include <functional>
#include <string>
#include <vector>

namespace xp
{

/** NLopt's derivative-free local optimisers that MaximizePose can run. */
enum class PoseOptimizerMethod
{
  NelderMead, ///< LN_NELDERMEAD: the paper's downhill simplex
  Subplex,    ///< LN_SBPLX: Nelder-Mead on subspaces, robust in valleys
  BOBYQA,     ///< LN_BOBYQA: quadratic models in a trust region, few evaluations on smooth peaks
  COBYLA      ///< LN_COBYLA: linear models in a trust region
};

/** "nelder-mead", "sbplx", "bobyqa", "cobyla"; throws xp::InputError naming `field` otherwise. */
VTKXPREGISTRATION_EXPORT PoseOptimizerMethod ParsePoseOptimizerMethod(const std::string& name, const std::string& field);
VTKXPREGISTRATION_EXPORT const char* PoseOptimizerMethodName(PoseOptimizerMethod method);
VTKXPREGISTRATION_EXPORT std::vector<std::string> PoseOptimizerMethodNames();

struct PoseOptimizerSettings
{
  PoseOptimizerMethod method = PoseOptimizerMethod::NelderMead;
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


/** One bounded search over any number of parameters (each vector holds one value per parameter). */
struct ParameterSearch
{
  PoseOptimizerMethod method = PoseOptimizerMethod::NelderMead;
  std::vector<double> lower, upper; ///< the search box
  std::vector<double> step;         ///< the first simplex's (or trust region's) size
  std::vector<double> tolerance;    ///< stop when a step changes every parameter less than this
  int maxEvaluations = 300;
  /** When set, the search ends as soon as an evaluated point satisfies it; that point is the result. */
  std::function<bool(const std::vector<double>&, double)> stopWhen;
};

struct ParameterSearchResult
{
  double value = 0.0;
  int evaluations = 0;
  bool converged = false;     ///< stopped on the tolerances or at stopWhen, not on the evaluation limit
  bool reachedTarget = false; ///< stopped at stopWhen
  std::string stopReason;
};

/** A 6-DOF search's end: the pose, and its search's figures (evaluations: all its restarts'). */
struct PoseOptimizerResult : ParameterSearchResult
{
  Pose pose;
};

/** Maximises `objective` from `x` (the result is left there) within `search`'s box; throws
 *  xp::Error when the optimiser fails. */
VTKXPREGISTRATION_EXPORT ParameterSearchResult MaximizeParameters(
  const std::function<double(const std::vector<double>&)>& objective, std::vector<double>& x, const ParameterSearch& search);

/** Maximises `objective` from `start` over the 6 pose parameters with `settings.method`
 *  (MaximizeParameters, restarted while a fresh simplex still improves the optimum). */
VTKXPREGISTRATION_EXPORT PoseOptimizerResult MaximizePose(
  const std::function<double(const Pose&)>& objective, const Pose& start, const PoseOptimizerSettings& settings = {});

/**
 * One step to the vertex of the objective's parabola along each parameter in turn, through its
 * values at `end` (`atEnd`) and `stepMM` (translations) or `stepDegrees` (rotations) either side:
 * 12 evaluations. A parameter whose three values do not bracket a maximum (no downward bend, or
 * the vertex farther than a step) keeps its value. On a quadratic peak with independent axes it
 * lands on the peak; on a cone (|x|) it at least halves the distance, never passing the peak.
 */
VTKXPREGISTRATION_EXPORT Pose MoveToParabolaVertex(
  const std::function<double(const Pose&)>& objective, const Pose& end, double atEnd, double stepMM, double stepDegrees);

} // namespace xp

#endif
