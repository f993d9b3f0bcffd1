#include "xpRegistrationSchedule.h"

#include "xpError.h"
#include "xpStereoRegistration.h"

#include <algorithm>
#include <cstdio>

namespace xp
{

const char* StageKindName(StageKind kind)
{
  switch (kind)
  {
    case StageKind::PreAlignment: return "pre-alignment";
    case StageKind::Masks: return "masks";
    case StageKind::Search: return "search";
    case StageKind::Refinement: return "refinement";
    case StageKind::Polish: return "polish";
    case StageKind::Restarts: return "restarts";
    case StageKind::Landscape: return "landscape";
    case StageKind::Gate: return "gate";
  }
  return "?";
}

std::optional<StageKind> StageKindNamed(const std::string& name)
{
  for (StageKind kind : { StageKind::PreAlignment, StageKind::Masks, StageKind::Search, StageKind::Refinement,
         StageKind::Polish, StageKind::Restarts, StageKind::Landscape, StageKind::Gate })
    if (name == StageKindName(kind))
      return kind;
  return std::nullopt;
}

ScheduleChoice ParseScheduleChoice(const std::string& name, const std::string& field)
{
  if (name == "standard")
    return ScheduleChoice::Standard;
  if (name == "economy")
    return ScheduleChoice::Economy;
  throw InputError(field, "'" + name + "' is not a schedule: standard or economy");
}

const char* ScheduleChoiceName(ScheduleChoice choice)
{
  return choice == ScheduleChoice::Economy ? "economy" : "standard";
}

namespace
{

ScheduledStage Stage(StageKind kind, const std::string& name, int imageDivisor, double progressFrom, double progressTo)
{
  ScheduledStage stage;
  stage.kind = kind;
  stage.name = name;
  stage.imageDivisor = imageDivisor;
  stage.progressFrom = progressFrom;
  stage.progressTo = progressTo;
  return stage;
}

/** The refinement's optimiser: steps and tolerances ten times finer than the accuracy asked. */
PoseOptimizerSettings RefinementOptimizer(const StereoRegistrationSettings& settings)
{
  PoseOptimizerSettings fine;
  fine.method = settings.refinementOptimizer;
  fine.maxEvaluations = settings.maxEvaluations;
  // No restart here: the searches' restarts already escaped the valley's stalls, and on 14
  // pelvis trials a restart of the refinement cost a third of the time and changed the median
  // mTRE by 0.006 mm.
  fine.maxRestarts = 0;
  fine.initialStepMM = 0.25;
  fine.initialStepDegrees = 0.15;
  fine.toleranceMM = 0.05;
  fine.toleranceDegrees = 0.03;
  return fine;
}

} // namespace

RegistrationSchedule MakeSchedule(const StereoRegistrationSettings& settings, bool pyramid, bool quarter, bool boneOnly)
{
  RegistrationSchedule schedule;
  std::vector<ScheduledStage>& stages = schedule.stages;
  const int coarse = pyramid ? 2 : 1;
  ScheduledStage prealignment = Stage(StageKind::PreAlignment, "pre-alignment", coarse, 0.0, 0.1);
  // A bone's start is already near (a given pose, the previous frame's, or the global search's):
  // it is evaluated, not pre-aligned (0 iterations).
  prealignment.rounds = boneOnly ? 0 : 6;
  stages.push_back(prealignment);
  stages.push_back(Stage(StageKind::Masks, "masks", 1, 0.1, 0.1));

  // The searches: steps that travel from the pre-alignment, stops coarser than the refinement's,
  // and restarts, since stalls happen in the long travel and restarts are cheap at this size.
  PoseOptimizerSettings search = RefinementOptimizer(settings);
  search.method = settings.optimizer;
  search.initialStepMM = 2.0;
  search.initialStepDegrees = 1.0;
  search.toleranceMM = 0.1;
  search.toleranceDegrees = 0.05;
  search.maxRestarts = 3;
  // With quarter-size travel, the travel (2 mm pixels at the isocentre at 512x384) stops at half
  // a pixel (ten times the search's tolerances): finer steps on these images only creep along the
  // peak that the half-size search resolves. The search goes on at half size from it with a
  // quarter of its simplex. Each of the second track's stages stops once it meets the first
  // track's end at the same size.
  PoseOptimizerSettings travel = search, afterTravel = search;
  travel.toleranceMM = 10.0 * search.toleranceMM;
  travel.toleranceDegrees = 10.0 * search.toleranceDegrees;
  afterTravel.initialStepMM = 0.25 * search.initialStepMM;
  afterTravel.initialStepDegrees = 0.25 * search.initialStepDegrees;
  const bool economy = settings.schedule == ScheduleChoice::Economy;
  const bool travels = pyramid && quarter && (settings.quarterSizeTravel || economy);
  const int tracks = settings.maxSearchDisagreementMM > 0.0 ? 2 : 1;
  for (int track = 0; track < tracks; ++track)
  {
    const double from = track == 0 ? 0.1 : 0.45, to = track == 0 ? 0.45 : 0.7;
    const std::string name = track == 0 ? (pyramid ? "coarse search (half resolution)" : "coarse search") : "second coarse search";
    if (travels)
    {
      ScheduledStage stage = Stage(StageKind::Search, track == 0 ? "coarse search (quarter resolution)"
                                                                 : "second coarse search (quarter resolution)", 4, from, 0.5 * (from + to));
      stage.track = track;
      stage.optimizer = travel;
      stage.stopAtFirstEnd = track == 1;
      stage.joinsFirstTrack = track == 1 && settings.secondSearchJoins;
      stages.push_back(stage);
    }
    ScheduledStage stage = Stage(StageKind::Search, name, coarse, travels ? 0.5 * (from + to) : from, to);
    stage.track = track;
    stage.optimizer = travels ? afterTravel : search;
    stage.highPassMM = travels && settings.highPassAfterTravel ? settings.fineHighPassMM : 0.0;
    stage.stopAtFirstEnd = track == 1;
    stages.push_back(stage);
  }

  ScheduledStage refinement = Stage(StageKind::Refinement, "fine", 1, 0.7, 0.8);
  refinement.optimizer = RefinementOptimizer(settings);
  // Where both searches' ends are refined, the second refinement only asks whether its end
  // climbs to another optimum: reaching the first one's answers it.
  refinement.stopAtFirstEnd = true;
  refinement.linearized = settings.linearizedRefinement;
  if (economy)
  {
    // Fewer evaluations: both searches travel on quarter-size images (a fifth of a half-size
    // pair's rays) where the images allow, restart once, and end at half size at twice the
    // standard tolerances, where the refinement's first simplex reaches; the robustness search's
    // end at half size within 60 evaluations, since it stops as soon as it meets the first one's
    // optimum; the refinement stops at 0.1 mm and 0.05 degree (twice the standard), and the polish
    // reads the peak's shape after it.
    for (ScheduledStage& stage : stages)
    {
      if (stage.kind != StageKind::Search)
        continue;
      stage.optimizer.maxRestarts = 1;
      if (stage.imageDivisor != 4)
      {
        stage.optimizer.toleranceMM = 2.0 * search.toleranceMM;
        stage.optimizer.toleranceDegrees = 2.0 * search.toleranceDegrees;
      }
      if (stage.stopAtFirstEnd && stage.imageDivisor != 4)
        stage.optimizer.maxEvaluations = std::min(stage.optimizer.maxEvaluations, 60);
    }
    refinement.optimizer.toleranceMM = 2.0 * refinement.optimizer.toleranceMM;
    refinement.optimizer.toleranceDegrees = 2.0 * refinement.optimizer.toleranceDegrees;
  }
  if (settings.halfSizeRefinement && pyramid)
  {
    // Every end refined in full at half size (no stop at the first end's: the full-size stage
    // stops the second end there).
    ScheduledStage half = Stage(StageKind::Refinement, "fine (half resolution)", coarse, 0.7, 0.75);
    half.optimizer = refinement.optimizer;
    half.optimizer.initialStepMM *= 2.0;
    half.optimizer.initialStepDegrees *= 2.0;
    half.optimizer.toleranceMM *= 2.0;
    half.optimizer.toleranceDegrees *= 2.0;
    stages.push_back(half);
    refinement.progressFrom = 0.75;
  }
  stages.push_back(refinement);
  if (boneOnly)
  {
    // Steps of the restarts' own size: the refinement's quarter-millimetre steps polish, they do
    // not travel 2 mm, and a stall would count as a disagreement of the images. A restart still
    // travelling after 150 evaluations is in a flat valley: it ends where it is, and that
    // disagreement is the answer (four unbounded ones took 10 s on the metacarpal).
    ScheduledStage restarts = Stage(StageKind::Restarts, "restarts", 1, 0.85, 0.9);
    restarts.optimizer = refinement.optimizer;
    restarts.optimizer.initialStepMM = 1.0;
    restarts.optimizer.initialStepDegrees = 1.0;
    restarts.optimizer.maxRestarts = 1;
    restarts.optimizer.maxEvaluations = std::min(restarts.optimizer.maxEvaluations, 150);
    restarts.rounds = 4;
    stages.push_back(restarts);
  }
  else if (settings.vertexPolishRounds > 0)
  {
    // Rounds until one moves no parameter farther than the refinement's own stop: on a noisy
    // objective each round lands nearer a peak that is broad and bumpy at once.
    ScheduledStage polish = Stage(StageKind::Polish, "vertex polish", 1, 0.85, 0.9);
    polish.rounds = settings.vertexPolishRounds;
    polish.optimizer.toleranceMM = refinement.optimizer.toleranceMM;
    polish.optimizer.toleranceDegrees = refinement.optimizer.toleranceDegrees;
    stages.push_back(polish);
  }
  stages.push_back(Stage(StageKind::Landscape, "landscape", 1, 0.9, 0.95));
  stages.push_back(Stage(StageKind::Gate, "quality gate", 1, 0.95, 1.0));
  return schedule;
}

std::string DescribeSchedule(const RegistrationSchedule& schedule)
{
  std::string text;
  char line[256];
  for (const ScheduledStage& stage : schedule.stages)
  {
    std::snprintf(line, sizeof line, "%-13s %-40s 1/%d size", StageKindName(stage.kind), stage.name.c_str(), stage.imageDivisor);
    text += line;
    const PoseOptimizerSettings& o = stage.optimizer;
    if (stage.kind == StageKind::Search || stage.kind == StageKind::Refinement || stage.kind == StageKind::Restarts)
    {
      std::snprintf(line, sizeof line, ", %s from steps %g mm %g deg, stops under %g mm %g deg, at most %d evaluations, %d restarts",
        PoseOptimizerMethodName(o.method), o.initialStepMM, o.initialStepDegrees, o.toleranceMM, o.toleranceDegrees,
        o.maxEvaluations, o.maxRestarts);
      text += line;
    }
    if (stage.kind == StageKind::Search)
    {
      text += ", track " + std::to_string(stage.track) + (stage.stopAtFirstEnd ? ", stops at the first track's end" : "");
      if (stage.joinsFirstTrack)
        text += " and ends the track there";
      if (stage.highPassMM > 0.0)
      {
        std::snprintf(line, sizeof line, ", high-passed at %g mm", stage.highPassMM);
        text += line;
      }
    }
    if (stage.kind == StageKind::Refinement && stage.linearized)
      text += ", on the DRRs' slopes (13 evaluations a round)";
    if (stage.kind == StageKind::Refinement && stage.stopAtFirstEnd)
      text += ", the second end's stops at the first's";
    if (stage.rounds > 0)
      text += ", " + std::to_string(stage.rounds) + (stage.kind == StageKind::PreAlignment ? " iterations at most" : " rounds");
    if (stage.kind == StageKind::Polish)
    {
      std::snprintf(line, sizeof line, " at most, until one moves under %g mm %g deg", o.toleranceMM, o.toleranceDegrees);
      text += line;
    }
    text += "\n";
  }
  return text;
}

} // namespace xp
