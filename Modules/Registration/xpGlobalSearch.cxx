#include "xpGlobalSearch.h"

#include "xpError.h"
#include "xpImageLevels.h"
#include "xpProjectionMatrix.h"
#include "xpRayCaster.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/** The X-ray at the working size: its ranks over the ROI, averaged down to 1 / factor; outside
 *  the ROI (shrunk by 2 working pixels) the ROI's mean, which correlates with nothing. */
cv::Mat XRayLevels(const RegistrationView& item, int factor)
{
  const int columns = item.view.Columns() / factor, rows = item.view.Rows() / factor;
  const std::vector<uint16_t> ranks = EqualizedLevels(item.xray, item.mask);
  cv::Mat full(item.view.Rows(), item.view.Columns(), CV_16U, const_cast<uint16_t*>(ranks.data())), fullFloat, small;
  full.convertTo(fullFloat, CV_32F);
  cv::resize(fullFloat, small, cv::Size(columns, rows), 0, 0, cv::INTER_AREA); // the panel's whole extent, as Resampled
  if (!item.mask.empty())
  {
    cv::Mat mask(item.view.Rows(), item.view.Columns(), CV_8U, const_cast<uint8_t*>(item.mask.data())), smallMask, inside;
    cv::resize(mask, smallMask, cv::Size(columns, rows), 0, 0, cv::INTER_NEAREST);
    cv::erode(smallMask, inside, cv::Mat(), cv::Point(-1, -1), 2);
    small.setTo(cv::mean(small, inside)[0], inside == 0);
  }
  return small;
}

struct Peak
{
  cv::Point at;
  double value = 0.0;
};

/** The `count` highest places of a correlation map, each at least `apart` pixels from the others. */
std::vector<Peak> HighestPeaks(cv::Mat map, int count, int apart)
{
  std::vector<Peak> peaks;
  for (int n = 0; n < count; ++n)
  {
    double value = 0.0;
    cv::Point at;
    cv::minMaxLoc(map, nullptr, &value, nullptr, &at);
    if (!(value > 0.0))
      break;
    peaks.push_back({ at, value });
    cv::rectangle(map, cv::Rect(at.x - apart, at.y - apart, 2 * apart + 1, 2 * apart + 1), cv::Scalar(-1.0), cv::FILLED);
  }
  return peaks;
}

} // namespace

std::vector<Eigen::Matrix3d> OrientationGrid(double stepDegrees)
{
  const double step = stepDegrees * M_PI / 180.0;
  const int directions = std::max(1, static_cast<int>(std::lround(4.0 * M_PI / (step * step))));
  const int spins = std::max(1, static_cast<int>(std::lround(360.0 / stepDegrees)));
  std::vector<Eigen::Matrix3d> grid;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int d = 0; d < directions; ++d)
  {
    const double z = 1.0 - 2.0 * (d + 0.5) / directions, r = std::sqrt(1.0 - z * z);
    const Eigen::Vector3d axis(r * std::cos(golden * d), r * std::sin(golden * d), z);
    // The rotation taking the slice axis (z) onto `axis`, then the spin about it.
    const Eigen::Matrix3d tilt = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis).toRotationMatrix();
    for (int s = 0; s < spins; ++s)
      grid.push_back(Eigen::AngleAxisd(2.0 * M_PI * s / spins, axis).toRotationMatrix() * tilt);
  }
  return grid;
}

