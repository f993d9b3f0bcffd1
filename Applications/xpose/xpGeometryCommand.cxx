// xpose geometry: the geometry file (Coordinates.md) from what calibrated systems provide.
#include "xpCommands.h"

#include "xpError.h"
#include "xpProjectionMatrix.h"
#include "xpStereoGeometry.h"
#include "xpXRayGeometryTags.h"

#include <cmath>
#include <cstdio>

namespace xp
{

namespace
{

/** "0.4" or "0.4,0.3" (between columns, between rows), mm. */
Eigen::Vector2d ParseSpacing(const std::string& text)
{
  Eigen::Vector2d spacing;
  char comma = 0, extra = 0;
  const int read = std::sscanf(text.c_str(), "%lf%c%lf%c", &spacing[0], &comma, &spacing[1], &extra);
  if (read == 1)
    spacing[1] = spacing[0];
  if (!((read == 1 || (read == 3 && comma == ',')) && spacing.allFinite() && spacing.minCoeff() > 0.0 && spacing.maxCoeff() <= 10.0))
    throw InputError("--pixel-spacing", "expected MM or COLUMN_MM,ROW_MM between 0 and 10 mm, got '" + text + "'");
  return spacing;
}

/** The imagers of --dicom: each X-ray's own tags (RT Image, DX, CR, XA), named by --names, an
 *  RT Image's label or the file. */
StereoGeometry GeometryFromDICOM(const GeometryOptions& options)
{
  if (!options.projectionMatrices.empty() || !options.intrinsics.empty() || !options.extrinsics.empty() ||
    !options.cameraCalibrations.empty())
    throw InputError("--dicom", "give DICOM X-rays or projection matrices or pinhole calibrations, not several");
  if (!options.pixelSpacing.empty() || !options.size.empty())
    throw InputError("--dicom", "DICOM X-rays carry their own pixel spacing and size: leave out --pixel-spacing and --size");
  if (!options.names.empty() && options.names.size() != options.dicom.size())
    throw InputError("--names", "give one name per DICOM X-ray (" + std::to_string(options.dicom.size()) + "), got " +
        std::to_string(options.names.size()));
  StereoGeometry geometry;
  geometry.name = "from DICOM X-ray tags";
  geometry.isocenter = ParsePoint(options.isocenter.empty() ? "0,0,0" : options.isocenter, "--isocenter");
  for (size_t v = 0; v < options.dicom.size(); ++v)
  {
    geometry.views.push_back(ReadXRayViewFromTags(options.dicom[v], geometry.isocenter, options.patientPosition));
    if (!options.names.empty())
      geometry.views.back().name = options.names[v];
    else if (geometry.views.back().name == options.dicom[v]) // a DX has no label: A, B, ...
      geometry.views.back().name = std::string(1, static_cast<char>('A' + v));
  }
  return geometry;
}

StereoGeometry GeometryFromMatrices(const GeometryOptions& options)
{
  const bool pinhole = !options.intrinsics.empty() || !options.extrinsics.empty();
  if (pinhole == !options.projectionMatrices.empty())
    throw InputError("--projection-matrix", "give DICOM X-rays (--dicom), projection matrices or --intrinsics with --extrinsics, one per imager");
  if (pinhole && options.intrinsics.size() != options.extrinsics.size())
    throw InputError("--extrinsics", "give one [R | t] file per --intrinsics file (" + std::to_string(options.intrinsics.size()) +
        "), got " + std::to_string(options.extrinsics.size()));
  const std::vector<std::string>& files = pinhole ? options.extrinsics : options.projectionMatrices;
  if (!options.names.empty() && options.names.size() != files.size())
    throw InputError("--names", "give one name per projection matrix (" + std::to_string(files.size()) + "), got " +
        std::to_string(options.names.size()));
  if (options.pixelSpacing.empty() || options.size.empty())
    throw InputError(options.pixelSpacing.empty() ? "--pixel-spacing" : "--size", "is needed with projection matrices");
  const Eigen::Vector2d spacing = ParseSpacing(options.pixelSpacing);
  const auto [columns, rows] = ParseSize(options.size, "--size");
  StereoGeometry geometry;
  geometry.name = pinhole ? "from pinhole calibrations" : "from projection matrices";
  geometry.isocenter = ParsePoint(options.isocenter.empty() ? "0,0,0" : options.isocenter, "--isocenter");
  for (size_t v = 0; v < files.size(); ++v)
  {
    const std::string name = options.names.empty() ? std::string(1, static_cast<char>('A' + v)) : options.names[v];
    const ProjectionMatrix projection =
      pinhole ? ReadPinholeCalibration(options.intrinsics[v], files[v]) : ReadProjectionMatrix(files[v]);
    geometry.views.push_back(ViewFromProjectionMatrix(projection, spacing, { columns, rows }, geometry.isocenter, name, files[v]));
  }
  return geometry;
}

/** The imagers of --camera-calibration; the isocentre where their central rays pass closest
 *  unless --isocenter gives it (a laboratory's origin is rarely where its cameras look). */
StereoGeometry GeometryFromCameraCalibrations(const GeometryOptions& options)
{
  if (!options.projectionMatrices.empty() || !options.intrinsics.empty() || !options.extrinsics.empty())
    throw InputError("--camera-calibration", "give camera calibrations or projection matrices or pinhole calibrations, not several");
  if (!options.size.empty())
    throw InputError("--size", "camera calibrations carry their image size: leave out --size");
  if (options.pixelSpacing.empty() || options.pixelSpacing.find(',') != std::string::npos)
    throw InputError("--pixel-spacing", "give one spacing MM with camera calibrations (the rows' follows from fx / fy)");
  if (!options.names.empty() && options.names.size() != options.cameraCalibrations.size())
    throw InputError("--names", "give one name per camera calibration (" + std::to_string(options.cameraCalibrations.size()) +
        "), got " + std::to_string(options.names.size()));
  const double spacing = ParseSpacing(options.pixelSpacing)[0];
  std::vector<CameraCalibration> cameras;
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> centralRays;
  for (const std::string& path : options.cameraCalibrations)
  {
    cameras.push_back(ReadCameraCalibration(path));
    centralRays.emplace_back(cameras.back().Source(), cameras.back().Axis());
  }
  StereoGeometry geometry;
  geometry.name = "from camera calibrations";
  if (options.isocenter.empty())
  {
    double gap = 0.0;
    geometry.isocenter = ClosestApproach(centralRays, &gap);
    std::printf("isocentre (%.2f, %.2f, %.2f) mm: where the central rays pass closest", geometry.isocenter[0],
      geometry.isocenter[1], geometry.isocenter[2]);
    if (centralRays.size() == 2)
      std::printf(", %.2f mm apart", gap);
    std::printf(" (--isocenter overrides it)\n");
  }
  else
    geometry.isocenter = ParsePoint(options.isocenter, "--isocenter");
  for (size_t v = 0; v < cameras.size(); ++v)
  {
    const std::string name = options.names.empty() ? std::string(1, static_cast<char>('A' + v)) : options.names[v];
    geometry.views.push_back(ViewFromProjectionMatrix(cameras[v].Projection(), cameras[v].PixelSpacing(spacing),
      cameras[v].size, geometry.isocenter, name, options.cameraCalibrations[v]));
  }
  return geometry;
}

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

/** --check: each DICOM X-ray against the geometry file's imager of the same order. */
int CheckAgainstGeometry(const GeometryOptions& options)
{
  if (options.dicom.empty())
    throw InputError("--check", "compares DICOM X-rays (--dicom) with the geometry file");
  const StereoGeometry geometry = ReadStereoGeometry(options.check);
  if (options.dicom.size() != geometry.views.size())
    throw InputError("--dicom", "give one DICOM X-ray per imager of " + options.check + " (" + std::to_string(geometry.views.size()) +
        "), in order; got " + std::to_string(options.dicom.size()));
  bool agree = true;
  for (size_t v = 0; v < geometry.views.size(); ++v)
  {
    const XRayView& expected = geometry.views[v];
    const XRayView found = ReadXRayViewFromTags(options.dicom[v], geometry.isocenter, options.patientPosition);
    std::printf("imager %s, %s: source %.3f mm, panel centre %.3f mm from the file's; rows %.4f deg, columns %.4f deg apart\n",
      expected.name.c_str(), options.dicom[v].c_str(), (found.source - expected.source).norm(),
      (found.detectorCenter - expected.detectorCenter).norm(), DegreesApart(found.rowDirection, expected.rowDirection),
      DegreesApart(found.columnDirection, expected.columnDirection));
    for (const std::string& difference :
      XRayTagDisagreements(options.dicom[v], expected, geometry.isocenter, options.patientPosition))
    {
      std::printf("  %s\n", difference.c_str());
      agree = false;
    }
  }
  std::printf("%s\n", agree ? "the X-rays' tags agree with the geometry file (0.5 mm, 0.1 deg)" : "the X-rays' tags DISAGREE with the geometry file");
  return agree ? ExitOk : ExitBadInput;
}

} // namespace

int RunGeometry(const GeometryOptions& options)
{
  if (!options.check.empty())
    return CheckAgainstGeometry(options);
  if (options.output.empty())
    throw InputError("--out", "the geometry file to write is missing");
  const StereoGeometry geometry = !options.dicom.empty() ? GeometryFromDICOM(options)
    : !options.cameraCalibrations.empty()                ? GeometryFromCameraCalibrations(options)
                                                         : GeometryFromMatrices(options);
  // The views must make a geometry xpose can use (central rays on the panels, names distinct).
  ValidateGeometry(geometry, options.output);
  WriteStereoGeometry(geometry, options.output);
  for (const XRayView& view : geometry.views)
  {
    const Eigen::Vector2d iso = view.Project(geometry.isocenter);
    std::printf("imager %s: source (%.2f, %.2f, %.2f) mm, source to panel %.2f mm, source to isocentre %.2f mm, "
                "isocentre at pixel (%.2f, %.2f)\n",
      view.name.c_str(), view.source[0], view.source[1], view.source[2], view.SourceToPanelDistance(),
      (view.source - geometry.isocenter).norm(), iso[0], iso[1]);
  }
  std::printf("wrote %s\n", options.output.c_str());
  return ExitOk;
}

} // namespace xp
