#include "xpCArmGeometry.h"

#include "xpError.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>

namespace xp
{

namespace
{

constexpr double Degree = M_PI / 180.0;
const char* const PatientOrientationTag = "Patient Orientation (0020,0020)";

/** The positioner's turn of the patient frame: Rz(primary) Rx(-secondary), in LPS. At 0, 0 the
 *  beam runs along -y (posterior to anterior); the panel's axes are +x (left) and -z (feet). */
Eigen::Matrix3d PositionerRotation(double primary, double secondary)
{
  return (Eigen::AngleAxisd(primary * Degree, Eigen::Vector3d::UnitZ()) *
    Eigen::AngleAxisd(-secondary * Degree, Eigen::Vector3d::UnitX()))
    .toRotationMatrix();
}

/** The four directions a row or column may take on the panel: +-left and +-feet, turned. */
std::array<Eigen::Vector3d, 4> PanelAxes(const Eigen::Matrix3d& turn)
{
  const Eigen::Vector3d left = turn * Eigen::Vector3d::UnitX(), feet = turn * -Eigen::Vector3d::UnitZ();
  return { left, -left, feet, -feet };
}

/** The LPS direction that Patient Orientation letters name; throws naming the tag. */
Eigen::Vector3d DirectionOfLetters(const std::string& letters, const char* which)
{
  if (letters.empty() || letters.size() > 3)
    throw InputError(PatientOrientationTag, std::string(which) + " '" + letters + "': expected one to three of L R A P H F");
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  for (const char letter : letters)
  {
    switch (letter)
    {
      case 'L': direction.x() += 1.0; break;
      case 'R': direction.x() -= 1.0; break;
      case 'P': direction.y() += 1.0; break;
      case 'A': direction.y() -= 1.0; break;
      case 'H': direction.z() += 1.0; break;
      case 'F': direction.z() -= 1.0; break;
      default:
        throw InputError(PatientOrientationTag, std::string(which) + " '" + letters + "': '" + letter + "' is none of L R A P H F");
    }
  }
  if (direction.norm() < 0.5)
    throw InputError(PatientOrientationTag, std::string(which) + " '" + letters + "' names opposite directions");
  return direction.normalized();
}

/** Of `candidates`, the one nearest `wanted` projected onto the panel; throws naming the tag when
 *  the letters lie along the beam or midway between two candidates. */
Eigen::Vector3d NearestAxis(const Eigen::Vector3d& wanted, const Eigen::Vector3d& beam,
  const std::vector<Eigen::Vector3d>& candidates, const std::string& letters, const char* which)
{
  const Eigen::Vector3d onPanel = wanted - wanted.dot(beam) * beam;
  if (onPanel.norm() < std::sin(10.0 * Degree))
    throw InputError(PatientOrientationTag, std::string(which) + " '" + letters + "' lies along the beam, not on the panel");
  std::vector<double> dots;
  for (const Eigen::Vector3d& c : candidates)
    dots.push_back(c.dot(onPanel.normalized()));
  const size_t best = std::max_element(dots.begin(), dots.end()) - dots.begin();
  for (size_t i = 0; i < dots.size(); ++i)
    if (i != best && dots[best] - dots[i] < 0.1)
      throw InputError(PatientOrientationTag, std::string(which) + " '" + letters + "' lies between two axes of the panel");
  return candidates[best];
}

} // namespace

XRayView ViewOfCArm(const CArmGeometry& g, const Eigen::Matrix3d& patientToRoom, const Eigen::Vector3d& roomIsocenter,
  const std::string& name)
{
  if (!(g.sourceToPatient > 0.0) || !(g.sourceToDetector > g.sourceToPatient))
    throw InputError("Distance Source to Detector (0018,1110)",
      "must exceed Distance Source to Patient (0018,1111), both positive (the isocentre lies between source and panel)");
  if (!(std::abs(g.primaryAngle) <= 180.0))
    throw InputError("Positioner Primary Angle (0018,1510)", "must lie within +-180 degrees");
  if (!(std::abs(g.secondaryAngle) <= 90.0))
    throw InputError("Positioner Secondary Angle (0018,1511)", "must lie within +-90 degrees");
  if (!(g.imagerPixelSpacing.minCoeff() > 0.0) || !g.imagerPixelSpacing.allFinite())
    throw InputError("Imager Pixel Spacing (0018,1164)", "must be positive");
  if (g.rows < 1 || g.columns < 1)
    throw InputError("Rows (0028,0010) / Columns (0028,0011)", "must be at least 1");
  const Eigen::Matrix3d turn = PositionerRotation(g.primaryAngle, g.secondaryAngle);
  const Eigen::Vector3d beam = turn * -Eigen::Vector3d::UnitY();
  const std::array<Eigen::Vector3d, 4> axes = PanelAxes(turn);
  const Eigen::Vector3d row =
    NearestAxis(DirectionOfLetters(g.rowOrientation, "row"), beam, { axes.begin(), axes.end() }, g.rowOrientation, "row");
  // Columns run along the other pair of axes.
  const bool rowAlongLeft = std::abs(row.dot(axes[0])) > 0.5;
  const Eigen::Vector3d column = NearestAxis(DirectionOfLetters(g.columnOrientation, "column"), beam,
    rowAlongLeft ? std::vector<Eigen::Vector3d>{ axes[2], axes[3] } : std::vector<Eigen::Vector3d>{ axes[0], axes[1] },
    g.columnOrientation, "column");

  XRayView view;
  view.name = name;
  view.source = roomIsocenter - g.sourceToPatient * (patientToRoom * beam);
  view.detectorCenter = roomIsocenter + (g.sourceToDetector - g.sourceToPatient) * (patientToRoom * beam);
  view.rowDirection = patientToRoom * row;
  view.columnDirection = patientToRoom * column;
  view.pixelSpacing = Eigen::Vector2d(g.imagerPixelSpacing[1], g.imagerPixelSpacing[0]);
  view.size = Eigen::Vector2i(g.columns, g.rows);
  return view;
}

CArmGeometry CArmGeometryOf(const XRayView& view, const Eigen::Matrix3d& patientToRoom, const Eigen::Vector3d& roomIsocenter)
{
  const std::string imager = "imager " + view.name;
  const Eigen::Vector3d toPanel = view.detectorCenter - view.source;
  const Eigen::Vector3d beam = patientToRoom.transpose() * toPanel.normalized();
  // A DX describes the panel only by distances along the central ray, normal to it.
  const Eigen::Vector3d normal = -view.NormalTowardsSource();
  if (std::atan2(toPanel.normalized().cross(normal).norm(), toPanel.normalized().dot(normal)) > 0.01 * Degree)
    throw InputError(imager, "the panel's centre is off the central ray, or the panel is tilted: DX/CR tags cannot describe it");
  const Eigen::Vector3d toIsocenter = roomIsocenter - view.source;
  if (toIsocenter.cross(toPanel.normalized()).norm() > 0.01)
    throw InputError(imager, "the isocentre is off the central ray: DX/CR tags cannot describe it");

  CArmGeometry g;
  g.sourceToPatient = toIsocenter.norm();
  g.sourceToDetector = toPanel.norm();
  g.secondaryAngle = std::asin(std::clamp(beam.z(), -1.0, 1.0)) / Degree;
  g.primaryAngle = std::hypot(beam.x(), beam.y()) < 1e-12 ? 0.0 : std::atan2(beam.x(), -beam.y()) / Degree;
  const std::array<Eigen::Vector3d, 4> axes = PanelAxes(PositionerRotation(g.primaryAngle, g.secondaryAngle));
  const Eigen::Vector3d row = patientToRoom.transpose() * view.rowDirection;
  const Eigen::Vector3d column = patientToRoom.transpose() * view.columnDirection;
  const auto onAnAxis = [&](const Eigen::Vector3d& direction)
  { return std::any_of(axes.begin(), axes.end(), [&](const Eigen::Vector3d& a) { return (a - direction).norm() < 0.01 * Degree; }); };
  if (!onAnAxis(row) || !onAnAxis(column))
    throw InputError(imager, "the panel is turned about the beam by other than a multiple of 90 degrees: DX/CR tags cannot describe it");
  g.rowOrientation = OrientationLetters(row);
  g.columnOrientation = OrientationLetters(column);
  g.imagerPixelSpacing = Eigen::Vector2d(view.pixelSpacing[1], view.pixelSpacing[0]);
  g.columns = view.Columns();
  g.rows = view.Rows();
  return g;
}

std::string OrientationLetters(const Eigen::Vector3d& direction)
{
  const char positive[3] = { 'L', 'P', 'H' }, negative[3] = { 'R', 'A', 'F' };
  std::array<int, 3> order = { 0, 1, 2 };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return std::abs(direction[a]) > std::abs(direction[b]); });
  std::string letters;
  for (const int axis : order)
    if (std::abs(direction[axis]) >= 0.25)
      letters += direction[axis] > 0.0 ? positive[axis] : negative[axis];
  return letters;
}

} // namespace xp
