#include "xpGlobalSearch.h"

#include "xpBoneCut.h"
#include "xpError.h"
#include "xpImageLevels.h"
#include "xpPoseOptimizer.h"
#include "xpProjectionMatrix.h"
#include "xpRayCaster.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/** Less its Gaussian low-pass (sd 6 working pixels, about 1 cm): a limb's shading and an image
 *  intensifier's bands go, a bone's outline and its inside stay. */
cv::Mat HighPass(const cv::Mat& image)
{
  cv::Mat low;
  cv::GaussianBlur(image, low, cv::Size(0, 0), 6.0);
  return image - low;
}

/** An X-ray at the working size: its structure (ranks over the ROI, high-passed), and per
 *  polarity where the body is (bone bright: brighter than the open field; bone dark: darker),
 *  split from the open field by Otsu's threshold on the grey levels within the ROI. A bone lies
 *  within the body. */
struct WorkingXRay
{
  cv::Mat structure;
  cv::Mat body[2]; ///< CV_8U 0/1: [0] bone bright, [1] bone dark
  /** How much more structure the darker side of the split holds than the brighter (mean
   *  |high-passed ranks|): above 1, the body is dark, as in raw transmission. */
  double darkStructureRatio = 1.0;
};

WorkingXRay MakeWorkingXRay(const RegistrationView& item, int factor)
{
  const int columns = item.view.Columns() / factor, rows = item.view.Rows() / factor;
  const std::vector<uint16_t> ranks = EqualizedLevels(item.xray, item.mask);
  cv::Mat full(item.view.Rows(), item.view.Columns(), CV_16U, const_cast<uint16_t*>(ranks.data())), fullFloat, small;
  full.convertTo(fullFloat, CV_32F);
  cv::resize(fullFloat, small, cv::Size(columns, rows), 0, 0, cv::INTER_AREA); // the panel's whole extent, as Resampled
  cv::Mat inside(rows, columns, CV_8U, cv::Scalar(1));
  if (!item.mask.empty())
  {
    cv::Mat mask(item.view.Rows(), item.view.Columns(), CV_8U, const_cast<uint8_t*>(item.mask.data())), smallMask;
    cv::resize(mask, smallMask, cv::Size(columns, rows), 0, 0, cv::INTER_NEAREST);
    cv::erode(smallMask, inside, cv::Mat(), cv::Point(-1, -1), 2);
    inside = inside != 0;
    inside /= 255;
  }
  // Outside the ROI the ROI's mean, which correlates with nothing.
  small.setTo(cv::mean(small, inside)[0], inside == 0);
  WorkingXRay working;
  working.structure = HighPass(small);
  // The body from the grey levels as they came (ranks are flat: every split is the median).
  cv::Mat raw(item.view.Rows(), item.view.Columns(), CV_16U, const_cast<uint16_t*>(item.xray.data())), rawFloat, smooth, grey, split;
  raw.convertTo(rawFloat, CV_32F);
  cv::resize(rawFloat, smooth, cv::Size(columns, rows), 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(smooth, smooth, cv::Size(0, 0), 2.0);
  double low = 0.0, high = 0.0;
  cv::minMaxLoc(smooth, &low, &high, nullptr, nullptr, inside);
  smooth.convertTo(grey, CV_8U, 255.0 / std::max(high - low, 1e-6), -255.0 * low / std::max(high - low, 1e-6));
  std::vector<uint8_t> values;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (inside.at<uint8_t>(r, c))
        values.push_back(grey.at<uint8_t>(r, c));
  const double threshold = values.empty() ? 128.0 : cv::threshold(cv::Mat(values), split, 0, 1, cv::THRESH_BINARY | cv::THRESH_OTSU);
  working.body[0] = (grey > threshold) & inside; // 255 & 1: 0 or 1
  working.body[1] = (grey <= threshold) & inside;
  const cv::Mat texture = cv::abs(working.structure);
  const double bright = cv::mean(texture, working.body[0])[0], dark = cv::mean(texture, working.body[1])[0];
  working.darkStructureRatio = dark / std::max(bright, 1e-9);
  return working;
}

/** A bone's shadow lies within the body's: at least this share of it. */
constexpr double MinWithinBody = 0.8;

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

/** The first `count` of `sorted` that are not within `mm` and `degrees` of an earlier one. */
std::vector<GlobalCandidate> Distinct(const std::vector<GlobalCandidate>& sorted, int count, double mm, double degrees)
{
  std::vector<GlobalCandidate> distinct;
  for (const GlobalCandidate& c : sorted)
  {
    if (static_cast<int>(distinct.size()) == count)
      break;
    const bool near = std::any_of(distinct.begin(), distinct.end(), [&](const GlobalCandidate& d)
      {
        const double apart = Eigen::AngleAxisd(c.pose.Rotation() * d.pose.Rotation().transpose()).angle() * 180.0 / M_PI;
        return (c.pose.translation - d.pose.translation).norm() < mm && apart < degrees;
      });
    if (!near)
      distinct.push_back(c);
  }
  return distinct;
}

/** The bone's cut faces' shadow and this much around it (mm on the panel) leave the template:
 *  beyond the cut the X-ray shows the bone running on (xpBoneCut.h). */
constexpr double CutMarginMM = 5.0;

/**
 * The search's score of a pose: per view, the correlation of the high-passed X-ray with the
 * high-passed DRR over the volume's shadow and a rim of 2 pixels (the template of the grid
 * search, at the pose's own place), averaged over the views; `sign` -1 for X-rays whose bone is
 * dark.
 */
class TwoViewCorrelation
{
public:
  TwoViewCorrelation(const AttenuationVolume& volume, const Eigen::Isometry3d& planned, const Eigen::Vector3d& isocenter,
    const std::vector<XRayView>& views, const std::vector<WorkingXRay>& xrays, int polarity,
    const std::vector<Eigen::Vector3d>& cutPoints)
    : Volume(volume), Planned(planned), Isocenter(isocenter), Views(views), XRays(xrays), Polarity(polarity), CutPoints(cutPoints)
  {
  }

  double operator()(const Pose& pose) const
  {
    double sum = 0.0;
    for (size_t v = 0; v < this->Views.size(); ++v)
    {
      const XRayView& view = this->Views[v];
      cv::Mat integrals(view.Rows(), view.Columns(), CV_32F, cv::Scalar(0.0f));
      const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(this->Planned, pose, this->Isocenter);
      RenderLineIntegrals(this->Volume, ctToRoom, view.source, DetectorGrid::TopRowFirst(view), nullptr, integrals.ptr<float>());
      cv::Mat shadow = integrals > 0.0f;
      const int pixels = cv::countNonZero(shadow);
      if (pixels < 16)
        return -1.0; // the volume left the images
      const cv::Mat& body = this->XRays[v].body[this->Polarity];
      if (cv::countNonZero(body & shadow) < MinWithinBody * pixels)
        return -1.0;
      cv::dilate(shadow, shadow, cv::Mat(), cv::Point(-1, -1), 2);
      LeaveOutAroundPoints(shadow.ptr<uint8_t>(), view, this->CutPoints, ctToRoom, CutMarginMM);
      if (cv::countNonZero(shadow) < 16)
        return -1.0;
      const cv::Mat structure = HighPass(integrals);
      const cv::Mat& xray = this->XRays[v].structure;
      cv::Scalar meanD, sdD, meanX, sdX;
      cv::meanStdDev(structure, meanD, sdD, shadow);
      cv::meanStdDev(xray, meanX, sdX, shadow);
      if (!(sdD[0] > 0.0 && sdX[0] > 0.0))
        return -1.0;
      cv::Mat product = (structure - meanD[0]).mul(xray - meanX[0]);
      sum += (this->Polarity == 0 ? 1.0 : -1.0) * cv::mean(product, shadow)[0] / (sdD[0] * sdX[0]);
    }
    return sum / this->Views.size();
  }

  /** The pose near `start` of the highest score, moved and turned about the volume's centre
   *  (`ctCenterInRoom` at the planned set-up); `score` is set to its score. */
  Pose Refine(const Pose& start, const Eigen::Vector3d& ctCenterInRoom, double& score) const
  {
    const Eigen::Isometry3d from = start.ToTransform(this->Isocenter);
    const Eigen::Vector3d center = from * ctCenterInRoom;
    // Parameters: a motion about the volume's centre after `start`, so that turning it does not
    // swing it about an isocentre some centimetres away.
    const auto posed = [&](const Pose& local)
    {
      const Eigen::Isometry3d motion = local.ToTransform(center);
      return Pose::FromTransform(motion * from, this->Isocenter);
    };
    PoseOptimizerSettings settings;
    settings.initialStepMM = 3.0;
    settings.initialStepDegrees = 6.0;
    settings.toleranceMM = 0.2;
    settings.toleranceDegrees = 0.5;
    settings.maxEvaluations = 150;
    settings.maxRestarts = 1;
    settings.boundMM = 20.0;
    settings.boundDegrees = 30.0;
    const PoseOptimizerResult result = MaximizePose([&](const Pose& local) { return (*this)(posed(local)); }, Pose{}, settings);
    score = result.value;
    return posed(result.pose);
  }

private:
  const AttenuationVolume& Volume;
  Eigen::Isometry3d Planned;
  Eigen::Vector3d Isocenter;
  const std::vector<XRayView>& Views;
  const std::vector<WorkingXRay>& XRays;
  int Polarity;
  const std::vector<Eigen::Vector3d>& CutPoints;
};

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
  std::vector<WorkingXRay> xrays;
  std::vector<XRayView> small;
  for (const RegistrationView& item : views)
  {
    xrays.push_back(MakeWorkingXRay(item, factor));
    small.push_back(item.view.Resampled(item.view.Columns() / factor, item.view.Rows() / factor));
  }
  // The X-rays' polarity: the body is the side of the grey-level split that holds the structure
  // (the open field is flat); a dark body is raw transmission, and its bone is dark too.
  const int polarity = xrays[0].darkStructureRatio * xrays[1].darkStructureRatio > 1.0 ? 1 : 0;
  const std::vector<Eigen::Vector3d> cutPoints = settings.leaveOutCuts ? CutFacePoints(volume) : std::vector<Eigen::Vector3d>();
  std::vector<GlobalCandidate> chosen;
  for (const Eigen::Matrix3d& rotation : OrientationGrid(settings.angleStepDegrees))
  {
    Eigen::Isometry3d turn = Eigen::Isometry3d::Identity();
    turn.linear() = rotation;
    turn.translation() = isocenter - rotation * isocenter;
    const Pose orientation = Pose::FromTransform(turn, isocenter);
    const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(plannedCTToRoom, orientation, isocenter);
    const Eigen::Vector3d center = turn * ctCenterInRoom; // where the volume's centre is now
    std::vector<cv::Mat> maps(2), withinBody(2);
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
      const cv::Rect padded = (box + cv::Size(4, 4) - cv::Point(2, 2)) & cv::Rect(0, 0, view.Columns(), view.Rows());
      // The share of the shadow that each placement puts within the body.
      cv::Mat bone, body;
      shadow(padded).convertTo(bone, CV_32F, 1.0 / 255.0);
      xrays[v].body[polarity].convertTo(body, CV_32F);
      cv::matchTemplate(body, bone, withinBody[v], cv::TM_CCORR);
      withinBody[v] /= std::max(1.0, cv::sum(bone)[0]);
      // The bone's shadow and a rim of 2 pixels: the bone against what surrounds it; not where
      // the crop cut it.
      cv::dilate(shadow, shadow, cv::Mat(), cv::Point(-1, -1), 2);
      LeaveOutAroundPoints(shadow.ptr<uint8_t>(), view, cutPoints, ctToRoom, CutMarginMM);
      const cv::Mat structure = HighPass(integrals);
      cv::matchTemplate(xrays[v].structure, structure(padded), maps[v], cv::TM_CCOEFF_NORMED, shadow(padded));
      // Where the X-ray is flat under the template (outside the field) the correlation is 0/0.
      cv::patchNaNs(maps[v], 0.0);
      maps[v].setTo(0.0f, (maps[v] > 1.0f) | (maps[v] < -1.0f));
      apart[v] = std::max(2, std::min(padded.width, padded.height) / 4);
      // The volume's centre in the template's frame: where it goes with the template.
      centerAt[v] = view.Project(center) - Eigen::Vector2d(padded.x, padded.y);
    }
    if (!seen)
      continue;
    {
      std::vector<std::vector<Peak>> peaks(2);
      for (size_t v = 0; v < 2; ++v)
      {
        cv::Mat map = polarity == 0 ? maps[v].clone() : cv::Mat(-maps[v]);
        map.setTo(-1.0f, withinBody[v] < MinWithinBody);
        peaks[v] = HighestPeaks(map, settings.peaksPerView, apart[v]);
      }
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
          chosen.push_back(candidate);
        }
    }
  }
  std::sort(chosen.begin(), chosen.end(), [](const GlobalCandidate& x, const GlobalCandidate& y) { return x.score > y.score; });
  // The grid's best are half a step off at most: each is refined on the same correlation, the
  // pose now free, and the refined scores decide.
  const TwoViewCorrelation correlation(volume, plannedCTToRoom, isocenter, small, xrays, polarity, cutPoints);
  std::vector<GlobalCandidate> refined;
  for (const GlobalCandidate& c : Distinct(chosen, settings.refined, 0.5 * settings.distinctMM, 0.5 * settings.distinctDegrees))
  {
    GlobalCandidate better = c;
    better.pose = correlation.Refine(c.pose, ctCenterInRoom, better.score);
    refined.push_back(better);
  }
  std::sort(refined.begin(), refined.end(), [](const GlobalCandidate& x, const GlobalCandidate& y) { return x.score > y.score; });
  return Distinct(refined, settings.candidates, settings.distinctMM, settings.distinctDegrees);
}

} // namespace xp
