#include "xpReport.h"

#include "xpCanvas.h"
#include "xpImageIO.h"
#include "xpPlot.h"

#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace xp
{

namespace
{

std::string Html(const std::string& text)
{
  std::string out;
  for (char c : text)
  {
    switch (c)
    {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string Fixed(double value, int decimals)
{
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

cv::Mat Binary(const std::vector<uint8_t>& mask, int columns, int rows)
{
  cv::Mat grey(rows, columns, CV_8UC1, cv::Scalar(255));
  for (size_t i = 0; i < mask.size(); ++i)
    grey.data[i] = mask[i] ? 255 : 0;
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

cv::Mat GreyBGR(const std::vector<uint16_t>& image, int columns, int rows)
{
  cv::Mat bgr;
  cv::cvtColor(canvas::Grey8(image, columns, rows), bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

/** A picture of the report: file name, caption, image. */
struct Picture
{
  std::string file, caption;
  cv::Mat image;
};

std::vector<Picture> ViewPictures(const ReportView& v)
{
  const int c = v.columns, r = v.rows;
  std::vector<Picture> pictures{
    { "xray", "X-ray " + v.name, GreyBGR(v.xray, c, r) },
    { "drr_start", "DRR at the start pose", GreyBGR(v.drrStart, c, r) },
    { "drr_final", "DRR at the result", GreyBGR(v.drrFinal, c, r) },
    { "checkerboard", "checkerboard X-ray / final DRR", canvas::Overlay(OverlayMode::Checkerboard, v.xray, v.drrFinal, c, r, {}) },
    { "blend", "blend: X-ray magenta, DRR green", canvas::Overlay(OverlayMode::ColourBlend, v.xray, v.drrFinal, c, r, {}) },
    { "edges", "final DRR edges on the X-ray", canvas::Overlay(OverlayMode::Edges, v.xray, v.drrFinal, c, r, {}) },
  };
  if (!v.entropy.empty())
    pictures.push_back({ "entropy", "block entropy (0 dark, 1 yellow)", canvas::ColourMap(v.entropy, c, r) });
  pictures.push_back({ "mask", "mask used (white)", Binary(v.mask, c, r) });
  cv::Mat roi = Binary(v.roi.empty() ? std::vector<uint8_t>(static_cast<size_t>(c) * r, 1) : v.roi, c, r);
  if (v.roi.empty())
    canvas::Text(roi, "no ROI: whole image", cv::Point(8, r / 2), std::max(0.6, c / 300.0), cv::Scalar(90, 90, 90));
  pictures.push_back({ "roi", v.roi.empty() ? "user ROI: whole image" : "user ROI (white)", roi });
  pictures.push_back({ "masked_xray", "masked X-ray (excluded: blue)", canvas::Overlay(OverlayMode::MaskedXRay, v.xray, {}, c, r, v.mask) });
  return pictures;
}

std::string PoseRow(const std::string& name, const Pose& p)
{
  return "<tr><th>" + name + "</th><td>" + Fixed(p.translation[0], 2) + "</td><td>" + Fixed(p.translation[1], 2) + "</td><td>" +
    Fixed(p.translation[2], 2) + "</td><td>" + Fixed(p.pitch, 2) + "</td><td>" + Fixed(p.roll, 2) + "</td><td>" + Fixed(p.yaw, 2) +
    "</td></tr>\n";
}

std::string PoseLine(const Pose& p)
{
  return "lat " + Fixed(p.translation[0], 2) + "  long " + Fixed(p.translation[1], 2) + "  vert " + Fixed(p.translation[2], 2) +
    " mm   pitch " + Fixed(p.pitch, 2) + "  roll " + Fixed(p.roll, 2) + "  yaw " + Fixed(p.yaw, 2) + " deg";
}

void Save(const cv::Mat& image, StagedOutputDirectory& output, const std::string& file)
{
  WritePNG(canvas::ToVTK(image), output.Path(file));
}

/** The report's correction table (misalignment, 6-DOF correction, couch motion) and couch panel. */
std::string CorrectionSection(const ReportContent& content)
{
  std::ostringstream html;
  html << "<h2>Correction</h2>\n<table><tr><th></th><th>lateral X (mm)</th><th>longitudinal Y (mm)</th><th>vertical Z (mm)</th>"
       << "<th>pitch (deg)</th><th>roll (deg)</th><th>yaw (deg)</th></tr>\n"
       << PoseRow("misalignment of the patient", content.misalignment) << PoseRow("6-DOF correction", content.correction);
  if (content.couch)
    html << PoseRow("couch motion (about its rotation centre)", content.couch->motion)
         << PoseRow("left uncorrected (about the isocentre)", content.couch->uncorrected);
  html << "</table>\n<p>Convention: " << Html(content.convention) << ". The 6-DOF correction is the inverse of the "
       << "misalignment.</p>\n";
  if (content.couch)
  {
    const CouchMotion& couch = *content.couch;
    std::string limits;
    for (const std::string& limit : couch.limitedBy)
      limits += (limits.empty() ? "" : ", ") + limit;
    html << "<h2>Couch</h2>\n<table><tr><th>couch</th><td>" << Html(couch.couch.Describe()) << "</td></tr>"
         << "<tr><th>action</th><td><b>" << Html(CouchActionName(couch.action)) << "</b>: " << Html(couch.actionReason)
         << "</td></tr><tr><th>target (room mm)</th><td>" << Fixed(couch.target[0], 1) << ", " << Fixed(couch.target[1], 1) << ", "
         << Fixed(couch.target[2], 1) << " (put back exactly)</td></tr><tr><th>uncorrected rotation</th><td>"
         << Fixed(couch.uncorrected.RotationAngle(), 2) << " deg: " << Fixed(couch.uncorrectedAt50MM, 2) << " mm at 50 mm and "
         << Fixed(couch.uncorrectedAt100MM, 2) << " mm at 100 mm from the target</td></tr><tr><th>limited by</th><td>"
         << (limits.empty() ? "none" : Html(limits)) << "</td></tr></table>\n";
  }
  return html.str();
}

/** summary.png's header: the status, the corrections, the couch motion and the run's figures. */
cv::Mat SummaryHeader(const ReportContent& content, int width)
{
  const std::string status = content.ok ? "OK" : "FAILED";
  const int couchLine = content.couch ? 26 : 0;
  cv::Mat header(150 + couchLine, width, CV_8UC3, cv::Scalar(255, 255, 255));
  cv::rectangle(header, cv::Rect(0, 0, width, 44), content.ok ? cv::Scalar(42, 125, 42) : cv::Scalar(34, 34, 178), cv::FILLED);
  canvas::Text(header, "xpose registration: " + status + (content.ok ? "" : "  (do not apply)"), cv::Point(12, 32), 1.5,
    cv::Scalar(255, 255, 255), 2);
  canvas::Text(header, "6-DOF correction:  " + PoseLine(content.correction), cv::Point(12, 72), 1.1, cv::Scalar(20, 20, 20), 2);
  if (content.couch)
    canvas::Text(header, "couch " + CouchMotionsName(content.couch->couch.motions) + " (" + CouchActionName(content.couch->action) +
        "): " + PoseLine(content.couch->motion) + ", " + Fixed(content.couch->uncorrected.RotationAngle(), 2) + " deg left",
      cv::Point(12, 98), 0.95, cv::Scalar(20, 20, 20), 2);
  canvas::Text(header, "misalignment:      " + PoseLine(content.misalignment), cv::Point(12, 98 + couchLine), 0.95,
    cv::Scalar(60, 60, 60));
  std::string facts;
  for (const ReportView& v : content.views)
    facts += v.name + ": MI " + Fixed(v.similarity, 3) + ", valid " + Fixed(100 * v.validFraction, 0) + " %" +
      (v.edgeDistanceMM >= 0.0 ? ", edges " + Fixed(v.edgeDistanceMM, 2) + " mm (moved " + Fixed(v.edgeDistanceMovedMM, 2) + ")" : "") + "   ";
  double total = 0.0;
  for (const auto& stage : content.seconds)
    total = stage.first == "total" ? stage.second : total;
  facts += "DRRs " + std::to_string(content.drrCount) + ", evaluations " + std::to_string(content.evaluations) + ", " +
    Fixed(total, 1) + " s";
  canvas::Text(header, facts, cv::Point(12, 124 + couchLine), 0.85, cv::Scalar(60, 60, 60));
  if (!content.ok && !content.reasons.empty())
    canvas::Text(header, "reason: " + content.reasons.front(), cv::Point(12, 146 + couchLine), 0.8, cv::Scalar(34, 34, 178));
  return header;
}

} // namespace

void WriteReport(const ReportContent& content, const std::string& directory)
{
  StagedOutputDirectory output(directory);

  // Convergence: the objective at every 6-DOF evaluation, stages marked.
  Plot plot("Convergence of the 6-DOF search", "evaluation", "objective MI_A^2 + MI_B^2");
  PlotSeries trace{ "", {}, content.trace, { 30, 90, 200 }, true, false };
  for (size_t n = 0; n < content.trace.size(); ++n)
    trace.x.push_back(static_cast<double>(n));
  plot.AddSeries(trace);
  for (const auto& [name, first] : content.stages)
    plot.AddMarker({ static_cast<double>(first), name, true });
  const cv::Mat convergence = canvas::FromVTK(plot.Render(900, 420));
  Save(convergence, output, "convergence.png");

  cv::Mat room;
  if (content.room)
  {
    room = canvas::FromVTK(content.room);
    Save(room, output, "scene3d.png");
  }

  std::ostringstream html;
  const std::string status = content.ok ? "OK" : "FAILED";
  html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>xpose registration report</title>\n"
       << "<style>body{font-family:sans-serif;margin:1.5em;color:#222}table{border-collapse:collapse;margin:.5em 0}"
       << "td,th{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#f2f2f2}"
       << ".ok{color:#fff;background:#2a7d2a;padding:.2em .6em}.failed{color:#fff;background:#b22222;padding:.2em .6em}"
       << "figure{display:inline-block;margin:.3em;vertical-align:top}figcaption{font-size:.85em}img{max-width:320px}"
       << ".wide img{max-width:900px}</style></head><body>\n";
  html << "<h1>xpose registration report</h1>\n<p>" << Html(content.title) << "</p>\n";
  html << "<p>Status: <span class=\"" << (content.ok ? "ok" : "failed") << "\">" << status << "</span></p>\n";
  if (!content.ok)
  {
    html << "<p><b>Do not apply this correction.</b> Reasons:</p><ul>\n";
    for (const std::string& reason : content.reasons)
      html << "<li>" << Html(reason) << "</li>\n";
    html << "</ul>\n";
  }
  html << CorrectionSection(content);
  html << "<h2>Similarity and effort</h2>\n<table><tr><th>view</th><th>MI (nats)</th><th>explained MI / H(X-ray)</th>"
       << "<th>mask valid fraction</th><th>DRR edges to the X-ray's (mm at the isocentre)</th>"
       << "<th>the same, DRR moved 3 mm</th></tr>\n";
  const auto edgeCell = [](double mm) { return mm < 0.0 ? std::string("-") : Fixed(mm, 2); };
  for (const ReportView& v : content.views)
    html << "<tr><th>" << Html(v.name) << "</th><td>" << Fixed(v.similarity, 4) << "</td><td>" << Fixed(v.explained, 3) << "</td><td>"
         << Fixed(v.validFraction, 3) << "</td><td>" << edgeCell(v.edgeDistanceMM) << "</td><td>"
         << edgeCell(v.edgeDistanceMovedMM) << "</td></tr>\n";
  html << "</table>\n<table><tr><th>objective</th><td>" << Fixed(content.objective, 4) << "</td></tr><tr><th>DRRs rendered</th><td>"
       << content.drrCount << "</td></tr><tr><th>6-DOF evaluations</th><td>" << content.evaluations << "</td></tr>\n";
  for (const auto& [stage, seconds] : content.seconds)
    html << "<tr><th>time: " << Html(stage) << " (s)</th><td>" << Fixed(seconds, 2) << "</td></tr>\n";
  html << "</table>\n";

  // Per view: every picture as a file, and a row of the summary.
  std::vector<cv::Mat> summaryRows;
  for (const ReportView& v : content.views)
  {
    html << "<h2>View " << Html(v.name) << "</h2>\n<p>Rows top to bottom as on the panel (row 0 at the top); bone is dark in "
         << "transmission.</p>\n";
    std::vector<cv::Mat> tiles;
    for (const Picture& picture : ViewPictures(v))
    {
      const std::string file = "view_" + v.name + "_" + picture.file + ".png";
      Save(picture.image, output, file);
      html << "<figure><img src=\"" << Html(file) << "\" alt=\"" << Html(picture.caption) << "\"><figcaption>" << Html(picture.caption)
           << "</figcaption></figure>\n";
      if (picture.file == "xray" || picture.file == "drr_final" || picture.file == "checkerboard" || picture.file == "edges" ||
        picture.file == "masked_xray")
        tiles.push_back(canvas::Captioned(picture.image, v.name + ": " + picture.caption, 300));
    }
    summaryRows.push_back(canvas::Grid(tiles, static_cast<int>(tiles.size()), 6));
  }
  html << "<h2>Convergence</h2>\n<figure class=\"wide\"><img src=\"convergence.png\" alt=\"convergence\"></figure>\n";
  html << "<h2>Room</h2>\n";
  if (!room.empty())
    html << "<figure class=\"wide\"><img src=\"scene3d.png\" alt=\"3D room scene\"><figcaption>Sources, panels, central rays, "
         << "the isocentre and the CT bone at the planned pose (translucent) and at the estimated pose.</figcaption></figure>\n";
  else
    html << "<p>" << Html(content.roomNote) << "</p>\n";
  html << "<p><small>Written by xpose.</small></p>\n</body></html>\n";
  std::ofstream(output.Path("index.html")) << html.str();

  // summary.png: the essentials on one image.
  const int width = 1560;
  const cv::Mat header = SummaryHeader(content, width);
  std::vector<cv::Mat> parts{ header };
  for (const cv::Mat& row : summaryRows)
    parts.push_back(row);
  cv::Mat bottomLeft, bottomRight;
  cv::resize(convergence, bottomLeft, cv::Size(width / 2 - 10, convergence.rows * (width / 2 - 10) / convergence.cols));
  if (!room.empty())
    cv::resize(room, bottomRight, cv::Size(width / 2 - 10, room.rows * (width / 2 - 10) / room.cols));
  std::vector<cv::Mat> bottom{ bottomLeft };
  if (!bottomRight.empty())
    bottom.push_back(bottomRight);
  parts.push_back(canvas::Grid(bottom, 2, 6));
  int height = 0;
  for (const cv::Mat& part : parts)
    height += part.rows;
  cv::Mat summary(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  int y = 0;
  for (const cv::Mat& part : parts)
  {
    const int w = std::min(width, part.cols);
    part(cv::Rect(0, 0, w, part.rows)).copyTo(summary(cv::Rect(0, y, w, part.rows)));
    y += part.rows;
  }
  Save(summary, output, "summary.png");
  output.Commit();
}

} // namespace xp
