#include "xpPoseOptimizer.h"

#include "xpError.h"

#include <nlopt.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace xp
{

namespace
{

Pose ToPose(const std::vector<double>& x)
{
  return Pose::FromParameters(x.data());
}

struct MethodName
{
  PoseOptimizerMethod method;
  const char* name;
  nlopt::algorithm algorithm;
};

const MethodName Methods[] = { { PoseOptimizerMethod::NelderMead, "nelder-mead", nlopt::LN_NELDERMEAD },
  { PoseOptimizerMethod::Subplex, "sbplx", nlopt::LN_SBPLX }, { PoseOptimizerMethod::BOBYQA, "bobyqa", nlopt::LN_BOBYQA },
  { PoseOptimizerMethod::COBYLA, "cobyla", nlopt::LN_COBYLA } };

struct Context
{
  const std::function<double(const std::vector<double>&)>* objective;
  const std::function<bool(const std::vector<double>&, double)>* stopWhen;
  int evaluations = 0;
  bool reachedTarget = false;
  std::vector<double> target; ///< the point that satisfied stopWhen, and its value
  double targetValue = 0.0;
};

double Trampoline(const std::vector<double>& x, std::vector<double>&, void* data)
{
  auto* context = static_cast<Context*>(data);
  ++context->evaluations;
  const double value = (*context->objective)(x);
  if (*context->stopWhen && (*context->stopWhen)(x, value))
  {
    context->reachedTarget = true;
    context->target = x;
    context->targetValue = value;
    throw nlopt::forced_stop(); // NLopt stops gracefully and optimize() rethrows
  }
  return value;
}

/** The settings of one 6-DOF search from `start` as a search over its parameters. */
ParameterSearch PoseSearch(const Pose& start, const PoseOptimizerSettings& settings, int evaluationsLeft)
{
  ParameterSearch search;
  search.method = settings.method;
  const std::array<double, 6> origin = start.Parameters();
  for (int i = 0; i < 6; ++i)
  {
    const bool translation = i < 3;
    const double bound = translation ? settings.boundMM : settings.boundDegrees;
    search.lower.push_back(origin[i] - bound);
    search.upper.push_back(origin[i] + bound);
    search.step.push_back(translation ? settings.initialStepMM : settings.initialStepDegrees);
    search.tolerance.push_back(translation ? settings.toleranceMM : settings.toleranceDegrees);
  }
  search.maxEvaluations = std::max(1, evaluationsLeft);
  if (settings.stopWhen)
    search.stopWhen = [&settings](const std::vector<double>& x, double value) { return settings.stopWhen(ToPose(x), value); };
  return search;
}

} // namespace

ParameterSearchResult MaximizeParameters(
  const std::function<double(const std::vector<double>&)>& objective, std::vector<double>& x, const ParameterSearch& search)
{
  nlopt::algorithm algorithm = nlopt::LN_NELDERMEAD;
  for (const MethodName& m : Methods)
    if (m.method == search.method)
      algorithm = m.algorithm;
  const size_t n = x.size();
  if (search.lower.size() != n || search.upper.size() != n || search.step.size() != n || search.tolerance.size() != n)
    throw Error("parameter search", "needs a bound, a step and a tolerance per parameter");
  Context context{ &objective, &search.stopWhen };
  nlopt::opt optimizer(algorithm, static_cast<unsigned>(n));
  optimizer.set_max_objective(Trampoline, &context);
  optimizer.set_lower_bounds(search.lower);
  optimizer.set_upper_bounds(search.upper);
  optimizer.set_initial_step(search.step);
  optimizer.set_xtol_abs(search.tolerance);
  optimizer.set_maxeval(std::max(1, search.maxEvaluations));
  ParameterSearchResult result;
  try
  {
    double value = 0.0;
    const nlopt::result code = optimizer.optimize(x, value);
    if (context.reachedTarget)
    {
      // NLopt's C++ interface catches forced_stop inside the objective, hands the algorithm
      // HUGE_VAL and asks it to stop; BOBYQA (NLopt 2.7.1) may then end with its own code
      // (XTOL_REACHED) and an infinite optimum instead of FORCED_STOP.
      x = context.target;
      result.value = context.targetValue;
      result.converged = true;
      result.reachedTarget = true;
      result.stopReason = "target reached";
      result.evaluations = context.evaluations;
      return result;
    }
    result.value = value;
    // BOBYQA ends its trust region's shrinking with the generic SUCCESS, not XTOL_REACHED.
    result.converged = code == nlopt::XTOL_REACHED || code == nlopt::FTOL_REACHED || code == nlopt::SUCCESS;
    result.stopReason = code == nlopt::MAXEVAL_REACHED ? "evaluation limit reached"
      : result.converged                             ? "tolerance reached"
                                                     : "stopped (NLopt code " + std::to_string(code) + ")";
  }
  catch (const nlopt::forced_stop&)
  {
    if (!context.reachedTarget)
      throw Error("parameter search", "stopped without reaching its target");
    x = context.target;
    result.value = context.targetValue;
    result.converged = true;
    result.reachedTarget = true;
    result.stopReason = "target reached";
  }
  catch (const nlopt::roundoff_limited&)
  {
    result.value = optimizer.last_optimum_value();
    result.stopReason = "round-off limited";
  }
  catch (const std::exception& e)
  {
    throw Error("parameter search", e.what());
  }
  result.evaluations = context.evaluations;
  return result;
}

PoseOptimizerMethod ParsePoseOptimizerMethod(const std::string& name, const std::string& field)
{
  for (const MethodName& m : Methods)
    if (name == m.name)
      return m.method;
  std::string known;
  for (const MethodName& m : Methods)
    known += std::string(known.empty() ? "" : ", ") + m.name;
  throw InputError(field, "unknown optimiser '" + name + "' (one of " + known + ")");
}

const char* PoseOptimizerMethodName(PoseOptimizerMethod method)
{
  for (const MethodName& m : Methods)
    if (m.method == method)
      return m.name;
  return "unknown";
}

std::vector<std::string> PoseOptimizerMethodNames()
{
  std::vector<std::string> names;
  for (const MethodName& m : Methods)
    names.push_back(m.name);
  return names;
}

PoseOptimizerResult MaximizePose(
  const std::function<double(const Pose&)>& objective, const Pose& start, const PoseOptimizerSettings& settings)
{
  // A restart begins at the optimum it restarts from: that point's value is known, and is not
  // evaluated again (the objective is a function of the pose). Its value comes back as the
  // optimiser returned it; any other point, even one within rounding of it, is evaluated.
  std::vector<double> known;
  double knownValue = 0.0;
  int reused = 0;
  const std::function<double(const std::vector<double>&)> ofParameters = [&](const std::vector<double>& x)
  {
    if (!known.empty() && x == known)
    {
      known.clear(); // once: a later visit is the optimiser's own business
      ++reused;
      return knownValue;
    }
    return objective(ToPose(x));
  };
  const std::array<double, 6> parameters = start.Parameters();
  std::vector<double> x(parameters.begin(), parameters.end());
  int evaluations = 0, calls = 0; // the objective's evaluations; the optimiser's calls, its budget's
  const auto run = [&](std::vector<double>& from)
  {
    reused = 0;
    const ParameterSearchResult found =
      MaximizeParameters(ofParameters, from, PoseSearch(start, settings, settings.maxEvaluations - calls));
    calls += found.evaluations;
    evaluations += found.evaluations - reused;
    PoseOptimizerResult result;
    static_cast<ParameterSearchResult&>(result) = found;
    return result;
  };
  PoseOptimizerResult result = run(x);
  for (int restart = 0; restart < settings.maxRestarts && result.converged && !result.reachedTarget; ++restart)
  {
    if (settings.endsRestarts && settings.endsRestarts(ToPose(x), result.value))
      break;
    std::vector<double> again = x;
    known = x;
    knownValue = result.value;
    const PoseOptimizerResult next = run(again);
    known.clear();
    if (next.reachedTarget)
    {
      x = again;
      result = next;
      break;
    }
    if (!(next.value > result.value))
    {
      break; // the restart found nothing better: a true optimum, not a stall
    }
    // Did the fresh simplex escape a stall (move several tolerances), or only polish the optimum?
    double moved = 0.0;
    for (int i = 0; i < 6; ++i)
    {
      moved = std::max(moved, std::abs(again[i] - x[i]) / (i < 3 ? settings.toleranceMM : settings.toleranceDegrees));
    }
    x = again;
    result = next;
    if (moved < 5.0)
    {
      break;
    }
  }
  result.pose = ToPose(x);
  result.evaluations = evaluations;
  return result;
}

Pose MoveToParabolaVertex(const std::function<double(const Pose&)>& objective, const Pose& end, double atEnd, double stepMM,
  double stepDegrees, AxisProbes* probes)
{
  AxisProbes found;
  found.atCenter = atEnd;
  found.stepMM = stepMM;
  found.stepDegrees = stepDegrees;
  const std::array<double, 6> center = end.Parameters();
  std::array<double, 6> vertex = center;
  for (int a = 0; a < 6; ++a)
  {
    const double h = found.Step(a);
    std::array<double, 6> p = center;
    p[a] = center[a] - h;
    found.below[a] = objective(Pose::FromParameters(p.data()));
    p[a] = center[a] + h;
    found.above[a] = objective(Pose::FromParameters(p.data()));
    const double offset = found.VertexOffset(a);
    if (std::abs(offset) <= h)
      vertex[a] += offset;
  }
  if (probes)
    *probes = found;
  return Pose::FromParameters(vertex.data());
}

VertexPolish PolishToVertex(const std::function<double(const Pose&)>& objective, const Pose& end, double atEnd,
  double stepMM, double stepDegrees, int maxRounds, double stopMM, double stopDegrees)
{
  VertexPolish polish;
  polish.pose = end;
  polish.value = atEnd;
  while (polish.rounds < maxRounds)
  {
    const Pose vertex = MoveToParabolaVertex(objective, polish.pose, polish.value, stepMM, stepDegrees, &polish.probes);
    const bool settled = (vertex.translation - polish.pose.translation).cwiseAbs().maxCoeff() <= stopMM &&
      std::max({ std::abs(vertex.pitch - polish.pose.pitch), std::abs(vertex.roll - polish.pose.roll),
        std::abs(vertex.yaw - polish.pose.yaw) }) <= stopDegrees;
    polish.pose = vertex;
    polish.value = objective(vertex);
    ++polish.rounds;
    if (settled)
      break;
  }
  return polish;
}

std::array<double, 6> UncertaintyFromProbes(const AxisProbes& probes, double atResult)
{
  std::array<double, 6> uncertainty{};
  for (int a = 0; a < 6; ++a)
  {
    const double h = probes.Step(a), curvature = probes.Bend(a) / (h * h);
    const bool peak = curvature > 0.0 && atResult >= probes.below[a] && atResult >= probes.above[a] && atResult > 0.0;
    uncertainty[a] = peak ? std::sqrt(0.1 * atResult / curvature) : std::numeric_limits<double>::infinity();
  }
  return uncertainty;
}

} // namespace xp
