#include "xpEvaluation.h"

#include "xpError.h"
#include "xpImageIO.h"
#include "xpPlot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

namespace xp
{

namespace
{

const char* const AxisNames[6] = { "tx", "ty", "tz", "pitch", "roll", "yaw" };

std::vector<std::string> SplitCSV(const std::string& line)
{
  std::vector<std::string> fields;
  std::stringstream stream(line);
  std::string field;
  while (std::getline(stream, field, ','))
    fields.push_back(field);
  if (!line.empty() && line.back() == ',')
    fields.emplace_back();
  return fields;
}

std::string Number(double value)
{
  if (!std::isfinite(value))
    return "null";
  char text[64];
  std::snprintf(text, sizeof(text), "%.6g", value);
  return text;
}

double MaxAbs(const std::array<double, 6>& error, int first)
{
  return std::max({ std::abs(error[first]), std::abs(error[first + 1]), std::abs(error[first + 2]) });
}

/** Statistics of a group of records, as one JSON object. */
std::string GroupJSON(const std::vector<const TrialRecord*>& group)
{
  std::vector<double> mtre, translation, rotation, seconds, drrs, evaluations;
  std::array<std::vector<double>, 6> axis, signedAxis;
  int successes = 0, ok = 0, okBeyond2 = 0;
  double largestOk = 0.0;
  for (const TrialRecord* r : group)
  {
    successes += r->success;
    ok += r->status == "ok";
    mtre.push_back(r->mtre);
    translation.push_back(MaxAbs(r->error, 0));
    rotation.push_back(MaxAbs(r->error, 3));
    seconds.push_back(r->totalSeconds);
    drrs.push_back(static_cast<double>(r->drrCount));
    evaluations.push_back(r->evaluations);
    for (int a = 0; a < 6; ++a)
    {
      axis[a].push_back(std::abs(r->error[a]));
      signedAxis[a].push_back(r->error[a]);
    }
    if (r->status == "ok")
    {
      largestOk = std::max(largestOk, r->mtre);
      okBeyond2 += r->mtre > 2.0;
    }
  }
  const double n = static_cast<double>(group.size());
  std::ostringstream json;
  json << "{\"trials\": " << group.size() << ", \"success_rate\": " << Number(n > 0 ? successes / n : NAN)
       << ", \"status_ok_rate\": " << Number(n > 0 ? ok / n : NAN) << ", \"mtre_mm\": {\"median\": " << Number(Quantile(mtre, 0.5))
       << ", \"p95\": " << Number(Quantile(mtre, 0.95)) << "}, \"abs_error_median\": {";
  for (int a = 0; a < 6; ++a)
    json << (a ? ", " : "") << "\"" << AxisNames[a] << "\": " << Number(Quantile(axis[a], 0.5));
  json << "}, \"signed_error_median\": {";
  for (int a = 0; a < 6; ++a)
    json << (a ? ", " : "") << "\"" << AxisNames[a] << "\": " << Number(Quantile(signedAxis[a], 0.5));
  json << "}, \"ok_beyond_2mm_mtre\": " << okBeyond2 << ", \"largest_ok_mtre_mm\": " << Number(largestOk);
  json << ", \"abs_error_p95\": {";
  for (int a = 0; a < 6; ++a)
    json << (a ? ", " : "") << "\"" << AxisNames[a] << "\": " << Number(Quantile(axis[a], 0.95));
  json << "}, \"max_axis_translation_error_mm\": {\"median\": " << Number(Quantile(translation, 0.5))
       << ", \"p95\": " << Number(Quantile(translation, 0.95)) << "}, \"max_axis_rotation_error_deg\": {\"median\": "
       << Number(Quantile(rotation, 0.5)) << ", \"p95\": " << Number(Quantile(rotation, 0.95))
       << "}, \"time_s\": {\"median\": " << Number(Quantile(seconds, 0.5)) << ", \"p95\": " << Number(Quantile(seconds, 0.95))
       << "}, \"drr_count_median\": " << Number(Quantile(drrs, 0.5))
       << ", \"evaluations_median\": " << Number(Quantile(evaluations, 0.5)) << "}";
  return json.str();
}

} // namespace

double Quantile(std::vector<double> values, double q)
{
  if (values.empty())
    return NAN;
  std::sort(values.begin(), values.end());
  const double position = q * (values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, values.size() - 1);
  return values[below] + (position - below) * (values[above] - values[below]);
}

std::string TrialCSVHeader()
{
  std::string header = "trial,approach,scenario";
  for (const char* axis : AxisNames)
    header += std::string(",initial_") + axis;
  header += ",initial_translation_mm,initial_mtre_mm,status";
  for (const char* axis : AxisNames)
    header += std::string(",error_") + axis;
  return header + ",mtre_mm,success,prealign_s,mask_s,fine_s,total_s,drr_count,evaluations,search_evaluations,"
                  "refinement_evaluations,second_end_evaluations,polish_evaluations,gate_evaluations,explained,residual_mm,uncovered,"
                  "search_apart_mm,search_apart_deg,valid_pixels,end_face_excess_min,end_face_excess_max,end_faces_left_out,peak_margin,"
                  "uncertainty_mm,uncertainty_deg,halves_apart_mm,peak_leads,edge_mm,edge_moved_mm,xray_rank_noise,table,reasons";
}

std::string TrialCSVRow(const TrialRecord& r)
{
  std::ostringstream row;
  row.precision(8);
  row << r.trial << ',' << r.approach << ',' << r.scenario;
  for (double v : r.initial)
    row << ',' << v;
  row << ',' << r.initialTranslation << ',' << r.initialMTRE << ',' << r.status;
  for (double v : r.error)
    row << ',' << v;
  std::string reasons = r.reasons;
  std::replace(reasons.begin(), reasons.end(), ',', ' ');
  std::replace(reasons.begin(), reasons.end(), '\n', ' ');
  row << ',' << r.mtre << ',' << (r.success ? 1 : 0) << ',' << r.prealignSeconds << ',' << r.maskSeconds << ','
      << r.fineSeconds << ',' << r.totalSeconds << ',' << r.drrCount << ',' << r.evaluations << ',' << r.searchEvaluations << ','
      << r.refinementEvaluations << ',' << r.secondEndEvaluations << ',' << r.polishEvaluations << ','
      << r.gateEvaluations << ',' << r.explained << ','
      << r.residualMM << ',' << r.uncovered << ',' << r.searchApartMM << ',' << r.searchApartDegrees << ','
      << r.validPixels << ',' << r.endFaceExcessMin << ',' << r.endFaceExcessMax << ',' << r.endFacesLeftOut << ','
      << r.peakMargin << ',' << r.uncertaintyMM << ',' << r.uncertaintyDegrees << ',' << r.halvesApartMM << ',';
  for (size_t k = 0; k < r.peakLeads.size(); ++k)
    row << (k ? " " : "") << r.peakLeads[k];
  // Per view, space-separated (a registration that ended early has none).
  for (const std::vector<double>* perView : { &r.edgeMM, &r.edgeMovedMM, &r.xrayRankNoise })
  {
    row << ',';
    for (size_t v = 0; v < perView->size(); ++v)
      row << (v ? " " : "") << (*perView)[v];
  }
  row << ',' << r.table << ',' << reasons;
  return row.str();
}

std::vector<TrialRecord> ReadTrialCSV(const std::string& path)
{
  std::ifstream in(path);
  std::vector<TrialRecord> records;
  if (!in)
    return records;
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line))
    lines.push_back(line);
  const bool lastLineComplete = [&] {
    std::ifstream tail(path, std::ios::binary | std::ios::ate);
    if (tail.tellg() <= 0)
      return true;
    tail.seekg(-1, std::ios::end);
    return tail.get() == '\n';
  }();
  if (lines.empty())
    return records;
  const std::string header = TrialCSVHeader();
  const size_t columns = static_cast<size_t>(std::count(header.begin(), header.end(), ',')) + 1;
  if (lines[0] != header)
  {
    throw InputError(path, "line 1: not the header of this version's trials.csv; use another --out-dir");
  }
  for (size_t n = 1; n < lines.size(); ++n)
  {
    const std::vector<std::string> f = SplitCSV(lines[n]);
    const bool cutOff = n + 1 == lines.size() && !lastLineComplete;
    try
    {
      if (f.size() != columns)
        throw std::invalid_argument("columns");
      TrialRecord r;
      size_t i = 0;
      r.trial = std::stoi(f[i++]);
      r.approach = f[i++];
      r.scenario = f[i++];
      for (double& v : r.initial)
        v = std::stod(f[i++]);
      r.initialTranslation = std::stod(f[i++]);
      r.initialMTRE = std::stod(f[i++]);
      r.status = f[i++];
      for (double& v : r.error)
        v = std::stod(f[i++]);
      r.mtre = std::stod(f[i++]);
      r.success = f[i++] == "1";
      r.prealignSeconds = std::stod(f[i++]);
      r.maskSeconds = std::stod(f[i++]);
      r.fineSeconds = std::stod(f[i++]);
      r.totalSeconds = std::stod(f[i++]);
      r.drrCount = std::stoll(f[i++]);
      r.evaluations = std::stoi(f[i++]);
      for (int* v : { &r.searchEvaluations, &r.refinementEvaluations, &r.secondEndEvaluations, &r.polishEvaluations,
             &r.gateEvaluations })
        *v = std::stoi(f[i++]);
      for (double* v : { &r.explained, &r.residualMM, &r.uncovered, &r.searchApartMM, &r.searchApartDegrees })
        *v = std::stod(f[i++]);
      r.validPixels = std::stoll(f[i++]);
      r.endFaceExcessMin = std::stod(f[i++]);
      r.endFaceExcessMax = std::stod(f[i++]);
      r.endFacesLeftOut = std::stoi(f[i++]);
      for (double* v : { &r.peakMargin, &r.uncertaintyMM, &r.uncertaintyDegrees, &r.halvesApartMM })
        *v = std::stod(f[i++]);
      // "nan" for a neighbour not measured (the turned ones without --held-out-turns).
      std::istringstream leads(f[i++]);
      for (double& v : r.peakLeads)
      {
        std::string lead;
        size_t used = 0;
        if (!(leads >> lead) || (v = std::stod(lead, &used), used != lead.size()))
          throw std::invalid_argument("peak_leads");
      }
      for (std::vector<double>* perView : { &r.edgeMM, &r.edgeMovedMM, &r.xrayRankNoise })
      {
        std::istringstream values(f[i++]);
        for (double v; values >> v;)
          perView->push_back(v);
        if (!values.eof())
          throw std::invalid_argument("edge figures");
      }
      r.table = f[i++];
      r.reasons = f[i++];
      records.push_back(r);
    }
    catch (const std::exception&)
    {
      if (cutOff)
        break; // the row being written when the run was interrupted: that trial runs again
      throw InputError(path, "line " + std::to_string(n + 1) + ": expected " + std::to_string(columns) +
          " comma-separated fields of a trial");
    }
  }
  return records;
}

