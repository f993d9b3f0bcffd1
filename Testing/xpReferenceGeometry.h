// The reference stereo geometry of Coordinates.md, built in code so tests need no file; shared by
// the tests of every module.
#ifndef xpReferenceGeometry_h
#define xpReferenceGeometry_h

#include "xpStereoGeometry.h"

namespace xp::testing
{

inline StereoGeometry ReferenceStereoGeometry()
{
  const double s = 0.707107, d = 707.107, h = 353.553;
  XRayView a;
  a.name = "A";
  a.source = { -d, 0, -d };
  a.detectorCenter = { h, 0, h };
  a.rowDirection = { -s, 0, s };
  a.columnDirection = { 0, -1, 0 };
  a.pixelSpacing = { 0.390625, 0.390625 };
  a.size = { 1024, 768 };
  XRayView b = a;
  b.name = "B";
  b.source = { d, 0, -d };
  b.detectorCenter = { -h, 0, h };
  b.rowDirection = { -s, 0, -s };
  StereoGeometry g;
  g.name = "stereo-oblique-90";
  g.views = { a, b };
  return g;
}

/** The reference views, resampled to columns x rows on the same panels. */
inline std::vector<XRayView> ReferenceViews(int columns, int rows)
{
  std::vector<XRayView> views;
  for (const XRayView& view : ReferenceStereoGeometry().views)
    views.push_back(view.Resampled(columns, rows));
  return views;
}

} // namespace xp::testing

#endif
