#include "xpEvaluationFolder.h"

#include "xpError.h"
#include "xpWholeFile.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

EvaluationFolder::EvaluationFolder(const std::string& directory, const std::string& settingsJSON)
  : Directory(directory)
{
  if (mkdir(directory.c_str(), 0755) != 0 && errno != EEXIST)
  {
    throw InputError(directory, "cannot create the output folder");
  }
  const std::string settingsPath = directory + "/evaluation.json";
  this->Rows = ReadTrialCSV(this->CSVPath());
  struct stat info;
  if (stat(settingsPath.c_str(), &info) == 0 && ReadWholeFile(settingsPath) != settingsJSON)
  {
    throw InputError(settingsPath, "was written with other settings (CT, geometry, scenario, size, seed or ranges); "
                                   "resume with the same options or use another --out-dir");
  }
  WriteWholeFile(settingsPath, settingsJSON);
  // Rewrite the rows that were read whole: drops a row cut off by an interruption.
  std::string text = TrialCSVHeader() + "\n";
  for (const TrialRecord& r : this->Rows)
  {
    text += TrialCSVRow(r) + "\n";
    this->Finished.insert({ r.trial, r.approach });
  }
  WriteWholeFile(this->CSVPath(), text);
  this->CSV.open(this->CSVPath(), std::ios::app);
}

bool EvaluationFolder::Done(int trial, const std::string& approach) const
{
  return this->Finished.count({ trial, approach }) > 0;
}

void EvaluationFolder::Append(const TrialRecord& record)
{
  this->CSV << TrialCSVRow(record) << std::endl; // flushed: an interruption keeps every finished registration
  if (!this->CSV)
  {
    throw Error(this->CSVPath(), "cannot append a trial");
  }
  this->Rows.push_back(record);
  this->Finished.insert({ record.trial, record.approach });
}

std::vector<TrialRecord> EvaluationFolder::Finish(int trials, double successMTRE)
{
  std::vector<TrialRecord> records = this->Rows;
  records.erase(std::remove_if(records.begin(), records.end(), [&](const TrialRecord& r) { return r.trial > trials; }),
    records.end());
  WriteWholeFile(this->Directory + "/summary.json", SummaryJSON(records, successMTRE));
  WriteEvaluationPlots(records, successMTRE, this->Directory);
  return records;
}

} // namespace xp