std::string SummaryJSON(const std::vector<TrialRecord>& records, double successMTRE)
{
  std::map<std::string, std::vector<const TrialRecord*>> byApproach;
  for (const TrialRecord& r : records)
    byApproach[r.approach].push_back(&r);
  std::ostringstream json;
  json << "{\n  \"success_definition\": \"status ok and mTRE < " << successMTRE << " mm\",\n  \"approaches\": {";
  bool firstApproach = true;
  std::map<std::string, double> medianSeconds;
  std::map<std::string, std::array<double, 3>> goals; // success <= 20 mm, <= 30 mm
  for (const auto& [approach, group] : byApproach)
  {
    json << (firstApproach ? "" : ",") << "\n    \"" << approach << "\": {\n      \"all\": " << GroupJSON(group)
         << ",\n      \"bands_mm\": {";
    firstApproach = false;
    std::map<int, std::vector<const TrialRecord*>> bands;
    std::vector<const TrialRecord*> upTo20, upTo30;
    std::vector<double> seconds;
    for (const TrialRecord* r : group)
    {
      bands[static_cast<int>(std::floor(r->initialTranslation / 5.0))].push_back(r);
      if (r->initialTranslation <= 20.0)
        upTo20.push_back(r);
      if (r->initialTranslation <= 30.0)
        upTo30.push_back(r);
      seconds.push_back(r->totalSeconds);
    }
    bool firstBand = true;
    for (const auto& [band, members] : bands)
    {
      json << (firstBand ? "" : ",") << "\n        \"" << 5 * band << "-" << 5 * band + 5 << "\": " << GroupJSON(members);
      firstBand = false;
    }
    json << "\n      }\n    }";
    const auto rate = [](const std::vector<const TrialRecord*>& g) {
      return g.empty() ? NAN : static_cast<double>(std::count_if(g.begin(), g.end(), [](auto* r) { return r->success; })) / g.size();
    };
    medianSeconds[approach] = Quantile(seconds, 0.5);
    goals[approach] = { rate(upTo20), rate(upTo30), static_cast<double>(group.size()) };
  }
  json << "\n  }";
  // The goals of the evaluation issue, for the masked approach B (the method xpose runs by default).
  if (byApproach.count("B"))
  {
    std::array<std::vector<double>, 6> axis;
    for (const TrialRecord* r : byApproach["B"])
      for (int a = 0; a < 6; ++a)
        axis[a].push_back(std::abs(r->error[a]));
    double translation = 0.0, rotation = 0.0;
    for (int a = 0; a < 3; ++a)
    {
      translation = std::max(translation, Quantile(axis[a], 0.5));
      rotation = std::max(rotation, Quantile(axis[a + 3], 0.5));
    }
    const double speedup = medianSeconds.count("A") ? medianSeconds["A"] / medianSeconds["B"] : NAN;
    const auto met = [](double value, double goal, bool atLeast) {
      return std::isfinite(value) ? ((atLeast ? value >= goal : value <= goal) ? "true" : "false") : "null";
    };
    json << ",\n  \"goals_B\": {\n    \"success_up_to_20mm\": {\"value\": " << Number(goals["B"][0])
         << ", \"goal\": 0.95, \"met\": " << met(goals["B"][0], 0.95, true) << "},\n    \"success_up_to_30mm\": {\"value\": "
         << Number(goals["B"][1]) << ", \"goal\": 0.90, \"met\": " << met(goals["B"][1], 0.90, true)
         << "},\n    \"median_abs_translation_error_mm\": {\"value\": " << Number(translation)
         << ", \"goal\": 0.3, \"met\": " << met(translation, 0.3, false)
         << "},\n    \"median_abs_rotation_error_deg\": {\"value\": " << Number(rotation) << ", \"goal\": 0.1, \"met\": "
         << met(rotation, 0.1, false) << "},\n    \"speedup_A_over_B_median_time\": {\"value\": " << Number(speedup)
         << ", \"goal\": 4, \"met\": " << met(speedup, 4.0, true) << "}\n  }";
  }
  json << "\n}\n";
  return json.str();
}

