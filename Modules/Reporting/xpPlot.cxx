#include "xpPlot.h"

#include "xpCanvas.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace xp
{

namespace
{

/** Tick positions at 1, 2 or 5 times a power of ten, about `count` across [low, high]. */
std::vector<double> NiceTicks(double low, double high, int count)
{
  const double raw = (high - low) / std::max(1, count);
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double factor : { 1.0, 2.0, 5.0, 10.0 })
    if (factor * power >= raw)
    {
      step = factor * power;
      break;
    }
  std::vector<double> ticks;
  for (double t = std::ceil(low / step) * step; t <= high + 1e-9 * step; t += step)
    ticks.push_back(std::abs(t) < 1e-12 * step ? 0.0 : t);
  return ticks;
}

std::string TickLabel(double value)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

} // namespace

Plot::Plot(std::string title, std::string xLabel, std::string yLabel)
  : Title(std::move(title))
  , XLabel(std::move(xLabel))
  , YLabel(std::move(yLabel))
{
}

void Plot::SetYRange(double minimum, double maximum)
{
  this->FixedY = maximum > minimum;
  this->YMin = minimum;
  this->YMax = maximum;
}

namespace
{

/** The y label, turned a quarter to read upwards along the axis left of `area`. */
void DrawYLabel(cv::Mat& canvas, const std::string& text, const cv::Rect& area, const cv::Scalar& ink)
{
  const int w = canvas::TextWidth(text, 0.9) + 8;
  cv::Mat label(24, w, CV_8UC3, cv::Scalar(255, 255, 255));
  canvas::Text(label, text, cv::Point(4, 17), 0.9, ink);
  cv::Mat turned;
  cv::rotate(label, turned, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int y = std::max(0, area.y + area.height / 2 - turned.rows / 2);
  const cv::Rect target(2, y, turned.cols, std::min(turned.rows, canvas.rows - y));
  turned(cv::Rect(0, 0, target.width, target.height)).copyTo(canvas(target));
}

/** The legend in the top margin, right-aligned at `right`, so that it never hides data. */
void DrawLegend(cv::Mat& canvas, const std::vector<PlotSeries>& series, int right, int top, const cv::Scalar& ink)
{
  int x = right;
  for (auto s = series.rbegin(); s != series.rend(); ++s)
  {
    if (s->name.empty())
      continue;
    x -= canvas::TextWidth(s->name, 0.8) + 34;
    const cv::Scalar colour(s->rgb[2], s->rgb[1], s->rgb[0]);
    cv::circle(canvas, cv::Point(x + 6, top - 14), 5, colour, cv::FILLED, cv::LINE_AA);
    canvas::Text(canvas, s->name, cv::Point(x + 16, top - 9), 0.8, ink);
  }
}

} // namespace

vtkSmartPointer<vtkImageData> Plot::Render(int width, int height) const
{
  cv::Mat canvas(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 78, right = 18, top = 40, bottom = 58;
  const cv::Rect area(left, top, std::max(10, width - left - right), std::max(10, height - top - bottom));

  // Data ranges (y in log10 when the axis is logarithmic).
  double xMin = std::numeric_limits<double>::max(), xMax = -xMin, yMin = xMin, yMax = -xMin;
  const auto yValue = [&](double y) { return this->LogY ? std::log10(std::max(y, 1e-12)) : y; };
  for (const PlotSeries& s : this->Series)
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
    {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]))
        continue;
      xMin = std::min(xMin, s.x[i]), xMax = std::max(xMax, s.x[i]);
      if (this->LogY && s.y[i] <= 0.0)
        continue;
      yMin = std::min(yMin, yValue(s.y[i])), yMax = std::max(yMax, yValue(s.y[i]));
    }
  for (const PlotMarker& m : this->Markers)
  {
    if (m.vertical)
      xMin = std::min(xMin, m.position), xMax = std::max(xMax, m.position);
    else if (!this->LogY || m.position > 0.0)
      yMin = std::min(yMin, yValue(m.position)), yMax = std::max(yMax, yValue(m.position));
  }
  if (xMin > xMax)
    xMin = 0.0, xMax = 1.0;
  if (yMin > yMax)
    yMin = 0.0, yMax = 1.0;
  if (this->FixedY)
    yMin = yValue(this->YMin), yMax = yValue(this->YMax);
  if (xMax - xMin < 1e-12)
    xMin -= 0.5, xMax += 0.5;
  if (yMax - yMin < 1e-12)
    yMin -= 0.5, yMax += 0.5;
  if (this->LogY && !this->FixedY)
    yMin = std::floor(yMin) - 0.05, yMax = std::ceil(yMax) + 0.15; // whole decades, room for labels
  else if (!this->FixedY)
  {
    const double margin = 0.05 * (yMax - yMin);
    yMin -= margin, yMax += margin;
  }
  const double xMargin = 0.03 * (xMax - xMin);
  xMin -= xMargin, xMax += xMargin;
  const auto toPixel = [&](double x, double yPlotted) {
    return cv::Point(area.x + static_cast<int>(std::lround((x - xMin) / (xMax - xMin) * (area.width - 1))),
      area.y + area.height - 1 - static_cast<int>(std::lround((yPlotted - yMin) / (yMax - yMin) * (area.height - 1))));
  };

  // Grid, ticks and labels.
  const cv::Scalar ink(30, 30, 30), grid(225, 225, 225);
  for (double x : NiceTicks(xMin, xMax, 8))
  {
    const cv::Point p = toPixel(x, yMin);
    cv::line(canvas, cv::Point(p.x, area.y), cv::Point(p.x, area.y + area.height), grid, 1);
    const std::string label = TickLabel(x);
    canvas::Text(canvas, label, cv::Point(p.x - canvas::TextWidth(label, 0.8) / 2, area.y + area.height + 20), 0.8, ink);
  }
  std::vector<double> yTicks;
  if (this->LogY)
    for (double e = std::ceil(yMin); e <= yMax + 1e-9; e += 1.0)
      yTicks.push_back(e);
  else
    yTicks = NiceTicks(yMin, yMax, 6);
  for (double y : yTicks)
  {
    const cv::Point p = toPixel(xMin, y);
    cv::line(canvas, cv::Point(area.x, p.y), cv::Point(area.x + area.width, p.y), grid, 1);
    const std::string label = TickLabel(this->LogY ? std::pow(10.0, y) : y);
    canvas::Text(canvas, label, cv::Point(area.x - 8 - canvas::TextWidth(label, 0.8), p.y + 5), 0.8, ink);
  }
  cv::rectangle(canvas, area, ink, 1);
  canvas::Text(canvas, this->Title, cv::Point(left, 26), 1.05, ink, 2);
  canvas::Text(canvas, this->XLabel, cv::Point(area.x + area.width / 2 - canvas::TextWidth(this->XLabel, 0.9) / 2, height - 12),
    0.9, ink);
  DrawYLabel(canvas, this->YLabel, area, ink);

  // Markers, then the data clipped to the axes.
  for (const PlotMarker& m : this->Markers)
  {
    const cv::Scalar colour(90, 90, 200);
    if (m.vertical)
    {
      const cv::Point p = toPixel(m.position, yMin);
      cv::line(canvas, cv::Point(p.x, area.y), cv::Point(p.x, area.y + area.height), colour, 1, cv::LINE_AA);
      canvas::Text(canvas, m.label, cv::Point(p.x + 4, area.y + 16), 0.75, colour);
    }
    else
    {
      const cv::Point p = toPixel(xMin, yValue(m.position));
      cv::line(canvas, cv::Point(area.x, p.y), cv::Point(area.x + area.width, p.y), colour, 1, cv::LINE_AA);
      canvas::Text(canvas, m.label, cv::Point(area.x + 6, p.y - 5), 0.75, colour);
    }
  }
  cv::Mat inside = canvas(area);
  for (const PlotSeries& s : this->Series)
  {
    const cv::Scalar colour(s.rgb[2], s.rgb[1], s.rgb[0]);
    std::vector<cv::Point> points;
    for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
    {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]))
        continue;
      const double y = this->LogY && s.y[i] <= 0.0 ? yMin : yValue(s.y[i]);
      points.push_back(toPixel(s.x[i], std::clamp(y, yMin, yMax)) - area.tl());
    }
    if (s.lines && points.size() > 1)
      cv::polylines(inside, points, false, colour, 2, cv::LINE_AA);
    if (s.points)
      for (const cv::Point& p : points)
        cv::circle(inside, p, 4, colour, cv::FILLED, cv::LINE_AA);
  }
  DrawLegend(canvas, this->Series, width - right, top, ink);
  return canvas::ToVTK(canvas);
}

} // namespace xp
