// The reference stereo geometry of GEOMETRY.md, built in code so tests need no file.
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

} // namespace xp::testing

#endif
