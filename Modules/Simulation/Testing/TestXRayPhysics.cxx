// The physics of the X-ray simulator, one effect at a time: each test fails if its effect is
// missing, has the wrong size or the wrong sign.
#include "xpXRayPhysics.h"
#include "xpXRaySpectrum.h"

#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkSmartPointer.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>

namespace
{

/** A CT of n voxels of `spacing` mm per axis, centred on the room isocentre, HU from `hu(x, y, z)` (mm). */
vtkSmartPointer<vtkImageData> MakeCT(const Eigen::Vector3i& n, double spacing, const std::function<float(double, double, double)>& hu)
{
  auto ct = vtkSmartPointer<vtkImageData>::New();
  ct->SetDimensions(n[0], n[1], n[2]);
  ct->SetSpacing(spacing, spacing, spacing);
  ct->SetOrigin(-0.5 * spacing * (n[0] - 1), -0.5 * spacing * (n[1] - 1), -0.5 * spacing * (n[2] - 1));
  ct->AllocateScalars(VTK_FLOAT, 1);
  float* v = static_cast<float*>(ct->GetScalarPointer());
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
      {
        const double p[3] = { ct->GetOrigin()[0] + i * spacing, ct->GetOrigin()[1] + j * spacing, ct->GetOrigin()[2] + k * spacing };
        *v++ = hu(p[0], p[1], p[2]);
      }
  return ct;
}

/** Source on -X, panel on +X: rays run along Room X; columns along +Y, rows down -Z. The CT's
 *  axes are the room's (identity set-up). */
xp::XRayView SideView(int size, double pixel)
{
  xp::XRayView view;
  view.name = "side";
  view.source = Eigen::Vector3d(-1000, 0, 0);
  view.detectorCenter = Eigen::Vector3d(500, 0, 0);
  view.rowDirection = Eigen::Vector3d::UnitY();
  view.columnDirection = -Eigen::Vector3d::UnitZ();
  view.pixelSpacing = Eigen::Vector2d(pixel, pixel);
  view.size = { size, size };
  return view;
}

xp::XRayPhysicsSettings Plain()
{
  xp::XRayPhysicsSettings s;
  s.polyenergetic = false;
  s.raysPerPixel = 1;
  return s;
}

/** A water cube of `side` mm in air. */
vtkSmartPointer<vtkImageData> WaterCube(double side, double spacing = 2.0)
{
  const int n = static_cast<int>(std::lround(side / spacing)) + 4;
  return MakeCT(Eigen::Vector3i(n, n, n), spacing, [side](double x, double y, double z)
    { return std::max({ std::abs(x), std::abs(y), std::abs(z) }) < 0.5 * side ? 0.0f : -1000.0f; });
}

float CentrePixel(const std::vector<float>& image, int size)
{
  return 0.25f * (image[(size / 2) * size + size / 2] + image[(size / 2 - 1) * size + size / 2] +
    image[(size / 2) * size + size / 2 - 1] + image[(size / 2 - 1) * size + size / 2 - 1]);
}

TEST(XRaySpectrum, FiltrationHardensTheBeamAndWeightsSumToOne)
{
  xp::TubeSettings tube;
  tube.kVp = 110;
  const xp::XRaySpectrum soft = xp::KramersSpectrum(tube);
  tube.copperMM = 0.2;
  const xp::XRaySpectrum hard = xp::KramersSpectrum(tube);
  double sum = 0.0;
  for (double w : hard.weight)
  {
    sum += w;
    EXPECT_GE(w, 0.0);
  }
  EXPECT_NEAR(sum, 1.0, 1e-9);
  EXPECT_LT(hard.keV.back(), 110.0);
  EXPECT_GT(soft.MeanEnergy(), 40.0);
  EXPECT_LT(soft.MeanEnergy(), 75.0);
  EXPECT_GT(hard.MeanEnergy(), soft.MeanEnergy() + 2.0);
  tube.kVp = 30;
  EXPECT_THROW(xp::KramersSpectrum(tube), std::exception);
}

TEST(XRaySpectrum, BoneHasMoreContrastAtLowEnergy)
{
  const auto ratio = [](double keV)
  { return xp::MassAttenuation(xp::Material::CorticalBone, keV) / xp::MassAttenuation(xp::Material::Water, keV); };
  EXPECT_GT(ratio(40.0), 1.3 * ratio(100.0)) << "the photoelectric effect of calcium";
  EXPECT_NEAR(xp::MassAttenuation(xp::Material::Water, 60.0), 0.2059, 0.01) << "NIST XCOM, water at 60 keV";
  EXPECT_GT(xp::CorticalBoneHU(70.0), 800.0);
  EXPECT_LT(xp::CorticalBoneHU(70.0), 2000.0);
  // HU split: water keeps its density, bone's CT number gives pure bone.
  const std::array<float, 2> water = xp::WaterAndBone(0.0, 1000.0, 1.85);
  EXPECT_FLOAT_EQ(water[0], 1.0f);
  EXPECT_FLOAT_EQ(water[1], 0.0f);
  const std::array<float, 2> bone = xp::WaterAndBone(1000.0, 1000.0, 1.85);
  EXPECT_FLOAT_EQ(bone[0], 0.0f);
  EXPECT_FLOAT_EQ(bone[1], 1.85f);
  EXPECT_FLOAT_EQ(xp::WaterAndBone(-1000.0, 1000.0, 1.85)[0], 0.0f);
}

TEST(XRayPhysics, SiddonChordsOfAWaterCubeWithTheMisalignmentsSign)
{
  const vtkSmartPointer<vtkImageData> cube = WaterCube(80.0); // -40..40 mm
  const xp::XRayPhysicsSimulator simulator(cube, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), Plain());
  const xp::XRayView view = SideView(64, 1.0);
  // Straight through the centre: 80 mm of water = 8 g/cm^2.
  EXPECT_NEAR(simulator.ArealDensities(view, view.detectorCenter, xp::Pose{})[0], 8.0, 1e-6);
  // Aimed at the panel point whose ray crosses the cube's diagonal: 80 sqrt(2) mm through a cube
  // turned 45 degrees about Z (yaw).
  xp::Pose turned;
  turned.yaw = 45.0;
  EXPECT_NEAR(simulator.ArealDensities(view, view.detectorCenter, turned)[0], 8.0 * std::sqrt(2.0), 1e-3);
  // Lifted 30 mm, the cube still holds the central ray; lifted 50 mm it does not.
  xp::Pose lifted;
  lifted.translation = Eigen::Vector3d(0, 0, 30);
  EXPECT_NEAR(simulator.ArealDensities(view, view.detectorCenter, lifted)[0], 8.0, 1e-6);
  lifted.translation = Eigen::Vector3d(0, 0, 50);
  EXPECT_EQ(simulator.ArealDensities(view, view.detectorCenter, lifted)[0], 0.0);
  // A ray 1.5 x 45 mm up on the panel passes 45 mm up at the isocentre: above a cube lifted
  // -10 mm (top at 30), inside one lifted +10 mm (top at 50).
  const Eigen::Vector3d upper = view.detectorCenter + Eigen::Vector3d(0, 0, 67.5);
  lifted.translation = Eigen::Vector3d(0, 0, -10);
  EXPECT_EQ(simulator.ArealDensities(view, upper, lifted)[0], 0.0);
  lifted.translation = Eigen::Vector3d(0, 0, 10);
  EXPECT_GT(simulator.ArealDensities(view, upper, lifted)[0], 7.0);
}

