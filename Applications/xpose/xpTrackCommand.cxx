#include "xpCommands.h"

#include "xpError.h"
#include "xpImageIO.h"
#include "xpRegistrationRecord.h"
#include "xpRegistrationSession.h"
#include "xpVolumeIO.h"

#include <json/json.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <sys/stat.h>

namespace xp
{

namespace
{

/** "A.tif,B.tif" -> its files, each checked to exist (all frames before any work). */
std::vector<std::string> FrameFiles(const std::string& frame, size_t index)
{
  std::vector<std::string> files;
  std::stringstream in(frame);
  for (std::string file; std::getline(in, file, ',');)
  {
    struct stat status;
    if (file.empty() || stat(file.c_str(), &status) != 0)
      throw InputError("--frames", "frame " + std::to_string(index + 1) + ": no such X-ray '" + file + "'");
    files.push_back(file);
  }
  return files;
}

/** "frame-0001" for the first frame: each frame's folder, under the output and the report. */
std::string FrameName(size_t index)
{
  char name[32];
  std::snprintf(name, sizeof(name), "frame-%04zu", index + 1);
  return name;
}

/** poses.csv's header for `views` X-rays per frame. */
std::string PosesCSVHeader(size_t views)
{
  std::ostringstream csv;
  csv << "frame";
  for (size_t v = 0; v < views; ++v)
    csv << ",xray_" << static_cast<char>('a' + v);
  csv << ",status,tx_mm,ty_mm,tz_mm,pitch_deg,roll_deg,yaw_deg,uncertainty_tx_mm,uncertainty_ty_mm,uncertainty_tz_mm,"
         "uncertainty_pitch_deg,uncertainty_roll_deg,uncertainty_yaw_deg,time_s";
  // After the columns: per view, the median distance (mm at the isocentre) from the DRR's
  // edges to the X-ray's, and the same with the DRR moved 3 mm (what chance gives).
  for (size_t v = 0; v < views; ++v)
    csv << ",edge_distance_" << static_cast<char>('a' + v) << "_mm,edge_distance_moved_" << static_cast<char>('a' + v) << "_mm";
  // Then the couch motion of an ok frame (empty for a failed one): result.json's `couch`.
  csv << ",couch_action,couch_tx_mm,couch_ty_mm,couch_tz_mm,couch_pitch_deg,couch_roll_deg,couch_yaw_deg,"
         "uncorrected_pitch_deg,uncorrected_roll_deg,uncorrected_yaw_deg,couch_limited_by";
  csv << "\n";
  return csv.str();
}

/** One frame's row of poses.csv: its X-rays, the record's status, pose, uncertainty, time, edges
 *  and couch motion. */
std::string PosesCSVRow(size_t frame, const std::vector<std::string>& files, const RegistrationRecord& record)
{
  std::ostringstream csv;
  const std::array<double, 6> p = record.misalignment.Parameters();
  csv << frame;
  for (const std::string& file : files)
    csv << "," << file;
  csv << "," << (record.ok ? "ok" : "failed");
  csv << std::setprecision(6);
  for (double value : p)
    csv << "," << value;
  for (double value : record.uncertainty)
    csv << "," << value;
  csv << "," << record.totalSeconds;
  for (size_t v = 0; v < files.size(); ++v)
    csv << "," << (v < record.edgeDistanceMM.size() ? record.edgeDistanceMM[v] : -1.0) << ","
        << (v < record.edgeDistanceShiftedMM.size() ? record.edgeDistanceShiftedMM[v] : -1.0);
  if (record.couch)
  {
    const CouchMotion& couch = *record.couch;
    std::string limits;
    for (const std::string& limit : couch.limitedBy)
      limits += (limits.empty() ? "" : " ") + limit;
    csv << "," << CouchActionName(couch.action) << "," << couch.motion.translation[0] << "," << couch.motion.translation[1]
        << "," << couch.motion.translation[2] << "," << couch.motion.pitch << "," << couch.motion.roll << ","
        << couch.motion.yaw << "," << couch.uncorrected.pitch << "," << couch.uncorrected.roll << ","
        << couch.uncorrected.yaw << "," << limits;
  }
  else
    csv << ",,,,,,,,,,,";
  csv << "\n";
  return csv.str();
}

/** One frame's entry of poses.json. */
Json::Value PoseItem(size_t frame, const std::vector<std::string>& files, const char* startedFrom, const RegistrationRecord& record)
{
  const std::array<double, 6> p = record.misalignment.Parameters();
  Json::Value item;
  item["frame"] = static_cast<Json::UInt64>(frame);
  for (const std::string& file : files)
    item["xrays"].append(file);
  item["status"] = record.ok ? "ok" : "failed";
  item["start"] = startedFrom;
  for (size_t k = 0; k < 6; ++k)
  {
    static const char* names[6] = { "tx_mm", "ty_mm", "tz_mm", "pitch_deg", "roll_deg", "yaw_deg" };
    item["misalignment"][names[k]] = p[k];
    item["uncertainty"][names[k]] =
      std::isfinite(record.uncertainty[k]) ? Json::Value(record.uncertainty[k]) : Json::Value(Json::nullValue); // no maximum
  }
  for (const std::string& reason : record.Reasons())
    item["reasons"].append(reason);
  if (record.couch)
  {
    const CouchMotion& couch = *record.couch;
    item["couch"]["action"] = CouchActionName(couch.action);
    for (int k = 0; k < 3; ++k)
      item["couch"]["translation_mm"].append(couch.motion.translation[k]);
    item["couch"]["rotation_deg"]["pitch"] = couch.motion.pitch;
    item["couch"]["rotation_deg"]["roll"] = couch.motion.roll;
    item["couch"]["rotation_deg"]["yaw"] = couch.motion.yaw;
    item["couch"]["uncorrected_rotation_deg"]["pitch"] = couch.uncorrected.pitch;
    item["couch"]["uncorrected_rotation_deg"]["roll"] = couch.uncorrected.roll;
    item["couch"]["uncorrected_rotation_deg"]["yaw"] = couch.uncorrected.yaw;
    item["couch"]["limited_by"] = Json::Value(Json::arrayValue);
    for (const std::string& limit : couch.limitedBy)
      item["couch"]["limited_by"].append(limit);
  }
  item["time_s"] = record.totalSeconds;
  for (size_t v = 0; v < record.edgeDistanceMM.size() && v < record.viewNames.size(); ++v)
  {
    item["edge_distance_mm"][record.viewNames[v]] = record.edgeDistanceMM[v];
    item["edge_distance_moved_3mm"][record.viewNames[v]] = record.edgeDistanceShiftedMM[v];
  }
  return item;
}

} // namespace

int RunTrack(const TrackOptions& options)
{
  if (options.frames.empty())
    throw InputError("--frames", "give at least one frame");
  std::vector<std::vector<std::string>> frames;
  for (size_t f = 0; f < options.frames.size(); ++f)
  {
    frames.push_back(FrameFiles(options.frames[f], f));
    if (frames.back().size() != frames.front().size() || frames.back().size() < 2)
      throw InputError("--frames", "frame " + std::to_string(f + 1) + " has " + std::to_string(frames.back().size()) +
          " X-rays: give one per imager, comma-separated, the same number in every frame");
  }
  StagedOutputDirectory::CheckWritable(options.outputDirectory);
  UseDevice(options.registration.device); // checked before the first frame
  StagedOutputDirectory output(options.outputDirectory);

  std::ostringstream csv;
  csv << PosesCSVHeader(frames.front().size());
  Json::Value poses(Json::arrayValue);
  std::string start = options.registration.initialPose;
  bool allOk = true, previousOk = true;
  std::unique_ptr<RegistrationSession> session;
  // A volume the global search can search (a bone in TIFF, or --global-search): a frame after a
  // failed one is searched from nothing. Between the wrist set's frames 2 and 158 the hand turns
  // by tens of degrees; a failed frame's end is no start for the next.
  const bool searchable = options.registration.globalSearch || IsTIFFVolumePath(options.registration.ct);
  for (size_t f = 0; f < frames.size(); ++f)
  {
    std::printf("frame %zu of %zu\n", f + 1, frames.size());
    RegisterOptions frame = options.registration;
    frame.xrays = frames[f];
    frame.initialPose = start;
    const bool searchAgain = f > 0 && !previousOk && searchable;
    if (searchAgain)
      frame.initialPose.clear(); // a given start would win over the search
    frame.globalSearch = (f == 0 && options.registration.globalSearch) || searchAgain;
    const bool searched = frame.initialPose.empty() && (frame.globalSearch || IsTIFFVolumePath(frame.ct));
    const char* startedFrom = searched ? "global search" : frame.initialPose.empty() ? "planned set-up"
      : f == 0                                                                   ? "given"
                                                                                 : "previous frame";
    frame.outputDirectory = output.Path(FrameName(f));
    if (!options.reportDirectory.empty())
      frame.reportDirectory = options.reportDirectory + "/" + FrameName(f);
    // The frame's folder written, its record returned; the CT read once, for the first frame.
    const RegistrationRecord record = RegisterFiles(frame, session);
    allOk = allOk && record.ok;
    previousOk = record.ok;
    // The next frame starts where this one ended: a motion between frames is small, and a failed
    // frame's end is still the best guess of where the bone is.
    const std::array<double, 6> p = record.misalignment.Parameters();
    std::ostringstream pose;
    pose << std::setprecision(10) << p[0] << "," << p[1] << "," << p[2] << "," << p[3] << "," << p[4] << "," << p[5];
    start = pose.str();

    csv << PosesCSVRow(f + 1, frames[f], record);
    poses.append(PoseItem(f + 1, frames[f], startedFrom, record));
  }
  std::ofstream(output.Path("poses.csv")) << csv.str();
  Json::StreamWriterBuilder writer;
  writer["indentation"] = "  ";
  writer["precision"] = 10; // as result.json's: micrometres on a metre, no binary noise
  std::ofstream(output.Path("poses.json")) << Json::writeString(writer, poses) << "\n";
  output.Commit();
  std::printf("wrote poses.csv and poses.json (%zu frames, %s) to %s\n", frames.size(), allOk ? "all ok" : "NOT all ok",
    options.outputDirectory.c_str());
  return allOk ? ExitOk : ExitRegistrationFailed;
}

} // namespace xp
