/**
 * @file xpLinearizedRefinement.h
 * @brief The full-size refinement on a first-order model of the DRRs: a pose's line integrals
 *        and their slopes along the six pose parameters, rendered once a round; the optimiser
 *        climbs the objective of the modelled DRRs, which renders nothing, and the round ends
 *        where the true objective is measured again.
 *
 * Near the optimum a DRR's line integrals move smoothly with the pose, and the first-order model
 * I(p + d) = I(p) + sum_k d_k dI/dp_k (the slopes by central differences of the refinement's own
 * first steps) is trusted within `trustSteps` of those steps; the objective of the modelled
 * integrals (MI of their ranks, high-passed, as StereoSimilarity measures a rendering) casts no
 * ray. A round renders 12 poses (a step either side along each
 * parameter) and measures each of them like any evaluation; the simplex then climbs the model
 * within `trustSteps` of those steps around the pose, and the true objective is measured where
 * it ends: a round that does not improve it, or moves every parameter less than the stops,
 * ends the refinement. Off by default: Algorithms.md, "The linearized refinement".
 */
#ifndef xpLinearizedRefinement_h
#define xpLinearizedRefinement_h

#include "vtkXPRegistrationModule.h"

#include "xpPoseOptimizer.h"
#include "xpStereoSimilarity.h"

#include <functional>

namespace xp
{

/** How far the modelled DRRs are trusted, and how many rounds at most. */
struct LinearizedClimb
{
  /** The model's climb stays within this many of the optimiser's first steps of its pose. */
  double trustSteps = 4.0;
  /** Rounds at most; a refinement still moving after them has not converged. */
  int maxRounds = 10;
};

/** A refinement's end (PoseOptimizerResult: `evaluations` are the measured ones, slopes
 *  included) and the model's own evaluations, which render nothing. */
struct LinearizedRefinementResult : PoseOptimizerResult
{
  int modelEvaluations = 0;
  int rounds = 0;
};

/**
 * Maximises `similarity`'s objective from `start`: each round the 12 slope poses and the
 * model's end are measured through `evaluate` (which must evaluate `similarity`, so that its
 * LastIntegrals are that pose's; it may trace or count them), the model's climb runs
 * `settings`' optimiser (its first steps are the slopes' steps, its stops the rounds' stops).
 * `settings.stopWhen` is asked at every measured pose, as MaximizePose asks it; the evaluation
 * budget counts measured poses.
 */
VTKXPREGISTRATION_EXPORT LinearizedRefinementResult MaximizeOnLinearizedDRRs(StereoSimilarity& similarity,
  const std::function<double(const Pose&)>& evaluate, const Pose& start, const PoseOptimizerSettings& settings,
  const LinearizedClimb& climb = {});

} // namespace xp

#endif