std::string SummaryTable(const std::vector<TrialRecord>& records)
{
  std::map<std::string, std::vector<const TrialRecord*>> byApproach;
  std::map<int, std::map<std::string, std::vector<const TrialRecord*>>> byBand;
  for (const TrialRecord& r : records)
  {
    byApproach[r.approach].push_back(&r);
    byBand[static_cast<int>(std::floor(r.initialTranslation / 5.0))][r.approach].push_back(&r);
  }
  const auto rate = [](const std::vector<const TrialRecord*>& group, double upTo) {
    int n = 0, successes = 0;
    for (const TrialRecord* r : group)
      if (r->initialTranslation <= upTo)
        ++n, successes += r->success;
    char text[32];
    std::snprintf(text, sizeof(text), n ? "%.0f %% (%d/%d)" : "-", n ? 100.0 * successes / n : 0.0, successes, n);
    return std::string(text);
  };
  const auto column = [](const std::vector<const TrialRecord*>& group, auto value) {
    std::vector<double> values;
    for (const TrialRecord* r : group)
      values.push_back(value(*r));
    return values;
  };
  std::ostringstream table;
  char line[512];
  table << "| approach | trials | success <= 20 mm | success <= 30 mm | median mTRE (mm) | p95 mTRE (mm) | median abs error "
           "tx ty tz (mm) | median abs error pitch roll yaw (deg) | median time (s) | p95 time (s) |\n|---|---|---|---|---|---|---|---|---|---|\n";
  std::map<std::string, double> medianTime;
  for (const auto& [approach, group] : byApproach)
  {
    std::array<double, 6> axis{};
    for (int a = 0; a < 6; ++a)
      axis[a] = Quantile(column(group, [a](const TrialRecord& r) { return std::abs(r.error[a]); }), 0.5);
    const std::vector<double> mtre = column(group, [](const TrialRecord& r) { return r.mtre; });
    const std::vector<double> seconds = column(group, [](const TrialRecord& r) { return r.totalSeconds; });
    medianTime[approach] = Quantile(seconds, 0.5);
    std::snprintf(line, sizeof(line), "| %s | %zu | %s | %s | %.3f | %.3f | %.3f %.3f %.3f | %.3f %.3f %.3f | %.1f | %.1f |\n",
      approach == "A" ? "A: whole image" : approach == "B" ? "B: entropy masks" : approach.c_str(), group.size(),
      rate(group, 20.0).c_str(), rate(group, 30.0).c_str(), Quantile(mtre, 0.5), Quantile(mtre, 0.95), axis[0], axis[1], axis[2],
      axis[3], axis[4], axis[5], medianTime[approach], Quantile(seconds, 0.95));
    table << line;
  }
  // Bias: the median signed error per axis, and the confident wrong answers.
  table << "\n| approach | median signed error tx ty tz (mm) | median signed error pitch roll yaw (deg) | ok | ok beyond "
           "2 mm mTRE | largest ok mTRE (mm) |\n|---|---|---|---|---|---|\n";
  for (const auto& [approach, group] : byApproach)
  {
    std::array<double, 6> bias{};
    for (int a = 0; a < 6; ++a)
      bias[a] = Quantile(column(group, [a](const TrialRecord& r) { return r.error[a]; }), 0.5);
    int ok = 0, wrong = 0;
    double largest = 0.0;
    for (const TrialRecord* r : group)
      if (r->status == "ok")
      {
        ++ok;
        wrong += r->mtre > 2.0;
        largest = std::max(largest, r->mtre);
      }
    std::snprintf(line, sizeof(line), "| %s | %+.3f %+.3f %+.3f | %+.3f %+.3f %+.3f | %d | %d | %.3f |\n", approach.c_str(), bias[0],
      bias[1], bias[2], bias[3], bias[4], bias[5], ok, wrong, largest);
    table << line;
  }
  if (medianTime.count("A") && medianTime.count("B") && medianTime["B"] > 0)
  {
    std::snprintf(line, sizeof(line), "\nmedian time A / B: %.2f\n", medianTime["A"] / medianTime["B"]);
    table << line;
  }
  table << "\n| initial error band (mm) | trials | success A | success B | median mTRE A (mm) | median mTRE B (mm) | median time A (s) | "
           "median time B (s) |\n|---|---|---|---|---|---|---|---|\n";
  for (auto& entry : byBand)
  {
    // Not a structured binding: C++17 lambdas cannot capture one (clang refuses).
    const int band = entry.first;
    auto& groups = entry.second;
    const auto median = [&](const std::string& approach, auto value) {
      return groups.count(approach) ? Quantile(column(groups[approach], value), 0.5) : NAN;
    };
    const size_t trials = std::max(groups.count("A") ? groups["A"].size() : 0, groups.count("B") ? groups["B"].size() : 0);
    std::snprintf(line, sizeof(line), "| %d-%d | %zu | %s | %s | %.3f | %.3f | %.1f | %.1f |\n", 5 * band, 5 * band + 5, trials,
      rate(groups["A"], 1e9).c_str(), rate(groups["B"], 1e9).c_str(), median("A", [](const TrialRecord& r) { return r.mtre; }),
      median("B", [](const TrialRecord& r) { return r.mtre; }), median("A", [](const TrialRecord& r) { return r.totalSeconds; }),
      median("B", [](const TrialRecord& r) { return r.totalSeconds; }));
    table << line;
  }
  return table.str();
}

