#include "xpXRayPhysics.h"

#include "xpDetector.h"

#include "xpBodyMask.h"
#include "xpError.h"
#include "xpImageGeometry.h"

#include <vtkDataArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace xp
{

namespace
{

/** A CT scanner's effective energy at 120 kV: the energy at which its HU are taken as exact. */
constexpr double CTEffectiveKeV = 70.0;

/** The couch: a 50 mm carbon-fibre sandwich, 530 mm wide, fixed in the room (Room X, Z). */
constexpr double CouchHalfWidth = 265.0, CouchThickness = 50.0, CouchSkin = 1.5;
constexpr double CarbonDensity = 1.6, FoamDensity = 0.05; // g/cm^3

/** Length (mm) of the segment from `a` to `b` inside the box lo..hi (Room X and Z only). */
double LengthInSlab(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double xLow, double xHigh, double zLow, double zHigh)
{
  const Eigen::Vector3d d = b - a;
  double t0 = 0.0, t1 = 1.0;
  const double low[2] = { xLow, zLow }, high[2] = { xHigh, zHigh };
  const int axes[2] = { 0, 2 };
  for (int k = 0; k < 2; ++k)
  {
    const int axis = axes[k];
    if (std::abs(d[axis]) < 1e-12)
    {
      if (a[axis] < low[k] || a[axis] > high[k])
        return 0.0;
      continue;
    }
    double ta = (low[k] - a[axis]) / d[axis], tb = (high[k] - a[axis]) / d[axis];
    if (ta > tb)
      std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  return t1 > t0 ? (t1 - t0) * d.norm() : 0.0;
}

} // namespace

XRayPhysicsSettings XRayPhysicsSettings::Clinical()
{
  XRayPhysicsSettings s;
  s.tube.kVp = 110.0;
  s.tube.aluminiumMM = 2.5;
  s.tube.copperMM = 0.1;
  s.polyenergetic = true;
  s.raysPerPixel = 2;
  s.removeTable = true;
  s.couch = true;
  s.scatterToPrimary = 0.5; // a pelvis behind a grid: 0.3 to 1 in the literature
  s.scatterSigmaMM = 30.0;
  s.blurSigmaMM = 0.4;      // CsI flat panels: MTF 50 % near 1.2 lp/mm
  // Open-field quanta of a pelvis exposure (about 100 kV, 20 mAs at 1.5 m: some 70 uGy in air);
  // behind 300 mm of tissue a 0.8 mm pixel still counts a few thousand.
  s.quantaPerMM2 = 2e6;
  s.electronicNoise = 5e-6; // a 16-bit panel's read-out noise
  s.heel = 0.1;
  s.logOutput = true;       // as a panel's processed (for presentation) image
  return s;
}

void XRayPhysicsSettings::Validate() const
{
  const auto check = [](double value, double low, double high, const char* field)
  {
    if (!(value >= low && value <= high))
      throw InputError(field, "must be between " + std::to_string(low) + " and " + std::to_string(high));
  };
  KramersSpectrum(this->tube); // checks the tube
  check(this->raysPerPixel, 1, 8, "rays per pixel (per side)");
  check(this->scatterToPrimary, 0.0, 10.0, "scatter-to-primary ratio");
  check(this->scatterSigmaMM, 1.0, 500.0, "scatter spread (mm)");
  check(this->blurSigmaMM, 0.0, 10.0, "detector blur (mm)");
  check(this->quantaPerMM2, 0.0, 1e9, "quanta per mm^2");
  check(this->electronicNoise, 0.0, 0.1, "electronic noise (fraction of the open field)");
  check(this->heel, 0.0, 0.5, "heel effect");
}

std::string XRayPhysicsSettings::Describe() const
{
  std::ostringstream text;
  text << "{ \"kVp\": " << tube.kVp << ", \"aluminium_mm\": " << tube.aluminiumMM << ", \"copper_mm\": " << tube.copperMM
       << ", \"polyenergetic\": " << (polyenergetic ? "true" : "false") << ", \"rays_per_pixel\": " << raysPerPixel
       << ", \"remove_table\": " << (removeTable ? "true" : "false") << ", \"couch\": " << (couch ? "true" : "false")
       << ", \"scatter_to_primary\": " << scatterToPrimary << ", \"scatter_sigma_mm\": " << scatterSigmaMM
       << ", \"blur_sigma_mm\": " << blurSigmaMM << ", \"quanta_per_mm2\": " << quantaPerMM2
       << ", \"electronic_noise\": " << electronicNoise << ", \"heel\": " << heel
       << ", \"output\": \"" << (logOutput ? "log" : "transmission") << "\" }";
  return text.str();
}

const std::vector<std::string>& PhysicsEffects()
{
  static const std::vector<std::string> effects{ "spectrum", "pixel-area", "table", "couch", "scatter", "blur",
    "quantum-noise", "electronic-noise", "heel", "log" };
  return effects;
}

void SwitchOff(XRayPhysicsSettings& s, const std::string& effect, const std::string& option)
{
  if (effect == "spectrum")
    s.polyenergetic = false;
  else if (effect == "pixel-area")
    s.raysPerPixel = 1;
  else if (effect == "table")
    s.removeTable = false;
  else if (effect == "couch")
    s.couch = false;
  else if (effect == "scatter")
    s.scatterToPrimary = 0.0;
  else if (effect == "blur")
    s.blurSigmaMM = 0.0;
  else if (effect == "quantum-noise")
    s.quantaPerMM2 = 0.0;
  else if (effect == "electronic-noise")
    s.electronicNoise = 0.0;
  else if (effect == "heel")
    s.heel = 0.0;
  else if (effect == "log")
    s.logOutput = false;
  else
  {
    std::string known;
    for (const std::string& name : PhysicsEffects())
      known += (known.empty() ? "" : ", ") + name;
    throw InputError(option, "unknown effect '" + effect + "'; expected one of " + known);
  }
}

double CorticalBoneHU(double keV)
{
  const double bone = MassAttenuation(Material::CorticalBone, keV) * Density(Material::CorticalBone);
  const double water = MassAttenuation(Material::Water, keV) * Density(Material::Water);
  return 1000.0 * (bone / water - 1.0);
}

std::array<float, 2> WaterAndBone(double hu, double boneHU, double boneDensity)
{
  if (hu <= 0.0)
    return { static_cast<float>(std::max(0.0, 1.0 + hu / 1000.0)), 0.0f };
  // Above water, the volume fraction f of bone: HU = f * boneHU. Denser than cortical bone
  // (f > 1) keeps the bone and no water.
  const double f = hu / boneHU;
  return { static_cast<float>(std::max(0.0, 1.0 - f)), static_cast<float>(f * boneDensity) };
}

XRayPhysicsSimulator::XRayPhysicsSimulator(vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& roomIsocenter, const XRayPhysicsSettings& settings)
  : Options(settings)
  , Planned(plannedCTToRoom)
  , Isocenter(roomIsocenter)
{
  settings.Validate();
  vtkDataArray* scalars = ct ? ct->GetPointData()->GetScalars() : nullptr;
  if (!scalars || scalars->GetNumberOfComponents() != 1 || ct->GetNumberOfPoints() == 0)
  {
    throw InputError("CT", "needs one scalar component in HU");
  }
  // The spectrum and, per energy, each material's attenuation.
  const XRaySpectrum full = KramersSpectrum(settings.tube);
  if (settings.polyenergetic)
    this->Energies = full;
  else
    this->Energies.keV = { full.MeanEnergy() }, this->Energies.weight = { 1.0 };
  for (double e : this->Energies.keV)
    this->MassMu.push_back({ static_cast<float>(MassAttenuation(Material::Water, e)),
      static_cast<float>(MassAttenuation(Material::CorticalBone, e)),
      static_cast<float>(MassAttenuation(Material::Carbon, e)), static_cast<float>(MassAttenuation(Material::Polystyrene, e)) });
  this->WaterMuPerMM = 0.1 * MassAttenuation(Material::Water, full.MeanEnergy());

  // Voxels as water and bone densities; the table (and what else lies apart from the body) out.
  int dims[3];
  ct->GetDimensions(dims);
  this->Dims = Eigen::Vector3i(dims[0], dims[1], dims[2]);
  const size_t count = static_cast<size_t>(scalars->GetNumberOfTuples());
  std::vector<float> hu(count);
  for (size_t i = 0; i < count; ++i)
  {
    hu[i] = static_cast<float>(scalars->GetTuple1(static_cast<vtkIdType>(i)));
    if (!std::isfinite(hu[i]))
      throw InputError("CT", "holds a value that is not a finite number");
  }
  if (settings.removeTable)
    ClearOutsideBody(hu.data(), SegmentBody(hu.data(), this->Dims));
  const double boneHU = CorticalBoneHU(CTEffectiveKeV), boneDensity = Density(Material::CorticalBone);
  this->Densities.resize(count);
  Eigen::Vector3i low = this->Dims, high(-1, -1, -1);
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const size_t n = (static_cast<size_t>(k) * dims[1] + j) * dims[0] + i;
        this->Densities[n] = WaterAndBone(hu[n], boneHU, boneDensity);
        if (this->Densities[n][0] > 0.0f || this->Densities[n][1] > 0.0f)
        {
          low = low.cwiseMin(Eigen::Vector3i(i, j, k));
          high = high.cwiseMax(Eigen::Vector3i(i, j, k));
        }
      }
  if (high[0] < 0)
  {
    throw InputError("CT", "holds no matter (every voxel is air)");
  }
  this->BoxLow = low.cast<double>();
  this->BoxHigh = high.cast<double>() + Eigen::Vector3d::Ones();
  // Voxel centre i sits at corner coordinate i + 0.5.
  this->PhysicalToCorner = Eigen::Translation3d(0.5, 0.5, 0.5) * IndexToPhysical(ct).inverse();

  // The couch top just under the lowest matter at the planned pose.
  const Eigen::Affine3d indexToRoom = plannedCTToRoom * IndexToPhysical(ct);
  double lowest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const std::array<float, 2>& d = this->Densities[(static_cast<size_t>(k) * dims[1] + j) * dims[0] + i];
        if (d[0] > 0.5f || d[1] > 0.0f)
          lowest = std::min(lowest, (indexToRoom * Eigen::Vector3d(i, j, k)).z());
      }
  this->CouchTop = lowest - 1.0;
}

