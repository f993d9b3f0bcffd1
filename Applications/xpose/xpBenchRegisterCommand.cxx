// `xpose bench register`: where a registration's time goes, stage by stage, and what each
// optimiser of the 6-DOF stages costs and gives on the same simulated trials.
#include "xpCommands.h"
#include "xpRegistrationSources.h"

#include "xpAccuracyEvaluation.h"
#include "xpError.h"
#include "xpEvaluation.h"
#include "xpEvaluationFolder.h"
#include "xpEvaluationScenario.h"
#include "xpStereoGeometry.h"
#include "xpVolumeIO.h"

#include <vtkImageData.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <thread>
#include <utility>
#include <unistd.h>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

double Median(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

/** The nearest-rank 95th percentile. */
double Percentile95(std::vector<double> values)
{
  if (values.empty())
    return 0.0;
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(std::ceil(0.95 * values.size()));
  return values[std::max<size_t>(rank, 1) - 1];
}

/** One stage's figures in one trial. */
struct StageFigures
{
  int imageDivisor = 0; ///< 0: not a stage of the trace
  double evaluations = 0, drrs = 0, megaRays = 0, renderSeconds = 0, metricSeconds = 0, wallSeconds = 0, cpuSeconds = 0;
  double modelEvaluations = 0; ///< the linearized refinement's, of modelled DRRs (nothing rendered)
};

/** What one optimiser's trials measured. */
struct VariantFigures
{
  std::string optimizer;
  std::vector<std::string> stageOrder;
  std::map<std::string, std::vector<StageFigures>> stages;
  std::vector<double> seconds, evaluations, mtre, megaRays, renderShare, renderSeconds;
  std::vector<double> busy; ///< per trial: CPU time of the staged work over its wall time and the cores
  std::string schedule;     ///< the first trial's (DescribeSchedule)
  int ok = 0, success = 0, trials = 0;
};

StageFigures FiguresOf(const RegistrationStage& stage, int nextEvaluation)
{
  StageFigures f;
  f.imageDivisor = stage.imageDivisor;
  f.evaluations = nextEvaluation - stage.firstEvaluation;
  f.modelEvaluations = stage.modelEvaluations;
  f.drrs = static_cast<double>(stage.cost.drrs);
  f.megaRays = stage.cost.rays / 1e6;
  f.renderSeconds = stage.cost.renderSeconds;
  f.metricSeconds = stage.cost.metricSeconds;
  f.wallSeconds = stage.seconds;
  f.cpuSeconds = stage.cpuSeconds;
  return f;
}

void Record(VariantFigures& variant, const TrialRecord& record, const StereoRegistrationResult& result, int cores)
{
  if (variant.trials == 0)
    variant.schedule = DescribeSchedule(result.schedule);
  ++variant.trials;
  variant.ok += record.status == "ok";
  variant.success += record.success;
  variant.seconds.push_back(record.totalSeconds);
  variant.evaluations.push_back(result.evaluations);
  variant.mtre.push_back(record.mtre);
  const auto add = [&](const std::string& name, const StageFigures& f)
  {
    if (!variant.stages.count(name))
      variant.stageOrder.push_back(name);
    variant.stages[name].push_back(f);
  };
  StageFigures prealign;
  prealign.drrs = static_cast<double>(result.prealignCost.drrs);
  prealign.megaRays = result.prealignCost.rays / 1e6;
  prealign.renderSeconds = result.prealignCost.renderSeconds;
  prealign.metricSeconds = result.prealignCost.metricSeconds;
  prealign.wallSeconds = result.prealignSeconds;
  prealign.cpuSeconds = result.prealignCPUSeconds;
  add("pre-alignment", prealign);
  StageFigures masks;
  masks.wallSeconds = result.maskSeconds;
  masks.cpuSeconds = result.maskCPUSeconds;
  add("masks", masks);
  double rays = prealign.megaRays, render = prealign.renderSeconds;
  for (size_t s = 0; s < result.stages.size(); ++s)
  {
    const int next = s + 1 < result.stages.size() ? result.stages[s + 1].firstEvaluation : static_cast<int>(result.objectiveTrace.size());
    const StageFigures f = FiguresOf(result.stages[s], next);
    rays += f.megaRays;
    render += f.renderSeconds;
    add(result.stages[s].name, f);
  }
  StageFigures gate;
  gate.wallSeconds = result.gateSeconds;
  gate.cpuSeconds = result.gateCPUSeconds;
  add("quality gate (each view's checks)", gate);
  StageFigures table;
  table.wallSeconds = result.table ? result.table->seconds : 0.0;
  table.cpuSeconds = -1.0;
  if (result.table)
    add("table's choice (the body's segmentation, the CT with its table compared)", table);
  // What no stage holds: reading the X-rays into the filter, the end-face test, the records.
  double staged = prealign.wallSeconds + masks.wallSeconds + gate.wallSeconds + table.wallSeconds;
  double stagedCPU = prealign.cpuSeconds + masks.cpuSeconds + gate.cpuSeconds;
  for (const RegistrationStage& stage : result.stages)
    staged += stage.seconds, stagedCPU += stage.cpuSeconds;
  if (staged > 0.0)
    variant.busy.push_back(stagedCPU / (staged * cores));
  StageFigures other;
  other.wallSeconds = std::max(0.0, record.totalSeconds - staged);
  other.cpuSeconds = -1.0;
  add("other (outside the stages)", other);
  variant.megaRays.push_back(rays);
  variant.renderShare.push_back(record.totalSeconds > 0.0 ? render / record.totalSeconds : 0.0);
  variant.renderSeconds.push_back(render);
}

void PrintStages(const VariantFigures& variant, int cores)
{
  std::printf("\n%s: the schedule (xpRegistrationSchedule.h; result.json `schedule`)\n%s", variant.optimizer.c_str(),
    variant.schedule.c_str());
  std::printf("\n%s: medians over the trials that ran each stage\n", variant.optimizer.c_str());
  std::printf("| stage | images | trials | evaluations | model evaluations | DRRs | rays (M) | DRR time (s) | metric time (s) | wall (s) | "
              "cores busy |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& name : variant.stageOrder)
  {
    const std::vector<StageFigures>& all = variant.stages.at(name);
    std::vector<double> e, m, d, r, render, metric, wall, busy;
    for (const StageFigures& f : all)
    {
      e.push_back(f.evaluations), m.push_back(f.modelEvaluations), d.push_back(f.drrs), r.push_back(f.megaRays), render.push_back(f.renderSeconds);
      metric.push_back(f.metricSeconds), wall.push_back(f.wallSeconds);
      if (f.cpuSeconds >= 0.0 && f.wallSeconds > 0.0)
        busy.push_back(f.cpuSeconds / (f.wallSeconds * cores));
    }
    char busyText[32] = "-", sizeText[32] = "-";
    if (!busy.empty())
      std::snprintf(busyText, sizeof busyText, "%.0f %%", 100.0 * Median(busy));
    if (all.front().imageDivisor > 0)
      std::snprintf(sizeText, sizeof sizeText, "1/%d", all.front().imageDivisor);
    std::printf("| %s | %s | %zu | %.0f | %.0f | %.0f | %.2f | %.3f | %.3f | %.3f | %s |\n", name.c_str(), sizeText, all.size(), Median(e),
      Median(m), Median(d), Median(r), Median(render), Median(metric), Median(wall), busyText);
  }
}

/** "SEARCH/FINE" render strides (StereoRegistrationSettings::searchRenderStride, fineRenderStride). */
std::pair<int, int> ParseRenderStrides(const std::string& text)
{
  int search = 0, fine = 0;
  char slash = 0, rest = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &search, &slash, &fine, &rest) != 3 || slash != '/' || search < 0 || search > 8 ||
    fine < 0 || fine > 8)
    throw InputError("--render-strides", "'" + text + "' is not SEARCH/FINE, each 0 (automatic) to 8 (for example 1/2)");
  return { search, fine };
}

} // namespace

