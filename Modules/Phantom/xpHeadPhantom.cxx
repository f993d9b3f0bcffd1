#include "xpHeadPhantom.h"

#include "xpError.h"

#include <vtkSMPTools.h>

#include <cmath>

namespace xp
{

namespace
{

using Eigen::Vector3d;

// Field of view (LPS mm): x left, y posterior, z superior.
const Vector3d FieldLow(-104.0, -104.0, -150.0);
const Vector3d FieldHigh(104.0, 124.0, 104.0);

/** Normalised ellipsoid radius: < 1 inside. */
double Ellipsoid(const Vector3d& p, const Vector3d& centre, const Vector3d& radii)
{
  return ((p - centre).array() / radii.array()).matrix().norm();
}

double Head(const Vector3d& p)
{
  const Vector3d centre(0, 0, 0), skin(74, 92, 98);
  const double r = Ellipsoid(p, centre, skin);
  const double x = p[0], y = p[1], z = p[2];

  // Fixation objects first (they sit outside the patient).
  const double axial = std::hypot(x, y - 8.0);
  if (y > 40.0 && axial > 99.0 && axial < 105.0 && z > -140.0 && z < 70.0)
    return 250.0; // carbon-fibre head rest: a cradle under the back of the head
  if (y > 112.0 && y < 122.0 && std::abs(x) < 103.0)
    return 180.0; // couch top
  if (std::hypot(std::abs(x) - 88.0, y + 10.0) < 4.0 && z > -130.0 && z < 80.0)
    return 1400.0; // mask frame rods, left and right
  if (y < 0.0 && r > 1.035 && r < 1.06 && z > -110.0)
    return 120.0; // thermoplastic mask over the face

  // Neck and cervical spine below the skull.
  if (z < -60.0)
  {
    if (z < -145.0)
      return -1000.0;
    const double neck = std::hypot(x / 52.0, (y - 12.0) / 58.0);
    if (neck > 1.0)
      return -1000.0;
    if (std::hypot(x, y - 22.0) < 13.0)
      return std::fmod(-z, 17.0) < 3.0 ? 80.0 : 750.0; // vertebral bodies and discs
    if (std::hypot(x, y - 44.0) < 7.0 && std::fmod(-z, 17.0) > 5.0)
      return 900.0; // spinous processes
    if (std::hypot(x, y + 20.0) < 8.0)
      return -1000.0; // airway
    return 40.0;
  }
  if (r > 1.0)
    return -1000.0;

  // Face: nasal cavity, sinuses, jaw and teeth (anterior, below the brain).
  if (y < -20.0 && z < 10.0)
  {
    const double arch = std::hypot(x, (y + 10.0) * 1.1);
    if (z > -62.0 && z < -48.0 && arch > 46.0 && arch < 54.0 && y < -30.0)
      return std::fmod(std::atan2(x, -(y + 10.0)) * 45.0 / M_PI + 100.0, 4.0) < 3.0 ? 2800.0 : 200.0; // teeth
    if (z > -78.0 && z < -62.0 && arch > 44.0 && arch < 58.0)
      return 1300.0; // mandible body
    if (z > -48.0 && z < -38.0 && arch < 54.0)
      return 900.0; // maxilla and hard palate
    if (std::abs(x) < 9.0 && y < -45.0 && z > -38.0 && z < 0.0)
      return -1000.0; // nasal cavity
    if (Ellipsoid(Vector3d(std::abs(x), y, z), Vector3d(26, -48, -22), Vector3d(13, 16, 15)) < 1.0)
      return -1000.0; // maxillary sinuses
  }
  if (std::abs(std::abs(x) - 50.0) < 5.0 && y > -20.0 && y < 12.0 && z > -78.0 && z < -25.0)
    return 1200.0; // mandible rami
  if (Ellipsoid(p, Vector3d(0, -72, 36), Vector3d(16, 8, 11)) < 1.0)
    return -1000.0; // frontal sinus
  if (Ellipsoid(Vector3d(std::abs(x), y, z), Vector3d(33, -66, 8), Vector3d(13, 13, 13)) < 1.0)
    return 15.0; // eyes
  if (Ellipsoid(Vector3d(std::abs(x), y, z), Vector3d(36, 12, -26), Vector3d(20, 9, 9)) < 1.0)
    return 1600.0; // petrous bones

  // Scalp, skull (cortical tables around diploe) and brain.
  if (r > 0.94)
    return 30.0;
  if (r > 0.86)
    return (r > 0.925 || r < 0.875) ? 1500.0 : 650.0;
  if (z < -25.0)
    return (z < -32.0) ? 1100.0 : 40.0; // skull base
  if (Ellipsoid(Vector3d(std::abs(x), y, z), Vector3d(9, 5, 22), Vector3d(5, 24, 10)) < 1.0)
    return 5.0; // lateral ventricles
  return 32.0 + 8.0 * std::sin(x * 0.21) * std::sin(y * 0.17) * std::sin(z * 0.19); // grey/white texture
}

} // namespace

double HeadPhantomHU(const Eigen::Vector3d& lps)
{
  return Head(lps);
}

CTVolumeData MakeHeadPhantom(double spacing)
{
  if (!(spacing >= 0.25 && spacing <= 10.0))
  {
    throw InputError("--spacing", "phantom voxel spacing must be between 0.25 and 10 mm");
  }
  CTVolumeData volume;
  const Vector3d extent = FieldHigh - FieldLow;
  for (int a = 0; a < 3; ++a)
  {
    volume.dimensions[a] = static_cast<int>(std::floor(extent[a] / spacing)) + 1;
  }
  volume.spacing = Vector3d::Constant(spacing);
  // Centre the grid on the field so that the volume centre is where FieldLow/High put it.
  volume.origin = 0.5 * (FieldLow + FieldHigh) - 0.5 * spacing * (volume.dimensions.cast<double>() - Vector3d::Ones());
  volume.direction = Eigen::Matrix3d::Identity();
  const Eigen::Vector3i& d = volume.dimensions;
  volume.hounsfield.resize(static_cast<size_t>(d.prod()));
  vtkSMPTools::For(0, d[2],
    [&](int k0, int k1)
    {
      for (int k = k0; k < k1; ++k)
        for (int j = 0; j < d[1]; ++j)
          for (int i = 0; i < d[0]; ++i)
          {
            const Vector3d p = volume.origin + spacing * Vector3d(i, j, k);
            volume.hounsfield[(static_cast<size_t>(k) * d[1] + j) * d[0] + i] = static_cast<float>(Head(p));
          }
    });
  return volume;
}

} // namespace xp
