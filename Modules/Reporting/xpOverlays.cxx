#include "xpOverlays.h"

#include "xpCanvas.h"
#include "xpError.h"

#include <opencv2/imgproc.hpp>

namespace xp
{

namespace canvas
{

cv::Mat Overlay(OverlayMode mode, const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr, int columns, int rows,
  const std::vector<uint8_t>& mask)
{
  const size_t pixels = static_cast<size_t>(columns) * rows;
  if (xray.size() != pixels || (mode != OverlayMode::MaskedXRay && drr.size() != pixels) || (!mask.empty() && mask.size() != pixels))
  {
    throw Error("overlay", "the X-ray, the DRR and the mask must have the same size");
  }
  const cv::Mat fixed = Grey8(xray, columns, rows, mask);
  cv::Mat out;
  switch (mode)
  {
    case OverlayMode::Checkerboard:
    {
      const cv::Mat moving = Grey8(drr, columns, rows, mask);
      const int square = std::max(8, std::max(columns, rows) / 8);
      cv::Mat grey = fixed.clone();
      for (int row = 0; row < rows; ++row)
        for (int column = 0; column < columns; ++column)
          if (((row / square) + (column / square)) % 2)
            grey.at<uint8_t>(row, column) = moving.at<uint8_t>(row, column);
      cv::cvtColor(grey, out, cv::COLOR_GRAY2BGR);
      break;
    }
    case OverlayMode::ColourBlend:
    {
      const cv::Mat moving = Grey8(drr, columns, rows, mask);
      cv::merge(std::vector<cv::Mat>{ fixed, moving, fixed }, out); // B, G, R: X-ray magenta, DRR green
      break;
    }
    case OverlayMode::Edges:
    {
      cv::Mat moving = Grey8(drr, columns, rows, mask), edges;
      cv::GaussianBlur(moving, moving, cv::Size(5, 5), 1.2);
      cv::Canny(moving, edges, 40, 100);
      cv::cvtColor(fixed, out, cv::COLOR_GRAY2BGR);
      out.setTo(cv::Scalar(0, 230, 255), edges);
      break;
    }
    case OverlayMode::MaskedXRay:
    {
      cv::cvtColor(fixed, out, cv::COLOR_GRAY2BGR);
      for (int row = 0; row < rows; ++row)
        for (int column = 0; column < columns; ++column)
          if (!mask.empty() && !mask[static_cast<size_t>(row) * columns + column])
          {
            cv::Vec3b& p = out.at<cv::Vec3b>(row, column);
            p = cv::Vec3b(static_cast<uint8_t>(60 + p[0] / 4), static_cast<uint8_t>(p[1] / 4), static_cast<uint8_t>(p[2] / 4));
          }
      break;
    }
  }
  return out;
}

cv::Mat ColourMap(const std::vector<float>& map, int columns, int rows)
{
  cv::Mat grey(rows, columns, CV_8UC1), out;
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      grey.at<uint8_t>(row, column) = cv::saturate_cast<uint8_t>(255.0f * map[static_cast<size_t>(row) * columns + column]);
  cv::applyColorMap(grey, out, cv::COLORMAP_VIRIDIS);
  return out;
}

} // namespace canvas

vtkSmartPointer<vtkImageData> MakeOverlay(OverlayMode mode, const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr,
  int columns, int rows, const std::vector<uint8_t>& mask)
{
  return canvas::ToVTK(canvas::Overlay(mode, xray, drr, columns, rows, mask));
}

vtkSmartPointer<vtkImageData> MakeGreyImage(const std::vector<uint16_t>& image, int columns, int rows)
{
  cv::Mat bgr;
  cv::cvtColor(canvas::Grey8(image, columns, rows), bgr, cv::COLOR_GRAY2BGR);
  return canvas::ToVTK(bgr);
}

vtkSmartPointer<vtkImageData> MakeColourMap(const std::vector<float>& map, int columns, int rows)
{
  if (map.size() != static_cast<size_t>(columns) * rows)
  {
    throw Error("colour map", "the map does not have columns x rows values");
  }
  return canvas::ToVTK(canvas::ColourMap(map, columns, rows));
}

} // namespace xp
