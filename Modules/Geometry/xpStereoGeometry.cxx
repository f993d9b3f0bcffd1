#include "xpStereoGeometry.h"

#include "xpError.h"
#include "xpWholeFile.h"

#include <vtk_jsoncpp.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>

namespace xp
{

namespace
{

constexpr double UnitTolerance = 1e-3;
constexpr int LatestFormatVersion = 2;

std::string Where(const std::string& origin, const std::string& field)
{
  return origin + ": " + field;
}

const Json::Value& Member(const Json::Value& object, const char* key, const std::string& origin,
  const std::string& field)
{
  if (!object.isObject() || !object.isMember(key))
  {
    throw InputError(Where(origin, field), "missing");
  }
  return object[key];
}

double Number(const Json::Value& value, const std::string& origin, const std::string& field)
{
  // Room coordinates are millimetres: beyond a kilometre a value is a mistake, and would
  // overflow the projection arithmetic long before that mattered.
  if (!value.isNumeric() || !(std::abs(value.asDouble()) <= 1e6))
  {
    throw InputError(Where(origin, field), "not a finite number within +-1e6");
  }
  return value.asDouble();
}

template <int N>
Eigen::Matrix<double, N, 1> Vector(
  const Json::Value& value, const std::string& origin, const std::string& field)
{
  if (!value.isArray() || value.size() != N)
  {
    throw InputError(Where(origin, field), "expected an array of " + std::to_string(N) + " numbers");
  }
  Eigen::Matrix<double, N, 1> v;
  for (Json::ArrayIndex i = 0; i < N; ++i)
  {
    v[i] = Number(value[i], origin, field + "[" + std::to_string(i) + "]");
  }
  return v;
}

XRayView ParseView(const Json::Value& imager, const std::string& origin, const std::string& field)
{
  XRayView view;
  const Json::Value& name = Member(imager, "name", origin, field + ".name");
  // The name becomes part of output file names (drr_NAME.png): letters, digits, '-' and '_' only.
  const std::string text = name.isString() ? name.asString() : std::string();
  const bool safe = !text.empty() && text.size() <= 32 && std::all_of(text.begin(), text.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_';
  });
  if (!safe)
  {
    throw InputError(Where(origin, field + ".name"), "expected 1 to 32 letters, digits, '-' or '_'");
  }
  view.name = text;
  view.source = Vector<3>(Member(imager, "source", origin, field + ".source"), origin, field + ".source");
  const std::string det = field + ".detector";
  const Json::Value& detector = Member(imager, "detector", origin, det);
  view.detectorCenter = Vector<3>(Member(detector, "center", origin, det + ".center"), origin, det + ".center");
  view.rowDirection = Vector<3>(
    Member(detector, "row_direction", origin, det + ".row_direction"), origin, det + ".row_direction");
  view.columnDirection = Vector<3>(Member(detector, "column_direction", origin, det + ".column_direction"),
    origin, det + ".column_direction");
  view.pixelSpacing = Vector<2>(
    Member(detector, "pixel_spacing", origin, det + ".pixel_spacing"), origin, det + ".pixel_spacing");
  const Eigen::Vector2d size = Vector<2>(Member(detector, "size", origin, det + ".size"), origin, det + ".size");
  if (size[0] != std::floor(size[0]) || size[1] != std::floor(size[1]) || size.minCoeff() < 1 || size.maxCoeff() > 16384)
  {
    throw InputError(Where(origin, det + ".size"), "expected whole numbers of pixels between 1 and 16384");
  }
  view.size = size.cast<int>();
  return view;
}

CouchDescription ParseCouch(const Json::Value& object, const std::string& origin)
{
  if (!object.isObject())
    throw InputError(Where(origin, "couch"), "expected an object");
  for (const std::string& key : object.getMemberNames())
    if (key != "motions" && key != "rotation_limit_deg" && key != "rotation_center")
      throw InputError(Where(origin, "couch." + key), "unknown (a couch has motions, rotation_limit_deg and rotation_center)");
  CouchDescription couch;
  const Json::Value& motions = Member(object, "motions", origin, "couch.motions");
  if (!motions.isString())
    throw InputError(Where(origin, "couch.motions"), "expected \"6dof\" or \"4dof\"");
  couch.motions = ParseCouchMotions(motions.asString(), Where(origin, "couch.motions"));
  if (object.isMember("rotation_limit_deg"))
  {
    const Json::Value& limit = object["rotation_limit_deg"];
    if (!limit.isNumeric() || !std::isfinite(limit.asDouble()) || limit.asDouble() < 0.0 || limit.asDouble() > 180.0)
      throw InputError(Where(origin, "couch.rotation_limit_deg"), "expected a number of degrees from 0 to 180 (pitch and roll, each way)");
    couch.pitchRollLimitDegrees = limit.asDouble();
  }
  if (object.isMember("rotation_center"))
    couch.rotationCenter = Vector<3>(object["rotation_center"], origin, "couch.rotation_center");
  return couch;
}

Json::Value ToJson(const Eigen::VectorXd& v)
{
  Json::Value array(Json::arrayValue);
  for (Eigen::Index i = 0; i < v.size(); ++i)
  {
    array.append(v[i]);
  }
  return array;
}

void ValidateView(const XRayView& view, const Eigen::Vector3d& isocenter, const std::string& origin,
  const std::string& field)
{
  const std::string det = field + ".detector";
  for (const auto& [dir, key] : { std::make_pair(view.rowDirection, ".row_direction"),
         std::make_pair(view.columnDirection, ".column_direction") })
  {
    if (std::abs(dir.norm() - 1.0) > UnitTolerance)
    {
      throw InputError(Where(origin, det + key),
        "not a unit vector (length " + std::to_string(dir.norm()) + ")");
    }
  }
  if (std::abs(view.rowDirection.dot(view.columnDirection)) > UnitTolerance)
  {
    throw InputError(Where(origin, det + ".column_direction"), "not orthogonal to row_direction");
  }
  if (!(view.pixelSpacing.minCoeff() > 0.0))
  {
    throw InputError(Where(origin, det + ".pixel_spacing"), "must be positive");
  }
  if (view.size.minCoeff() < 1 || view.size.maxCoeff() > 16384)
  {
    throw InputError(Where(origin, det + ".size"), "must be between 1 and 16384 pixels");
  }
  if (!(view.SourceToPanelDistance() >= 1.0))
  {
    throw InputError(Where(origin, field + ".source"), "lies on the panel plane");
  }
  // The central ray (source through the isocentre) must hit the panel within its extent.
  Eigen::Vector2d pixel;
  try
  {
    pixel = view.Project(isocenter);
  }
  catch (const Error&)
  {
    throw InputError(Where(origin, field + ".source"), "the isocentre is not between source and panel");
  }
  if (pixel[0] < -0.5 || pixel[0] > view.size[0] - 0.5 || pixel[1] < -0.5 || pixel[1] > view.size[1] - 0.5)
  {
    throw InputError(Where(origin, det + ".center"), "the ray from the source through the isocentre misses the panel");
  }
}

} // namespace

