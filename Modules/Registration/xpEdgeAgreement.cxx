#include "xpEdgeAgreement.h"

#include "xpError.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdlib>
#include <cmath>

namespace xp
{

namespace
{

/** Smoothing before the gradients (pixels): a few quanta's noise must not make edges. */
constexpr double EdgeSmoothingSigma = 2.0;
/** Canny's upper threshold: this percentile of the region's non-zero gradient magnitudes; the lower, half. */
constexpr double StrongGradientPercentile = 0.75;
/** The region's border is no edge: DRR edges within this many pixels of it are not counted. */
constexpr int BorderPixels = 4;

/** The q-quantile of `values` (reordered). */
double Quantile(std::vector<float>& values, double q)
{
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1)));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

/**
 * Canny edges of `image` within `region` (255 = edge), the upper threshold at a percentile of its
 * own gradient magnitude there (the lower, half of it). With `targetCount` > 0, the percentile
 * among a few whose edges come nearest that count: a noisy X-ray's weakest edges are noise, and
 * an edge map as dense as the DRR's keeps its strongest ones.
 */
cv::Mat EdgesOf(const std::vector<uint16_t>& image, const cv::Mat& region, int columns, int rows, long long targetCount)
{
  // 8 bits over the region's 1st to 99th percentile; outside it, the region's median (no step at
  // its border).
  std::vector<float> inside;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (region.at<uint8_t>(r, c))
        inside.push_back(image[static_cast<size_t>(r) * columns + c]);
  cv::Mat edges = cv::Mat::zeros(rows, columns, CV_8U);
  if (inside.size() < 16)
    return edges;
  const double low = Quantile(inside, 0.01), high = Quantile(inside, 0.99), median = Quantile(inside, 0.5);
  if (!(high > low))
    return edges; // flat: no edges
  cv::Mat grey(rows, columns, CV_32F);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const double v = region.at<uint8_t>(r, c) ? image[static_cast<size_t>(r) * columns + c] : median;
      grey.at<float>(r, c) = static_cast<float>(255.0 * std::clamp((v - low) / (high - low), 0.0, 1.0));
    }
  cv::GaussianBlur(grey, grey, cv::Size(0, 0), EdgeSmoothingSigma);
  cv::Mat grey8;
  grey.convertTo(grey8, CV_8U);
  cv::Mat dx, dy;
  cv::Sobel(grey8, dx, CV_16S, 1, 0);
  cv::Sobel(grey8, dy, CV_16S, 0, 1);
  std::vector<float> magnitudes;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      // Percentiles of the gradients that are not zero: a noise-free DRR is flat almost everywhere.
      const float magnitude = std::hypot(static_cast<float>(dx.at<int16_t>(r, c)), static_cast<float>(dy.at<int16_t>(r, c)));
      if (region.at<uint8_t>(r, c) && magnitude > 0.0f)
        magnitudes.push_back(magnitude);
    }
  if (magnitudes.empty())
    return edges;
  const auto cannyAt = [&](double percentile)
  {
    cv::Mat found = cv::Mat::zeros(rows, columns, CV_8U);
    const double strong = Quantile(magnitudes, percentile);
    if (strong > 0.0)
    {
      cv::Canny(dx, dy, found, 0.5 * strong, strong, true);
      found.setTo(0, region == 0);
    }
    return found;
  };
  if (targetCount <= 0)
    return cannyAt(StrongGradientPercentile);
  long long bestGap = -1;
  for (double percentile : { 0.75, 0.85, 0.9, 0.95, 0.98 })
  {
    cv::Mat found = cannyAt(percentile);
    const long long gap = std::llabs(static_cast<long long>(cv::countNonZero(found)) - targetCount);
    if (bestGap < 0 || gap < bestGap)
    {
      bestGap = gap;
      edges = found;
    }
  }
  return edges;
}

double Median(std::vector<float>& values)
{
  return values.empty() ? -1.0 : Quantile(values, 0.5);
}

} // namespace

EdgeAgreement MeasureEdgeAgreement(const std::vector<uint16_t>& xray, const std::vector<uint16_t>& drr,
  const std::vector<uint8_t>& region, int columns, int rows, int shiftPixels)
{
  const size_t n = static_cast<size_t>(columns) * rows;
  if (columns <= 0 || rows <= 0 || xray.size() != n || drr.size() != n || !(region.empty() || region.size() == n))
    throw InputError("edge agreement", "the X-ray, DRR and region differ in size");
  if (shiftPixels < 1)
    throw InputError("edge agreement", "the chance level's shift must be a pixel or more");
  cv::Mat inside(rows, columns, CV_8U, cv::Scalar(255));
  if (!region.empty())
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < columns; ++c)
        inside.at<uint8_t>(r, c) = region[static_cast<size_t>(r) * columns + c] ? 255 : 0;
  const cv::Mat drrEdges = EdgesOf(drr, inside, columns, rows, 0);
  const cv::Mat xrayEdges = EdgesOf(xray, inside, columns, rows, std::max(1, cv::countNonZero(drrEdges)));
  EdgeAgreement agreement;
  if (cv::countNonZero(xrayEdges) == 0)
    return agreement; // nothing to be near
  // Distance to the nearest X-ray edge: the distance transform's zeros are the edges.
  cv::Mat distance;
  cv::distanceTransform(255 - xrayEdges, distance, cv::DIST_L2, cv::DIST_MASK_PRECISE);
  cv::Mat counted;
  cv::erode(inside, counted, cv::Mat(), cv::Point(-1, -1), BorderPixels, cv::BORDER_CONSTANT, cv::Scalar(0));
  std::vector<float> atResult;
  std::vector<std::vector<float>> shifted(4);
  const int shifts[4][2] = { { shiftPixels, 0 }, { -shiftPixels, 0 }, { 0, shiftPixels }, { 0, -shiftPixels } };
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      if (!drrEdges.at<uint8_t>(r, c) || !counted.at<uint8_t>(r, c))
        continue;
      atResult.push_back(distance.at<float>(r, c));
      for (int s = 0; s < 4; ++s)
      {
        const int sc = c + shifts[s][0], sr = r + shifts[s][1];
        if (sc >= 0 && sc < columns && sr >= 0 && sr < rows && counted.at<uint8_t>(sr, sc))
          shifted[s].push_back(distance.at<float>(sr, sc));
      }
    }
  agreement.drrEdgePixels = static_cast<long long>(atResult.size());
  agreement.medianPixels = Median(atResult);
  std::vector<float> medians;
  for (std::vector<float>& s : shifted)
    if (!s.empty())
      medians.push_back(static_cast<float>(Median(s)));
  agreement.shiftedMedianPixels = Median(medians);
  return agreement;
}

} // namespace xp