std::array<double, 2> XRayPhysicsSimulator::ArealDensities(
  const XRayView& view, const Eigen::Vector3d& panelPoint, const Pose& misalignment) const
{
  const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(this->Planned, misalignment, this->Isocenter);
  const Eigen::Affine3d roomToCorner = this->PhysicalToCorner * ctToRoom.inverse();
  const Eigen::Vector3d p0 = roomToCorner * view.source, p1 = roomToCorner * panelPoint;
  const Eigen::Vector3d d = p1 - p0;
  const double lengthMM = (panelPoint - view.source).norm();
  // Siddon: the parameter range inside the box of matter, then one voxel crossing at a time.
  double a0 = 0.0, a1 = 1.0;
  for (int axis = 0; axis < 3; ++axis)
  {
    if (std::abs(d[axis]) < 1e-12)
    {
      if (p0[axis] < this->BoxLow[axis] || p0[axis] >= this->BoxHigh[axis])
        return { 0.0, 0.0 };
      continue;
    }
    double ta = (this->BoxLow[axis] - p0[axis]) / d[axis], tb = (this->BoxHigh[axis] - p0[axis]) / d[axis];
    if (ta > tb)
      std::swap(ta, tb);
    a0 = std::max(a0, ta);
    a1 = std::min(a1, tb);
  }
  if (!(a1 > a0))
    return { 0.0, 0.0 };
  Eigen::Vector3i voxel, step;
  Eigen::Vector3d next, delta;
  // The first voxel: the one holding the point just after the entry (clamped into the box).
  const Eigen::Vector3d entry = p0 + (a0 + 1e-9 * (a1 - a0)) * d;
  for (int axis = 0; axis < 3; ++axis)
  {
    voxel[axis] = std::clamp(static_cast<int>(std::floor(entry[axis])), static_cast<int>(this->BoxLow[axis]),
      static_cast<int>(this->BoxHigh[axis]) - 1);
    if (d[axis] > 1e-12)
      step[axis] = 1, next[axis] = (voxel[axis] + 1 - p0[axis]) / d[axis], delta[axis] = 1.0 / d[axis];
    else if (d[axis] < -1e-12)
      step[axis] = -1, next[axis] = (voxel[axis] - p0[axis]) / d[axis], delta[axis] = -1.0 / d[axis];
    else
      step[axis] = 0, next[axis] = std::numeric_limits<double>::infinity(), delta[axis] = 0.0;
  }
  const size_t strideY = static_cast<size_t>(this->Dims[0]), strideZ = strideY * this->Dims[1];
  double water = 0.0, bone = 0.0, alpha = a0;
  const int maximumSteps = this->Dims.sum() + 3;
  for (int n = 0; n < maximumSteps && alpha < a1; ++n)
  {
    int axis = next[0] < next[1] ? 0 : 1;
    if (next[2] < next[axis])
      axis = 2;
    const double until = std::min(next[axis], a1);
    const std::array<float, 2>& rho = this->Densities[voxel[2] * strideZ + voxel[1] * strideY + voxel[0]];
    water += (until - alpha) * rho[0];
    bone += (until - alpha) * rho[1];
    alpha = until;
    voxel[axis] += step[axis];
    next[axis] += delta[axis];
    if (voxel[axis] < this->BoxLow[axis] || voxel[axis] >= this->BoxHigh[axis])
      break;
  }
  // parameter x length (mm) x density (g/cm^3) / 10 = g/cm^2
  return { water * lengthMM * 0.1, bone * lengthMM * 0.1 };
}

