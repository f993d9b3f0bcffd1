/**
 * @file xpEvaluation.h
 * @brief The records of an evaluation (`xpose evaluate`): one CSV row per trial and approach,
 *        their summary (JSON, Markdown) and plots.
 */
#ifndef xpEvaluation_h
#define xpEvaluation_h

#include "vtkXPEvaluationModule.h"

#include <array>
#include <string>
#include <vector>

namespace xp
{

/** One registration of one trial: approach "A" (whole image) or "B" (entropy masks). */
struct TrialRecord
{
  int trial = 0;
  std::string approach;
  std::string scenario;
  std::array<double, 6> initial{};   ///< the true misalignment tx,ty,tz (mm), pitch,roll,yaw (deg)
  double initialTranslation = 0.0;   ///< |t| of the true misalignment, mm
  double initialMTRE = 0.0;          ///< mTRE of the start pose (no correction), mm
  std::string status;                ///< "ok" or "failed"
  std::array<double, 6> error{};     ///< estimated minus true misalignment, per axis
  double mtre = 0.0;                 ///< mean target registration error after registration, mm
  bool success = false;              ///< status ok and mtre below the success threshold
  double prealignSeconds = 0.0, maskSeconds = 0.0, fineSeconds = 0.0, totalSeconds = 0.0;
  long long drrCount = 0;
  int evaluations = 0;
  /** `evaluations` by what they served (result.json `convergence.stages`): the searches at every
   *  size, the refinement of the better search end, the refinement of the second end (where both
   *  were refined), the polish, and the gate's own (the landscape, the held-out check, the result). */
  int searchEvaluations = 0, refinementEvaluations = 0, secondEndEvaluations = 0, polishEvaluations = 0, gateEvaluations = 0;
  /** The gate's measures (worst view), to calibrate it: MI / H(X-ray), 2D residual (mm),
   *  uncovered fraction, and how far apart the two searches ended (mm, degrees). */
  double explained = 0.0, residualMM = 0.0, uncovered = 0.0, searchApartMM = 0.0, searchApartDegrees = 0.0;
  /** The fewest valid pixels of a view; the least and most excess attenuation beyond a CT end
   *  face over all faces and views, and how many faces were left out (xpCTCoverage.h). */
  long long validPixels = 0;
  double endFaceExcessMin = 0.0, endFaceExcessMax = 0.0;
  int endFacesLeftOut = 0;
  /** The landscape at the result: the least lead of the result over its held-out neighbours, and the largest per-axis
   *  uncertainty in mm and in degrees (inf: no maximum along some axis). */
  double peakMargin = 0.0, uncertaintyMM = 0.0, uncertaintyDegrees = 0.0;
  double halvesApartMM = 0.0; ///< the largest over views (xpQualityGate.h)
  std::array<double, 12> peakLeads{}; ///< each held-out neighbour's lead (StereoRegistrationResult::peakLeads)
  /** Per view: the DRR's edges' median distance to the X-ray's, and with the DRR moved 3 mm
   *  (StereoRegistrationResult::edgeDistanceMM, edgeDistanceShiftedMM). */
  std::vector<double> edgeMM, edgeMovedMM;
  /** Per view: the X-ray's noise on its ranks, which sets its smoothing
   *  (StereoRegistrationResult::xrayRankNoise). */
  std::vector<double> xrayRankNoise;
  /** With chooseTable, the CT the X-rays chose: "ct" (with its table, or none found) or
   *  "body_only"; empty without. */
  std::string table;
  std::string reasons;               ///< the gate's reasons, ';'-separated
};

/** The CSV header line (without newline) and one row. */
VTKXPEVALUATION_EXPORT std::string TrialCSVHeader();
VTKXPEVALUATION_EXPORT std::string TrialCSVRow(const TrialRecord& record);

/**
 * Reads the rows of a trials.csv written by TrialCSVRow. A last line cut off by an interruption
 * is ignored; any other malformed line or a different header throws xp::InputError naming the
 * file and the line. A missing file gives no rows.
 */
VTKXPEVALUATION_EXPORT std::vector<TrialRecord> ReadTrialCSV(const std::string& path);

/** summary.json: per approach and per 5 mm band of initial error, and the goals of the issue. */
VTKXPEVALUATION_EXPORT std::string SummaryJSON(const std::vector<TrialRecord>& records, double successMTRE);

/** The summary as Markdown tables (per approach, per 5 mm band), printed at the end of a run. */
VTKXPEVALUATION_EXPORT std::string SummaryTable(const std::vector<TrialRecord>& records);

/**
 * The plots of an evaluation, as PNG in `directory`: final_error.png (final mTRE against initial
 * error, the paper's Figure 6), time.png (registration time against initial error) and
 * capture_range.png (success rate per 5 mm band of initial error), approaches A and B together.
 */
VTKXPEVALUATION_EXPORT void WriteEvaluationPlots(const std::vector<TrialRecord>& records, double successMTRE, const std::string& directory);

/** The q-quantile (0..1) of values, linear between order statistics; NaN when empty. */
VTKXPEVALUATION_EXPORT double Quantile(std::vector<double> values, double q);

} // namespace xp

#endif