const XRayView* StereoGeometry::FindView(const std::string& viewName) const
{
  for (const XRayView& view : this->views)
  {
    if (view.name == viewName)
    {
      return &view;
    }
  }
  return nullptr;
}

void ValidateGeometry(const StereoGeometry& geometry, const std::string& origin)
{
  if (geometry.views.empty())
  {
    throw InputError(Where(origin, "imagers"), "no imager defined");
  }
  std::set<std::string> names;
  for (size_t i = 0; i < geometry.views.size(); ++i)
  {
    const std::string field = "imagers[" + std::to_string(i) + "]";
    if (!names.insert(geometry.views[i].name).second)
    {
      throw InputError(Where(origin, field + ".name"), "duplicate imager name '" + geometry.views[i].name + "'");
    }
    ValidateView(geometry.views[i], geometry.isocenter, origin, field);
  }
}

void ValidateStereoGeometry(const StereoGeometry& geometry, const std::string& origin)
{
  ValidateGeometry(geometry, origin);
  if (geometry.views.size() < 2)
  {
    throw InputError(Where(origin, "imagers"), "a stereo registration needs at least two imagers, found " +
        std::to_string(geometry.views.size()));
  }
}

StereoGeometry ParseStereoGeometry(const std::string& jsonText, const std::string& origin)
{
  Json::CharReaderBuilder builder;
  builder["collectComments"] = false;
  Json::Value root;
  std::string errors;
  std::istringstream stream(jsonText);
  if (!Json::parseFromStream(builder, stream, &root, &errors))
  {
    throw InputError(origin, "not valid JSON: " + errors);
  }
  if (!root.isObject())
  {
    throw InputError(origin, "expected a JSON object at the top level");
  }
  StereoGeometry geometry;
  if (root.isMember("name"))
  {
    if (!root["name"].isString())
    {
      throw InputError(Where(origin, "name"), "expected a string");
    }
    geometry.name = root["name"].asString();
  }
  if (root.isMember("isocenter"))
  {
    geometry.isocenter = Vector<3>(root["isocenter"], origin, "isocenter");
  }
  int version = 1;
  if (root.isMember("format_version"))
  {
    const Json::Value& value = root["format_version"];
    if (!value.isInt() || value.asInt() < 1 || value.asInt() > LatestFormatVersion)
    {
      Json::StreamWriterBuilder writer;
      writer["indentation"] = "";
      throw InputError(Where(origin, "format_version"), "unknown version " + Json::writeString(writer, value) +
          ": this xpose reads versions 1 and " + std::to_string(LatestFormatVersion));
    }
    version = value.asInt();
  }
  if (root.isMember("couch"))
  {
    if (version < 2)
      throw InputError(Where(origin, "couch"), "a couch needs \"format_version\": 2 (a file without one is version 1)");
    geometry.couch = ParseCouch(root["couch"], origin);
  }
  const Json::Value& imagers = Member(root, "imagers", origin, "imagers");
  if (!imagers.isArray())
  {
    throw InputError(Where(origin, "imagers"), "expected an array");
  }
  for (Json::ArrayIndex i = 0; i < imagers.size(); ++i)
  {
    geometry.views.push_back(ParseView(imagers[i], origin, "imagers[" + std::to_string(i) + "]"));
  }
  ValidateGeometry(geometry, origin);
  // Files give directions to a few digits; make them exactly orthonormal so that projecting a
  // point and tracing a pixel's ray agree to rounding error.
  for (XRayView& view : geometry.views)
  {
    view.rowDirection.normalize();
    view.columnDirection = (view.columnDirection - view.columnDirection.dot(view.rowDirection) * view.rowDirection).normalized();
  }
  return geometry;
}