XRayComponents XRayPhysicsSimulator::RenderPrimary(const XRayView& view, const Pose& misalignment) const
{
  const int columns = view.Columns(), rows = view.Rows(), k = this->Options.raysPerPixel;
  XRayComponents out;
  out.primary.assign(static_cast<size_t>(columns) * rows, 0.0f);
  const size_t energies = this->Energies.keV.size();
  const double couchLow = this->CouchTop - CouchThickness;
  vtkSMPTools::For(0, rows, [&](int firstRow, int lastRow)
    {
      for (int row = firstRow; row < lastRow; ++row)
        for (int column = 0; column < columns; ++column)
        {
          double sum = 0.0;
          for (int sy = 0; sy < k; ++sy)
            for (int sx = 0; sx < k; ++sx)
            {
              const Eigen::Vector3d point = view.PixelCenter(column + (sx + 0.5) / k - 0.5, row + (sy + 0.5) / k - 0.5);
              const std::array<double, 2> tissue = this->ArealDensities(view, point, misalignment);
              double carbon = 0.0, foam = 0.0;
              if (this->Options.couch)
              {
                const double whole = LengthInSlab(view.source, point, -CouchHalfWidth, CouchHalfWidth, couchLow, this->CouchTop);
                const double core = LengthInSlab(view.source, point, -CouchHalfWidth, CouchHalfWidth, couchLow + CouchSkin,
                  this->CouchTop - CouchSkin);
                carbon = 0.1 * CarbonDensity * (whole - core);
                foam = 0.1 * FoamDensity * core;
              }
              double transmitted = 0.0;
              for (size_t e = 0; e < energies; ++e)
              {
                const std::array<float, 4>& mu = this->MassMu[e];
                transmitted += this->Energies.weight[e] *
                  std::exp(-(mu[0] * tissue[0] + mu[1] * tissue[1] + mu[2] * carbon + mu[3] * foam));
              }
              sum += transmitted;
            }
          out.primary[static_cast<size_t>(row) * columns + column] = static_cast<float>(sum / (k * k));
        }
    });
  return out;
}

