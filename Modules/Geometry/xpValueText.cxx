#include "xpValueText.h"

#include "xpError.h"

#include <cstdio>

namespace xp
{

std::pair<int, int> ParseSize(const std::string& text, const std::string& field)
{
  int columns = 0, rows = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &columns, &x, &rows, &extra) != 3 || (x != 'x' && x != 'X') ||
    columns < 1 || rows < 1 || columns > 16384 || rows > 16384)
  {
    throw InputError(field, "expected COLSxROWS such as 512x384, got '" + text + "'");
  }
  return { columns, rows };
}

Eigen::Vector2i ParseImageSize(const std::string& text, const std::string& field)
{
  const auto [columns, rows] = ParseSize(text, field);
  return { columns, rows };
}

Eigen::Vector3d ParsePoint(const std::string& text, const std::string& field)
{
  Eigen::Vector3d p;
  char c1 = 0, c2 = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%lf%c%lf%c%lf%c", &p[0], &c1, &p[1], &c2, &p[2], &extra) != 5 || c1 != ',' ||
    c2 != ',' || !p.allFinite())
  {
    throw InputError(field, "expected x,y,z in mm, got '" + text + "'");
  }
  return p;
}

std::optional<Eigen::Vector2i> ParseSizeIfGiven(const std::string& text, const std::string& field)
{
  return text.empty() ? std::nullopt : std::optional<Eigen::Vector2i>(ParseImageSize(text, field));
}

std::optional<Eigen::Vector3d> ParsePointIfGiven(const std::string& text, const std::string& field)
{
  return text.empty() ? std::nullopt : std::optional<Eigen::Vector3d>(ParsePoint(text, field));
}

std::string SizeText(const Eigen::Vector2i& size)
{
  return std::to_string(size[0]) + "x" + std::to_string(size[1]);
}

std::string PointText(const Eigen::Vector3d& point)
{
  char text[96];
  std::snprintf(text, sizeof text, "%.10g,%.10g,%.10g", point[0], point[1], point[2]);
  return text;
}

} // namespace xp