int RunBenchRegister(const BenchRegisterOptions& options)
{
  if (options.trials < 1)
    throw InputError("--trials", "must be at least 1");
  if (options.optimizers.empty())
    throw InputError("--optimizers", "name at least one optimiser");
  if (options.renderStrides.empty())
    throw InputError("--render-strides", "name at least one SEARCH/FINE pair");
  if (options.travels.empty())
    throw InputError("--travels", "name at least one of half, quarter");
  for (const std::string& travel : options.travels)
    if (travel != "half" && travel != "quarter")
      throw InputError("--travels", "'" + travel + "' is neither half nor quarter");
  if (options.schedules.empty())
    throw InputError("--schedules", "name at least one of standard, economy");
  for (const std::string& schedule : options.schedules)
    ParseScheduleChoice(schedule, "--schedules");
  std::vector<std::pair<int, int>> strides;
  for (const std::string& text : options.renderStrides)
    strides.push_back(ParseRenderStrides(text));
  for (const std::string& name : options.optimizers) // every name checked before hours of work
  {
    StereoRegistrationSettings check;
    SetOptimizers(name, check, "--optimizers");
  }
  UseThreads(options.threads);
  std::optional<DetectorSettings> detector;
  if (!options.detector.empty())
    detector = DetectorSettings{ ParseDetectorFormat(options.detector, "--detector"), 20000.0, 0.001 };
  const EvaluationScenario scenario(options.scenario, options.without, 30.0, options.removeTable, detector);

  const Clock::time_point readStart = Clock::now();
  const StereoGeometry geometry = ReadStereoGeometry(options.geometry);
  ValidateStereoGeometry(geometry, options.geometry);
  const CTVolume ct = ReadCTVolume(options.ct, options.series);
  const double readSeconds = std::chrono::duration<double>(Clock::now() - readStart).count();
  const PatientSetup patient{ ParsePatientPosition(ct.patientPosition, options.ct), std::nullopt, geometry.isocenter };
  AccuracyEvaluationSettings settings;
  settings.seed = options.seed;
  settings.range = { options.minTranslation, options.maxTranslation, options.maxRotation };
  settings.successMTRE = 1.0;
  settings.shrinkFactor = RegistrationShrinkFactor(geometry.views, ParseSizeIfGiven(options.size, "--size"));
  settings.registration.entropyMask = true;
  settings.registration.chooseTable = options.chooseTable;
  settings.registration.device = UseDevice(options.device);
  const int cores = options.threads > 0 ? options.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  int dims[3];
  ct.image->GetDimensions(dims);
  std::printf("xpose bench register\nCT: %s, %d x %d x %d voxels, read in %.2f s (with the geometry; not in the times "
              "below)\nX-rays: scenario %s%s%s, %d trials (seed %u, %.0f-%.0f mm, %.0f degrees), registered at %s with "
              "entropy masks (approach B) against %.0f %% of the CT's slices%s; %d threads\nmachine: %s\n",
    options.ct.c_str(), dims[0], dims[1], dims[2], readSeconds, options.scenario.c_str(), detector ? ", detector " : "",
    options.detector.c_str(), options.trials, options.seed, options.minTranslation, options.maxTranslation, options.maxRotation,
    options.size.c_str(), 100.0 * scenario.RegistrationCTLength(), scenario.RemovesTable() ? ", its table left out" : "", cores,
    BenchMachineDescription().c_str());

  std::vector<VariantFigures> variants;
  const std::filesystem::path scratch =
    std::filesystem::temp_directory_path() / ("xpose-bench-register-" + std::to_string(::getpid()));
  for (const std::string& optimizer : options.optimizers)
    for (size_t k = 0; k < strides.size(); ++k)
      for (const std::string& travel : options.travels)
        for (const std::string& schedule : options.schedules)
      {
        settings.registration.schedule = ParseScheduleChoice(schedule, "--schedules");
        SetOptimizers(optimizer, settings.registration, "--optimizers");
        settings.registration.searchRenderStride = strides[k].first;
        settings.registration.fineRenderStride = strides[k].second;
        settings.registration.quarterSizeTravel = travel == "quarter";
        std::string name = strides.size() > 1 || strides[k] != std::make_pair(1, 0)
          ? optimizer + ", strides " + options.renderStrides[k] : optimizer;
        if (options.travels.size() > 1 || travel != "half")
          name += ", " + travel + " travel";
        if (options.schedules.size() > 1 || schedule != "economy")
          name += ", " + schedule + " schedule";
        AccuracyEvaluation evaluation(scenario, ct.image, patient, geometry, settings);
        // The folder only carries the records: a fresh one per variant, removed afterwards.
        std::string folderName = optimizer + "-" + std::to_string(k) + "-" + travel + "-" + schedule;
        std::replace(folderName.begin(), folderName.end(), '/', '+');
        const std::filesystem::path directory = scratch / folderName;
        std::filesystem::remove_all(directory);
        std::filesystem::create_directories(scratch);
        VariantFigures variant;
        variant.optimizer = name;
        {
          EvaluationFolder folder(directory.string(), "{\"bench\": \"register\", \"variant\": \"" + name + "\"}");
          evaluation.Run(options.trials, { "B" }, folder, [&](const TrialRecord& record, int, int)
            {
              Record(variant, record, evaluation.LastResult(), cores);
              std::fprintf(stderr, "%s: trial %d, %s, mTRE %.3f mm, %.2f s%s%s\n", name.c_str(), record.trial,
                record.status.c_str(), record.mtre, record.totalSeconds, record.reasons.empty() ? "" : ": ", record.reasons.c_str());
            });
        }
        std::filesystem::remove_all(directory);
        PrintStages(variant, cores);
        variants.push_back(std::move(variant));
      }
  std::filesystem::remove_all(scratch);

  std::printf("\nVariants side by side (the same trials and X-rays; time = the registration, CT read excluded; the CT "
              "read once, %.2f s, added in its own column: what one `xpose register` on this CT waits for)\n", readSeconds);
  std::printf("| variant | ok | within 1 mm and ok | median mTRE (mm) | median evaluations | median rays (M) | median DRR time "
              "(s) | DRR share of the time | cores busy | median time (s) | p95 time (s) | median time with the CT read (s) | time / %s |\n"
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    variants.front().optimizer.c_str());
  const double reference = Median(variants.front().seconds);
  for (const VariantFigures& v : variants)
    std::printf("| %s | %d/%d | %d/%d | %.3f | %.0f | %.1f | %.3f | %.0f %% | %.0f %% | %.2f | %.2f | %.2f | %.2f |\n", v.optimizer.c_str(),
      v.ok, v.trials, v.success, v.trials, Median(v.mtre), Median(v.evaluations), Median(v.megaRays), Median(v.renderSeconds),
      100.0 * Median(v.renderShare), 100.0 * Median(v.busy),
      Median(v.seconds), Percentile95(v.seconds), Median(v.seconds) + readSeconds,
      reference > 0.0 ? Median(v.seconds) / reference : 0.0);
  return ExitOk;
}

} // namespace xp