void WriteEvaluationPlots(const std::vector<TrialRecord>& records, double successMTRE, const std::string& directory)
{
  const std::map<std::string, std::array<unsigned char, 3>> colours{ { "A", { 200, 60, 40 } }, { "B", { 30, 90, 200 } } };
  const auto name = [](const std::string& approach) {
    return approach == "A" ? std::string("A: whole image") : approach == "B" ? std::string("B: entropy masks") : approach;
  };
  Plot error("Final error against initial error", "initial translation error (mm)", "final mTRE (mm)");
  error.SetLogY(true);
  error.AddMarker({ successMTRE, "success threshold", false });
  Plot time("Registration time against initial error", "initial translation error (mm)", "time (s)");
  Plot capture("Capture range", "initial translation error (mm), 5 mm bands", "success rate");
  capture.SetYRange(0.0, 1.05);
  for (const auto& [approach, rgb] : colours)
  {
    PlotSeries errors{ name(approach), {}, {}, rgb }, times{ name(approach), {}, {}, rgb };
    std::map<int, std::pair<int, int>> bands; // band -> successes, trials
    for (const TrialRecord& r : records)
    {
      if (r.approach != approach)
        continue;
      errors.x.push_back(r.initialTranslation);
      errors.y.push_back(r.mtre);
      times.x.push_back(r.initialTranslation);
      times.y.push_back(r.totalSeconds);
      auto& band = bands[static_cast<int>(std::floor(r.initialTranslation / 5.0))];
      band.first += r.success;
      band.second += 1;
    }
    if (errors.x.empty())
      continue;
    PlotSeries rate{ name(approach), {}, {}, rgb, true, true };
    for (const auto& [band, counts] : bands)
    {
      rate.x.push_back(5.0 * band + 2.5);
      rate.y.push_back(static_cast<double>(counts.first) / counts.second);
    }
    error.AddSeries(errors);
    time.AddSeries(times);
    capture.AddSeries(rate);
  }
  const auto write = [&](const Plot& plot, const std::string& file) {
    const std::string path = directory + "/" + file, partial = directory + "/partial-" + file;
    WritePNG(plot.Render(900, 560), partial);
    if (std::rename(partial.c_str(), path.c_str()) != 0)
      throw Error(path, "cannot write");
  };
  write(error, "final_error.png");
  write(time, "time.png");
  write(capture, "capture_range.png");
}

} // namespace xp
