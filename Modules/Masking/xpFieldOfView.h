/**
 * @file xpFieldOfView.h
 * @brief An image intensifier's circular field: the disc of an X-ray that holds the image.
 *
 * Image intensifiers (fluoroscopy, biplane videoradiography) show their image in a disc and
 * leave the corners black. Those corners are no anatomy: left in, they would pull the
 * similarity towards the disc's edge. The field is found from the image alone, and only when
 * it is a disc: a flat panel's dark anatomy also touches the border (a thick body on a raw
 * image), and must never be taken for one.
 */
#ifndef xpFieldOfView_h
#define xpFieldOfView_h

#include "vtkXPMaskingModule.h"

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace xp
{

struct CircularField
{
  bool found = false;
  Eigen::Vector2d center = Eigen::Vector2d::Zero(); ///< pixels (column, row), row 0 at the top
  double radius = 0.0;                              ///< pixels, the disc as it is in the image
  double mismatch = 0.0; ///< pixels where the dark surround and the disc disagree, per disc pixel
  /** 1 inside the disc less its vignetted rim (3 % of the radius), row 0 first; empty unless found. */
  std::vector<uint8_t> mask;
};

/**
 * The dark surround: pixels at most 6 % of the image's range above its minimum that connect to
 * the image's border. It is a circular field when it takes at least 5 % of the image and the
 * rest is a disc (the disc of the same area at the rest's centroid differs from it in at most
 * 2 % of its pixels).
 */
VTKXPMASKING_EXPORT CircularField FindCircularField(const std::vector<uint16_t>& image, int columns, int rows);

} // namespace xp

#endif