/** Effective attenuation (1/mm) of a water cube of `side` mm on the central ray. */
double EffectiveMu(double side, bool polyenergetic)
{
  xp::XRayPhysicsSettings settings = Plain();
  settings.polyenergetic = polyenergetic;
  const xp::XRayPhysicsSimulator simulator(WaterCube(side, 4.0), Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  const xp::XRayView view = SideView(8, 1.0);
  return -std::log(CentrePixel(simulator.Render(view, xp::Pose{}).primary, 8)) / side;
}

TEST(XRayPhysics, BeamHardeningLowersTheEffectiveMuWithThickness)
{
  const double thin = EffectiveMu(40.0, true), thick = EffectiveMu(240.0, true);
  EXPECT_LT(thick, 0.93 * thin) << "a polyenergetic beam hardens";
  EXPECT_GT(thick, 0.015);
  const double monoThin = EffectiveMu(40.0, false), monoThick = EffectiveMu(240.0, false);
  EXPECT_NEAR(monoThick / monoThin, 1.0, 1e-3) << "one energy: Beer-Lambert";
}

TEST(XRayPhysics, ScatterAddsTheStatedFractionAsASmoothComponent)
{
  // 200 mm of water along the rays, wider than the field.
  const vtkSmartPointer<vtkImageData> slab = MakeCT(Eigen::Vector3i(104, 60, 60), 2.0,
    [](double x, double, double) { return std::abs(x) < 100.0 ? 0.0f : -1000.0f; });
  xp::XRayPhysicsSettings settings = Plain();
  settings.scatterToPrimary = 0.4;
  settings.scatterSigmaMM = 10.0;
  const xp::XRayPhysicsSimulator simulator(slab, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  const int size = 48;
  const xp::XRayComponents c = simulator.Render(SideView(size, 2.0), xp::Pose{});
  const double ratio = CentrePixel(c.scatter, size) / CentrePixel(c.primary, size);
  EXPECT_NEAR(ratio, 0.4, 0.01) << "SPR behind 200 mm of water";
  EXPECT_NEAR(CentrePixel(c.signal, size), CentrePixel(c.primary, size) * 1.4, 1e-4);
  float steepest = 0.0f;
  for (int r = 0; r < size; ++r)
    for (int col = 1; col < size; ++col)
      steepest = std::max(steepest, std::abs(c.scatter[r * size + col] - c.scatter[r * size + col - 1]));
  EXPECT_LT(steepest, 0.02f * CentrePixel(c.scatter, size)) << "scatter is smooth";
}

TEST(XRayPhysics, DetectorBlurSpreadsAnEdgeByItsSigma)
{
  // A 4 mm slab of bone-like water in the upper half (Z > 0): a sharp edge on the central row.
  const vtkSmartPointer<vtkImageData> edge = MakeCT(Eigen::Vector3i(4, 40, 80), 1.0,
    [](double, double, double z) { return z > 0.0 ? 3000.0f : -1000.0f; });
  xp::XRayPhysicsSettings settings = Plain();
  settings.raysPerPixel = 4;
  settings.blurSigmaMM = 1.0;
  const xp::XRayPhysicsSimulator simulator(edge, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  const int size = 64;
  const xp::XRayComponents c = simulator.Render(SideView(size, 0.25), xp::Pose{});
  // Down the middle column: bright below (rows > 32), dark above.
  std::vector<double> profile;
  for (int r = 0; r < size; ++r)
    profile.push_back(c.signal[r * size + size / 2]);
  const double dark = profile.front(), bright = profile.back();
  ASSERT_LT(dark, 0.9 * bright);
  const auto crossing = [&](double level)
  {
    for (int r = 1; r < size; ++r)
      if (profile[r] >= level && profile[r - 1] < level)
        return r - 1 + (level - profile[r - 1]) / (profile[r] - profile[r - 1]);
    return -1.0;
  };
  const double width = (crossing(dark + 0.9 * (bright - dark)) - crossing(dark + 0.1 * (bright - dark))) * 0.25;
  EXPECT_NEAR(width, 2.563 * 1.0, 0.3) << "10-90 % width of a Gaussian edge = 2.563 sigma";
}

TEST(XRayPhysics, QuantumNoiseIsPoissonAndTheHeelTiltsTheOpenField)
{
  xp::XRayPhysicsSettings settings = Plain();
  settings.quantaPerMM2 = 1000.0;
  settings.heel = 0.2;
  const xp::XRayPhysicsSimulator simulator(WaterCube(20.0), Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  const int size = 128;
  const xp::XRayView view = SideView(size, 1.0);
  xp::Pose away; // the cube far out of the field: an open field
  away.translation = Eigen::Vector3d(0, 400, 0);
  const xp::XRayComponents clean = simulator.Render(view, away);
  EXPECT_NEAR(clean.signal.front(), 1.0 + 0.2 * (0.5 - 0.5 / size), 1e-4) << "first row: the cathode side";
  EXPECT_NEAR(clean.signal.back(), 1.0 + 0.2 * (0.5 - (size - 0.5) / size), 1e-4) << "last row: the anode side";
  std::mt19937 random(3);
  const std::vector<uint16_t> image = simulator.Simulate(view, away, random);
  // Rows near the centre (heel about 1): variance of a count of 1000 quanta per pixel.
  double sum = 0.0, squares = 0.0;
  int n = 0;
  for (int r = size / 2 - 4; r < size / 2 + 4; ++r)
    for (int col = 0; col < size; ++col)
    {
      const double v = image[r * size + col] / xp::RawOpenField;
      sum += v, squares += v * v, ++n;
    }
  const double mean = sum / n, variance = squares / n - mean * mean;
  EXPECT_NEAR(mean, 1.0, 0.01);
  EXPECT_NEAR(variance, 1.0 / 1000.0, 0.15 / 1000.0);
}

TEST(XRayPhysics, TheCouchAttenuatesOnlyTheRaysThatCrossIt)
{
  const vtkSmartPointer<vtkImageData> cube = WaterCube(40.0); // lowest matter at Z = -20 mm
  xp::XRayPhysicsSettings settings = Plain();
  settings.couch = true;
  const xp::XRayPhysicsSimulator withCouch(cube, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  EXPECT_NEAR(withCouch.CouchTopZ(), -20.0, 1e-9) << "1 mm under the lowest voxel centre (-19 mm)";
  settings.couch = false;
  const xp::XRayPhysicsSimulator without(cube, Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  const int size = 128;
  const xp::XRayView view = SideView(size, 1.0); // 1 mm pixels = 0.67 mm at the isocentre
  const std::vector<float> a = withCouch.Render(view, xp::Pose{}).primary, b = without.Render(view, xp::Pose{}).primary;
  // Row r looks at Z = (63.5 - r) / 1.5 at the isocentre.
  EXPECT_FLOAT_EQ(a[20 * size + 64], b[20 * size + 64]) << "above the couch";
  // Row 95 passes 21 mm under the isocentre, nearly along the top skin: 70 mm of carbon.
  EXPECT_FLOAT_EQ(b[95 * size + 64], 1.0f);
  EXPECT_LT(a[95 * size + 64], 0.5f) << "grazing the couch's carbon skin";
}

TEST(XRayPhysics, LogOutputShowsBoneBrightAndSettingsAreChecked)
{
  xp::XRayPhysicsSettings settings = Plain();
  settings.logOutput = true;
  const xp::XRayPhysicsSimulator simulator(WaterCube(40.0), Eigen::Isometry3d::Identity(), Eigen::Vector3d::Zero(), settings);
  std::mt19937 random(1);
  const int size = 32;
  const std::vector<uint16_t> image = simulator.Simulate(SideView(size, 2.0), xp::Pose{}, random);
  EXPECT_EQ(image[0], 0) << "open field: -ln 1 = 0";
  const double expected = 4095.0 * 40.0 * 0.1 * xp::MassAttenuation(xp::Material::Water, simulator.Spectrum().MeanEnergy()) / xp::LogFullScale;
  EXPECT_NEAR(image[(size / 2) * size + size / 2], expected, 2.0);
  xp::XRayPhysicsSettings bad = Plain();
  bad.heel = -0.1;
  EXPECT_THROW(bad.Validate(), std::exception);
  bad = Plain();
  bad.raysPerPixel = 0;
  EXPECT_THROW(bad.Validate(), std::exception);
  EXPECT_NO_THROW(xp::XRayPhysicsSettings::Clinical().Validate());
}

} // namespace