StereoGeometry ReadStereoGeometry(const std::string& path)
{
  return ParseStereoGeometry(ReadWholeFile(path), path);
}

std::string FormatStereoGeometry(const StereoGeometry& geometry)
{
  Json::Value root(Json::objectValue);
  if (geometry.couch)
    root["format_version"] = LatestFormatVersion;
  root["name"] = geometry.name;
  root["isocenter"] = ToJson(geometry.isocenter);
  Json::Value imagers(Json::arrayValue);
  for (const XRayView& view : geometry.views)
  {
    Json::Value detector(Json::objectValue);
    detector["center"] = ToJson(view.detectorCenter);
    detector["row_direction"] = ToJson(view.rowDirection);
    detector["column_direction"] = ToJson(view.columnDirection);
    detector["pixel_spacing"] = ToJson(view.pixelSpacing);
    Json::Value size(Json::arrayValue);
    size.append(view.size[0]);
    size.append(view.size[1]);
    detector["size"] = size;
    Json::Value imager(Json::objectValue);
    imager["name"] = view.name;
    imager["source"] = ToJson(view.source);
    imager["detector"] = detector;
    imagers.append(imager);
  }
  root["imagers"] = imagers;
  if (geometry.couch)
  {
    Json::Value couch(Json::objectValue);
    couch["motions"] = CouchMotionsName(geometry.couch->motions);
    if (std::isfinite(geometry.couch->pitchRollLimitDegrees))
      couch["rotation_limit_deg"] = geometry.couch->pitchRollLimitDegrees;
    if (geometry.couch->rotationCenter)
      couch["rotation_center"] = ToJson(*geometry.couch->rotationCenter);
    root["couch"] = couch;
  }
  Json::StreamWriterBuilder writer;
  writer["indentation"] = "  ";
  writer["precision"] = 17;
  return Json::writeString(writer, root) + "\n";
}

void WriteStereoGeometry(const StereoGeometry& geometry, const std::string& path)
{
  // Written beside and renamed into place: a failed write never leaves half a geometry file.
  const std::string partial = path + ".partial";
  std::ofstream file(partial);
  file << FormatStereoGeometry(geometry);
  file.close();
  if (!file || std::rename(partial.c_str(), path.c_str()) != 0)
  {
    std::remove(partial.c_str());
    throw Error(path, "cannot write the geometry file");
  }
}

} // namespace xp
