/**
 * @file xpPlot.h
 * @brief Small scientific plots (points and lines, linear or log axis) drawn without OpenGL.
 */
#ifndef xpPlot_h
#define xpPlot_h

#include "vtkXPReportingModule.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <array>
#include <string>
#include <vector>

namespace xp
{

struct PlotSeries
{
  std::string name;
  std::vector<double> x, y;
  std::array<unsigned char, 3> rgb{ 0, 0, 0 };
  bool lines = false;  ///< join the points in order
  bool points = true;  ///< mark every point
};

/** A labelled line: vertical at an x (a stage start) or horizontal at a y (a threshold). */
struct PlotMarker
{
  double position = 0.0;
  std::string label;
  bool vertical = true;
};

class VTKXPREPORTING_EXPORT Plot
{
public:
  Plot(std::string title, std::string xLabel, std::string yLabel);

  void AddSeries(PlotSeries series) { this->Series.push_back(std::move(series)); }
  void AddMarker(PlotMarker marker) { this->Markers.push_back(std::move(marker)); }
  /** Logarithmic y axis; values <= 0 are drawn at the bottom edge. */
  void SetLogY(bool logY) { this->LogY = logY; }
  /** Fixed y range (otherwise the data's, with a margin). */
  void SetYRange(double minimum, double maximum);

  /** The plot as an RGB image (unsigned char, 3 components, row 0 at the top as displayed). */
  vtkSmartPointer<vtkImageData> Render(int width, int height) const;

private:
  std::string Title, XLabel, YLabel;
  std::vector<PlotSeries> Series;
  std::vector<PlotMarker> Markers;
  bool LogY = false;
  bool FixedY = false;
  double YMin = 0.0, YMax = 1.0;
};

} // namespace xp

#endif
