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

#include <array>
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
  /** When set, no restart follows a run whose end (its pose and value) satisfies it: the end
   *  already answers what the restarts would look for. */
  std::function<bool(const Pose&, double)> endsRestarts;
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

/** The objective at a pose and a step either side of it along each pose parameter (x, y, z mm;
 *  pitch, roll, yaw degrees): MoveToParabolaVertex's evaluations, which also give the peak's
 *  curvature along each axis. */
struct AxisProbes
{
  double atCenter = 0.0;
  std::array<double, 6> below{}, above{}; ///< at -step and +step along each parameter
  double stepMM = 0.0, stepDegrees = 0.0;

  double Step(int parameter) const { return parameter < 3 ? this->stepMM : this->stepDegrees; }
  /** 2 f0 - f- - f+ along `parameter`: positive where the three values bend down. */
  double Bend(int parameter) const { return 2.0 * this->atCenter - this->below[parameter] - this->above[parameter]; }
  /** The parabola's vertex along `parameter`, from the centre (0 without a downward bend). */
  double VertexOffset(int parameter) const
  {
    const double bend = this->Bend(parameter);
    return bend > 0.0 ? 0.5 * this->Step(parameter) * (this->above[parameter] - this->below[parameter]) / bend : 0.0;
  }
};

/**
 * One step to the vertex of the objective's parabola along each parameter in turn, through its
 * values at `end` (`atEnd`) and `stepMM` (translations) or `stepDegrees` (rotations) either side:
 * 12 evaluations (kept in `probes` when given). A parameter whose three values do not bracket a
 * maximum (no downward bend, or the vertex farther than a step) keeps its value. On a quadratic
 * peak with independent axes it lands on the peak; on a cone (|x|) it at least halves the
 * distance, never passing the peak.
 */
VTKXPREGISTRATION_EXPORT Pose MoveToParabolaVertex(const std::function<double(const Pose&)>& objective, const Pose& end,
  double atEnd, double stepMM, double stepDegrees, AxisProbes* probes = nullptr);

/** A vertex polish's rounds (PolishToVertex). */
struct VertexPolish
{
  Pose pose;           ///< the last round's vertex
  double value = 0.0;  ///< the objective there
  int rounds = 0;      ///< rounds run
  AxisProbes probes;   ///< the last round's (about the pose it started from)
};

/**
 * Rounds of MoveToParabolaVertex from `end` (objective `atEnd`), each followed by the objective
 * at its vertex (13 evaluations a round), until a round moves no translation farther than
 * `stopMM` and no angle farther than `stopDegrees`, or after `maxRounds`. Along a valley that
 * couples two parameters each round lands nearer its peak; on a peak with independent axes the
 * first round lands on it and the second settles.
 */
VTKXPREGISTRATION_EXPORT VertexPolish PolishToVertex(const std::function<double(const Pose&)>& objective, const Pose& end,
  double atEnd, double stepMM, double stepDegrees, int maxRounds, double stopMM, double stopDegrees);

/**
 * The landscape's uncertainty per axis from a vertex polish's probes: the curvature c = bend / h^2
 * of the parabola through the three values along each axis, and the distance over which a
 * parabola of that curvature falls by 5 % of `atResult` (the objective at the result, the
 * polished end): sqrt(0.1 atResult / c). Infinite where the three values do not bracket a
 * maximum (no downward bend, or the vertex beyond a step: a neighbour scores higher than
 * anything between them).
 */
VTKXPREGISTRATION_EXPORT std::array<double, 6> UncertaintyFromProbes(const AxisProbes& probes, double atResult);

} // namespace xp

#endif
