#include "xpLinearizedRefinement.h"

#include "xpError.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace xp
{

namespace
{

using Panels = std::vector<std::vector<float>>; ///< one panel of line integrals per view

Panels CopyIntegrals(const StereoSimilarity& similarity)
{
  Panels panels;
  for (size_t v = 0; v < similarity.Views().size(); ++v)
    panels.push_back(similarity.LastIntegrals(v));
  return panels;
}

/** The step along parameter k (translations mm, then rotations degrees). */
double StepOf(const PoseOptimizerSettings& settings, int k)
{
  return k < 3 ? settings.initialStepMM : settings.initialStepDegrees;
}

/** Thrown out of the climb when a measured pose meets `stopWhen`. */
struct ReachedTarget
{
  Pose pose;
  double value = 0.0;
};

} // namespace

LinearizedRefinementResult MaximizeOnLinearizedDRRs(StereoSimilarity& similarity,
  const std::function<double(const Pose&)>& evaluate, const Pose& start, const PoseOptimizerSettings& settings,
  const LinearizedClimb& climb)
{
  for (int k = 0; k < 6; ++k)
    if (!(StepOf(settings, k) > 0.0) || !std::isfinite(StepOf(settings, k)))
      throw Error("linearized refinement", "needs a positive first step per parameter");
  if (!(climb.trustSteps > 0.0) || climb.maxRounds < 1)
    throw Error("linearized refinement", "needs a positive trust region and at least one round");

  LinearizedRefinementResult result;
  // Every measured pose: counted, and asked whether it reaches the target.
  const auto measure = [&](const Pose& pose)
  {
    const double value = evaluate(pose);
    ++result.evaluations;
    if (settings.stopWhen && settings.stopWhen(pose, value))
      throw ReachedTarget{ pose, value };
    return value;
  };
  std::array<double, 6> at = start.Parameters();
  try
  {
    double value = measure(start);
    Panels center = CopyIntegrals(similarity);
    std::array<Panels, 6> slopes;
    for (;;)
    {
      if (result.rounds == climb.maxRounds || result.evaluations + 13 > settings.maxEvaluations)
      {
        result.stopReason = result.rounds == climb.maxRounds ? "rounds" : "evaluations";
        break;
      }
      ++result.rounds;
      // The slopes: central differences of the line integrals a first step either side.
      for (int k = 0; k < 6; ++k)
      {
        const double h = StepOf(settings, k);
        std::array<double, 6> p = at;
        p[k] = at[k] + h;
        measure(Pose::FromParameters(p.data()));
        Panels up = CopyIntegrals(similarity);
        p[k] = at[k] - h;
        measure(Pose::FromParameters(p.data()));
        for (size_t v = 0; v < up.size(); ++v)
        {
          const std::vector<float>& down = similarity.LastIntegrals(v);
          const float scale = static_cast<float>(0.5 / h);
          for (size_t i = 0; i < up[v].size(); ++i)
            up[v][i] = (up[v][i] - down[i]) * scale;
        }
        slopes[k] = std::move(up);
      }
      // The climb on the model, within the trust region around `at`.
      Panels model = center;
      const auto modelled = [&](const Pose& pose)
      {
        const std::array<double, 6> x = pose.Parameters();
        for (size_t v = 0; v < model.size(); ++v)
        {
          float* out = model[v].data();
          std::copy(center[v].begin(), center[v].end(), out);
          for (int k = 0; k < 6; ++k)
          {
            const float d = static_cast<float>(x[k] - at[k]);
            const float* slope = slopes[k][v].data();
            for (size_t i = 0, n = model[v].size(); i < n; ++i)
              out[i] += d * slope[i];
          }
        }
        ++result.modelEvaluations;
        return similarity.ObjectiveOf(model);
      };
      PoseOptimizerSettings trusted = settings;
      trusted.stopWhen = nullptr;
      trusted.maxRestarts = 0;
      trusted.boundMM = climb.trustSteps * settings.initialStepMM;
      trusted.boundDegrees = climb.trustSteps * settings.initialStepDegrees;
      const PoseOptimizerResult end = MaximizePose(modelled, Pose::FromParameters(at.data()), trusted);
      const double reached = measure(end.pose);
      if (!(reached > value))
      {
        result.converged = true;
        result.stopReason = "the model's climb no longer improves the objective";
        break;
      }
      const std::array<double, 6> to = end.pose.Parameters();
      bool settled = true;
      for (int k = 0; k < 6; ++k)
        settled = settled && std::abs(to[k] - at[k]) < (k < 3 ? settings.toleranceMM : settings.toleranceDegrees);
      at = to;
      value = reached;
      center = CopyIntegrals(similarity);
      if (settled)
      {
        result.converged = true;
        result.stopReason = "tolerance";
        break;
      }
    }
    result.value = value;
  }
  catch (const ReachedTarget& target)
  {
    result.pose = target.pose;
    result.value = target.value;
    result.converged = result.reachedTarget = true;
    result.stopReason = "target";
    return result;
  }
  result.pose = Pose::FromParameters(at.data());
  return result;
}

} // namespace xp
