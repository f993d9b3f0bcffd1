// OpenCV canvases for the 2D parts of a report (private to XP::Reporting: OpenCV stays out of the
// public headers). Images are row 0 at the top, as displayed.
#ifndef xpCanvas_h
#define xpCanvas_h

#include "xpOverlays.h"

#include <opencv2/core.hpp>

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <cstdint>
#include <string>
#include <vector>

namespace xp
{
namespace canvas
{

/** An RGB vtkImageData (as displayed) from a BGR canvas, and back. */
vtkSmartPointer<vtkImageData> ToVTK(const cv::Mat& bgr);
cv::Mat FromVTK(vtkImageData* image);

/** 12-bit grey (row 0 first) -> 8-bit, windowed on the 1st..99th percentile of the valid pixels. */
cv::Mat Grey8(const std::vector<uint16_t>& image, int columns, int rows, const std::vector<uint8_t>& valid = {});

/** The overlays of xpOverlays.h, and a 0..1 map in viridis, as BGR canvases. */
cv::Mat Overlay(OverlayMode mode, const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr, int columns, int rows,
  const std::vector<uint8_t>& mask);
cv::Mat ColourMap(const std::vector<float>& map, int columns, int rows);

/** Text in the plain Hershey font, anti-aliased; `scale` 1 is about 20 pixels high. */
void Text(cv::Mat& canvas, const std::string& text, cv::Point origin, double scale, cv::Scalar bgr, int thickness = 1);
int TextWidth(const std::string& text, double scale, int thickness = 1);

/** A panel with a caption bar above the image. */
cv::Mat Captioned(const cv::Mat& image, const std::string& caption, int width);

/** Tiles, left to right then top to bottom, `columns` per row, on white. */
cv::Mat Grid(const std::vector<cv::Mat>& tiles, int columns, int gap = 8);

} // namespace canvas
} // namespace xp

#endif
