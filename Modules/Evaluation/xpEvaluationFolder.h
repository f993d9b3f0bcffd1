/**
 * @file xpEvaluationFolder.h
 * @brief The output folder of an evaluation, which an interrupted run resumes.
 */
#ifndef xpEvaluationFolder_h
#define xpEvaluationFolder_h

#include "vtkXPEvaluationModule.h"
#include "xpEvaluation.h"

#include <fstream>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace xp
{

/**
 * evaluation.json holds the settings that make trials comparable; trials.csv gets one row per
 * finished registration, flushed at once, so that a run stopped at any point resumes where it
 * was with the same settings, and refuses other settings.
 */
class VTKXPEVALUATION_EXPORT EvaluationFolder
{
public:
  /**
   * Creates the folder or opens it to resume. A row cut off by an interruption is dropped.
   * Throws xp::InputError when the folder holds an evaluation with other `settingsJSON`.
   */
  EvaluationFolder(const std::string& directory, const std::string& settingsJSON);

  const std::vector<TrialRecord>& Records() const { return this->Rows; }
  bool Done(int trial, const std::string& approach) const;
  /** Appends a row to trials.csv and flushes it. */
  void Append(const TrialRecord& record);
  /** summary.json and the plots of trials 1..`trials` (rows of a longer earlier run stay in
   *  trials.csv); returns those records. */
  std::vector<TrialRecord> Finish(int trials, double successMTRE);

  std::string CSVPath() const { return this->Directory + "/trials.csv"; }

private:
  std::string Directory;
  std::vector<TrialRecord> Rows;
  std::set<std::pair<int, std::string>> Finished;
  std::ofstream CSV;
};

} // namespace xp

#endif
