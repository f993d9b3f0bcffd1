#include "xpCanvas.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>

namespace xp
{
namespace canvas
{

vtkSmartPointer<vtkImageData> ToVTK(const cv::Mat& bgr)
{
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(rgb.cols, rgb.rows, 1);
  image->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* out = static_cast<uint8_t*>(image->GetScalarPointer());
  for (int row = 0; row < rgb.rows; ++row) // VTK rows run up
    std::copy(rgb.ptr<uint8_t>(row), rgb.ptr<uint8_t>(row) + 3 * rgb.cols, out + static_cast<size_t>(rgb.rows - 1 - row) * 3 * rgb.cols);
  return image;
}

cv::Mat FromVTK(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  const int components = image->GetNumberOfScalarComponents();
  const auto* in = static_cast<const uint8_t*>(image->GetScalarPointer());
  cv::Mat bgr(dims[1], dims[0], CV_8UC3);
  for (int row = 0; row < dims[1]; ++row)
  {
    const uint8_t* line = in + static_cast<size_t>(dims[1] - 1 - row) * dims[0] * components;
    for (int column = 0; column < dims[0]; ++column)
    {
      const uint8_t* p = line + static_cast<size_t>(column) * components;
      bgr.at<cv::Vec3b>(row, column) = components >= 3 ? cv::Vec3b(p[2], p[1], p[0]) : cv::Vec3b(p[0], p[0], p[0]);
    }
  }
  return bgr;
}

cv::Mat Grey8(const std::vector<uint16_t>& image, int columns, int rows, const std::vector<uint8_t>& valid)
{
  std::vector<uint16_t> values;
  values.reserve(image.size());
  for (size_t i = 0; i < image.size(); ++i)
    if (valid.empty() || valid[i])
      values.push_back(image[i]);
  double low = 0.0, high = 4095.0;
  if (!values.empty())
  {
    auto at = [&](double q) {
      auto nth = values.begin() + static_cast<std::ptrdiff_t>(q * (values.size() - 1));
      std::nth_element(values.begin(), nth, values.end());
      return static_cast<double>(*nth);
    };
    low = at(0.01);
    high = at(0.99);
    if (high - low < 1.0) // an object on less than 1 % of a flat image (a bone's DRR): its whole range
    {
      const auto [least, most] = std::minmax_element(values.begin(), values.end());
      low = *least;
      high = *most;
    }
    high = std::max(high, low + 1.0);
  }
  cv::Mat grey(rows, columns, CV_8UC1);
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
    {
      const double v = (image[static_cast<size_t>(row) * columns + column] - low) / (high - low);
      grey.at<uint8_t>(row, column) = cv::saturate_cast<uint8_t>(255.0 * v);
    }
  return grey;
}

void Text(cv::Mat& canvas, const std::string& text, cv::Point origin, double scale, cv::Scalar bgr, int thickness)
{
  cv::putText(canvas, text, origin, cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, bgr, thickness, cv::LINE_AA);
}

int TextWidth(const std::string& text, double scale, int thickness)
{
  int baseline = 0;
  return cv::getTextSize(text, cv::FONT_HERSHEY_SIMPLEX, 0.6 * scale, thickness, &baseline).width;
}

cv::Mat Captioned(const cv::Mat& image, const std::string& caption, int width)
{
  cv::Mat colour;
  if (image.channels() == 1)
    cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  else
    colour = image;
  const int height = std::max(1, colour.rows * width / std::max(1, colour.cols));
  cv::Mat scaled;
  cv::resize(colour, scaled, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  constexpr int bar = 26;
  cv::Mat panel(height + bar, width, CV_8UC3, cv::Scalar(255, 255, 255));
  scaled.copyTo(panel(cv::Rect(0, bar, width, height)));
  Text(panel, caption, cv::Point(4, bar - 8), 0.85, cv::Scalar(20, 20, 20));
  return panel;
}

cv::Mat Grid(const std::vector<cv::Mat>& tiles, int columns, int gap)
{
  if (tiles.empty())
    return cv::Mat(1, 1, CV_8UC3, cv::Scalar(255, 255, 255));
  const int rows = (static_cast<int>(tiles.size()) + columns - 1) / columns;
  int tileWidth = 0, tileHeight = 0;
  for (const cv::Mat& tile : tiles)
    tileWidth = std::max(tileWidth, tile.cols), tileHeight = std::max(tileHeight, tile.rows);
  cv::Mat grid(rows * (tileHeight + gap) + gap, columns * (tileWidth + gap) + gap, CV_8UC3, cv::Scalar(255, 255, 255));
  for (size_t n = 0; n < tiles.size(); ++n)
  {
    const int x = gap + static_cast<int>(n % columns) * (tileWidth + gap), y = gap + static_cast<int>(n / columns) * (tileHeight + gap);
    tiles[n].copyTo(grid(cv::Rect(x, y, tiles[n].cols, tiles[n].rows)));
  }
  return grid;
}

} // namespace canvas
} // namespace xp
