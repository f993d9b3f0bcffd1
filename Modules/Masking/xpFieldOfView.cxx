#include "xpFieldOfView.h"

#include <algorithm>
#include <cmath>

namespace xp
{

CircularField FindCircularField(const std::vector<uint16_t>& image, int columns, int rows)
{
  CircularField field;
  const size_t count = static_cast<size_t>(columns) * rows;
  if (columns < 16 || rows < 16 || image.size() != count)
    return field;
  const auto [low, high] = std::minmax_element(image.begin(), image.end());
  const double dark = *low + 0.06 * (*high - *low);
  // The dark surround: a flood from every dark border pixel (an explicit stack, no recursion).
  std::vector<uint8_t> surround(count, 0);
  std::vector<int> stack;
  const auto push = [&](int c, int r)
  {
    const size_t i = static_cast<size_t>(r) * columns + c;
    if (!surround[i] && image[i] <= dark)
    {
      surround[i] = 1;
      stack.push_back(static_cast<int>(i));
    }
  };
  for (int c = 0; c < columns; ++c)
    push(c, 0), push(c, rows - 1);
  for (int r = 0; r < rows; ++r)
    push(0, r), push(columns - 1, r);
  while (!stack.empty())
  {
    const int i = stack.back();
    stack.pop_back();
    const int c = i % columns, r = i / columns;
    if (c > 0)
      push(c - 1, r);
    if (c + 1 < columns)
      push(c + 1, r);
    if (r > 0)
      push(c, r - 1);
    if (r + 1 < rows)
      push(c, r + 1);
  }
  double inside = 0.0;
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      if (!surround[static_cast<size_t>(r) * columns + c])
      {
        inside += 1.0;
        sum += Eigen::Vector2d(c, r);
      }
  if (inside > 0.95 * count || inside < 0.05 * count)
    return field; // no surround to speak of, or nothing but
  field.center = sum / inside;
  field.radius = std::sqrt(inside / M_PI);
  long long disagree = 0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
    {
      const bool inDisc = (Eigen::Vector2d(c, r) - field.center).squaredNorm() <= field.radius * field.radius;
      disagree += inDisc == static_cast<bool>(surround[static_cast<size_t>(r) * columns + c]);
    }
  field.mismatch = disagree / inside;
  if (!(field.mismatch <= 0.02))
    return field;
  field.found = true;
  field.mask.assign(count, 0);
  const double kept = 0.97 * field.radius;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < columns; ++c)
      field.mask[static_cast<size_t>(r) * columns + c] = (Eigen::Vector2d(c, r) - field.center).squaredNorm() <= kept * kept;
  return field;
}

} // namespace xp