std::vector<GlobalCandidate> FindGlobalStarts(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& isocenter, const Eigen::Vector3d& ctCenterInRoom, const std::vector<RegistrationView>& views,
  const GlobalSearchSettings& settings)
{
  if (views.size() != 2)
    throw InputError("global search", "joins the places found in exactly two views");
  const int factor = std::max(1, static_cast<int>(std::lround(static_cast<double>(views[0].view.Columns()) / settings.workingColumns)));
  std::vector<cv::Mat> xrays;
  std::vector<XRayView> small;
  for (const RegistrationView& item : views)
  {
    xrays.push_back(XRayLevels(item, factor));
    small.push_back(item.view.Resampled(item.view.Columns() / factor, item.view.Rows() / factor));
  }
  // Per polarity of the X-rays (bone bright, as the DRR's line integrals, or dark, as raw
  // transmission): the polarity whose best pair scores higher is the X-rays'.
  std::vector<GlobalCandidate> found[2];
  for (const Eigen::Matrix3d& rotation : OrientationGrid(settings.angleStepDegrees))
  {
    Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
    turn.linear() = rotation;
    turn.translation() = isocenter - rotation * isocenter;
    const Pose orientation = Pose::FromTransform(turn, isocenter);
    const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(plannedCTToRoom, orientation, isocenter);
    const Eigen::Vector3d center = turn * ctCenterInRoom; // where the volume's centre is now
    std::vector<cv::Mat> maps(2);
    std::vector<int> apart(2);
    std::vector<Eigen::Vector2d> centerAt(2);
    bool seen = true;
    for (size_t v = 0; v < 2 && seen; ++v)
    {
      const XRayView& view = small[v];
      cv::Mat integrals(view.Rows(), view.Columns(), CV_32F, cv::Scalar(0.0f));
      RenderLineIntegrals(volume, ctToRoom, view.source, DetectorGrid::TopRowFirst(view), nullptr, integrals.ptr<float>());
      cv::Mat shadow = integrals > 0.0f;
      const cv::Rect box = cv::boundingRect(shadow);
      // A template of a few pixels, or one as large as the image, finds nothing.
      if (box.width < 4 || box.height < 4 || box.width * 2 > view.Columns() || box.height * 2 > view.Rows())
      {
        seen = false;
        break;
      }
      // The bone's shadow and a rim of 2 pixels: the bone against what surrounds it.
      cv::dilate(shadow, shadow, cv::Mat(), cv::Point(-1, -1), 2);
      const cv::Rect padded = (box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, view.Columns(), view.Rows());
      cv::matchTemplate(xrays[v], integrals(padded), maps[v], cv::TM_CCOEFF_NORMED, shadow(padded));
      // Where the X-ray is flat under the template (outside the field) the correlation is 0/0.
      cv::patchNaNs(maps[v], 0.0);
      maps[v].setTo(0.0f, (maps[v] > 1.0f) | (maps[v] < -1.0f));
      apart[v] = std::max(2, std::min(padded.width, padded.height) / 4);
      // The volume's centre in the template's frame: where it goes with the template.
      centerAt[v] = view.Project(center) - Eigen::Vector2d(padded.x, padded.y);
    }
    if (!seen)
      continue;
    for (int polarity = 0; polarity < 2; ++polarity)
    {
      std::vector<std::vector<Peak>> peaks(2);
      for (size_t v = 0; v < 2; ++v)
        peaks[v] = HighestPeaks(polarity == 0 ? maps[v].clone() : cv::Mat(-maps[v]), settings.peaksPerView, apart[v]);
      for (const Peak& a : peaks[0])
        for (const Peak& b : peaks[1])
        {
          std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rays;
          const Peak* both[2] = { &a, &b };
          for (size_t v = 0; v < 2; ++v)
          {
            const Eigen::Vector2d pixel = centerAt[v] + Eigen::Vector2d(both[v]->at.x, both[v]->at.y);
            rays.emplace_back(small[v].source, small[v].PixelCenter(pixel[0], pixel[1]) - small[v].source);
          }
          double raysApart = 0.0;
          const Eigen::Vector3d place = ClosestApproach(rays, &raysApart);
          if (!(raysApart <= settings.maxRaysApartMM))
            continue;
          GlobalCandidate candidate;
          candidate.pose = orientation;
          candidate.pose.translation = place - center;
          candidate.score = 0.5 * (a.value + b.value);
          candidate.raysApartMM = raysApart;
          found[polarity].push_back(candidate);
        }
    }
  }
  const auto best = [](const std::vector<GlobalCandidate>& list)
  {
    double top = -1.0;
    for (const GlobalCandidate& c : list)
      top = std::max(top, c.score);
    return top;
  };
  std::vector<GlobalCandidate>& chosen = best(found[1]) > best(found[0]) ? found[1] : found[0];
  std::sort(chosen.begin(), chosen.end(), [](const GlobalCandidate& x, const GlobalCandidate& y) { return x.score > y.score; });
  std::vector<GlobalCandidate> distinct;
  for (const GlobalCandidate& c : chosen)
  {
    const bool near = std::any_of(distinct.begin(), distinct.end(), [&](const GlobalCandidate& d)
      {
        const double degrees = Eigen::AngleAxisd(c.pose.Rotation() * d.pose.Rotation().transpose()).angle() * 180.0 / M_PI;
        return (c.pose.translation - d.pose.translation).norm() < settings.distinctMM && degrees < settings.distinctDegrees;
      });
    if (!near)
      distinct.push_back(c);
    if (static_cast<int>(distinct.size()) == settings.candidates)
      break;
  }
  return distinct;
}

GlobalStart RefineGlobalCandidates(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& isocenter, const std::vector<RegistrationView>& views, const StereoRegistrationSettings& settings,
  const std::vector<GlobalCandidate>& candidates)
{
  if (candidates.empty())
    throw InputError("global search", "no orientation of the volume matches both X-rays: give an initial pose");
  GlobalStart start;
  start.candidates = candidates;
  double best = -1.0;
  for (const GlobalCandidate& candidate : candidates)
  {
    StereoRegistrationSettings refine = settings;
    refine.initialPose = candidate.pose;
    refine.maxTranslation = 500.0;
    refine.maxRotation = 180.0;
    const StereoRegistrationResult result = RegisterStereo(volume, plannedCTToRoom, isocenter, views, refine);
    start.objectives.push_back(result.objective);
    start.refined.push_back(result.misalignment);
    if (result.objective > best)
    {
      best = result.objective;
      start.pose = result.misalignment;
    }
  }
  return start;
}

} // namespace xp