void XRayPhysicsSimulator::Finish(const XRayView& view, XRayComponents& c, std::mt19937* random) const
{
  const int columns = view.Columns(), rows = view.Rows();
  const size_t count = c.primary.size();
  // Scatter: each pixel's primary times the SPR of its water-equivalent thickness, spread wide.
  c.scatter.assign(count, 0.0f);
  if (this->Options.scatterToPrimary > 0.0)
  {
    for (size_t i = 0; i < count; ++i)
    {
      const double thickness = -std::log(std::max(c.primary[i], 1e-12f)) / this->WaterMuPerMM;
      c.scatter[i] = static_cast<float>(c.primary[i] * this->Options.scatterToPrimary * thickness / 200.0);
    }
    GaussianBlur(c.scatter, columns, rows, this->Options.scatterSigmaMM / view.pixelSpacing[0]);
  }
  c.signal.resize(count);
  for (int row = 0; row < rows; ++row)
  {
    const double heel = 1.0 + this->Options.heel * (0.5 - (row + 0.5) / rows);
    for (int column = 0; column < columns; ++column)
    {
      const size_t i = static_cast<size_t>(row) * columns + column;
      c.signal[i] = static_cast<float>((c.primary[i] + c.scatter[i]) * heel);
    }
  }
  // Quantum noise is drawn before the scintillator spreads the light: the PSF correlates it.
  if (random && this->Options.quantaPerMM2 > 0.0)
  {
    const double quanta = this->Options.quantaPerMM2 * view.pixelSpacing[0] * view.pixelSpacing[1];
    for (float& s : c.signal)
    {
      std::poisson_distribution<long long> counts(std::max(0.0, s * quanta));
      s = static_cast<float>(counts(*random) / quanta);
    }
  }
  GaussianBlur(c.signal, columns, rows, this->Options.blurSigmaMM / view.pixelSpacing[0]);
}

XRayComponents XRayPhysicsSimulator::Render(const XRayView& view, const Pose& misalignment) const
{
  XRayComponents c = this->RenderPrimary(view, misalignment);
  this->Finish(view, c, nullptr);
  return c;
}

std::vector<uint16_t> XRayPhysicsSimulator::Simulate(const XRayView& view, const Pose& misalignment, std::mt19937& random) const
{
  XRayComponents c = this->RenderPrimary(view, misalignment);
  this->Finish(view, c, &random);
  std::normal_distribution<double> electronic(0.0, std::max(this->Options.electronicNoise, 1e-12));
  std::vector<uint16_t> image(c.signal.size());
  for (size_t i = 0; i < image.size(); ++i)
  {
    double raw = RawOpenField * c.signal[i];
    if (this->Options.electronicNoise > 0.0)
      raw += RawOpenField * electronic(random);
    double grey = raw;
    if (this->Options.logOutput)
      grey = 4095.0 * -std::log(std::max(raw / RawOpenField, 1e-9)) / LogFullScale;
    image[i] = static_cast<uint16_t>(std::clamp(std::lround(grey), 0L, 4095L));
  }
  return image;
}

} // namespace xp
