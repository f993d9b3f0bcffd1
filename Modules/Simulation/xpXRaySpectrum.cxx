#include "xpXRaySpectrum.h"

#include "xpError.h"

#include <xraylib.h>

#include <cmath>

namespace xp
{

namespace
{

const char* CompoundName(Material material)
{
  switch (material)
  {
    case Material::Water: return "Water, Liquid";
    case Material::CorticalBone: return "Bone, Cortical (ICRP)";
    case Material::Aluminium: return "Al";
    case Material::Copper: return "Cu";
    case Material::Carbon: return "C";
    case Material::Polystyrene: return "Polystyrene";
    case Material::CesiumIodide: return "Cesium Iodide";
  }
  return "";
}

/** xraylib reports errors through an out-parameter; turn one into an exception. */
void ThrowOnError(xrl_error* error, const std::string& what)
{
  if (error)
  {
    const std::string message = error->message ? error->message : "unknown error";
    xrl_error_free(error);
    throw Error("xraylib", what + ": " + message);
  }
}

} // namespace

std::string Name(Material material)
{
  return CompoundName(material);
}

double MassAttenuation(Material material, double keV)
{
  xrl_error* error = nullptr;
  const double value = CS_Total_CP(CompoundName(material), keV, &error);
  ThrowOnError(error, Name(material));
  return value;
}

double Density(Material material)
{
  xrl_error* error = nullptr;
  switch (material)
  {
    case Material::Aluminium: return ElementDensity(13, nullptr);
    case Material::Copper: return ElementDensity(29, nullptr);
    case Material::Carbon: return 1.6; // carbon-fibre composite, not graphite's 2.26
    default: break;
  }
  compoundDataNIST* data = GetCompoundDataNISTByName(CompoundName(material), &error);
  ThrowOnError(error, Name(material));
  const double density = data->density;
  FreeCompoundDataNIST(data);
  return density;
}

double XRaySpectrum::MeanEnergy() const
{
  double mean = 0.0;
  for (size_t i = 0; i < keV.size(); ++i)
    mean += keV[i] * weight[i];
  return mean;
}

XRaySpectrum KramersSpectrum(const TubeSettings& tube)
{
  const auto check = [](double value, double low, double high, const char* field)
  {
    if (!(value >= low && value <= high))
      throw InputError(field, "must be between " + std::to_string(low) + " and " + std::to_string(high));
  };
  check(tube.kVp, 40.0, 150.0, "tube kVp");
  check(tube.aluminiumMM, 0.0, 20.0, "tube aluminium filtration (mm)");
  check(tube.copperMM, 0.0, 2.0, "tube copper filtration (mm)");
  check(tube.scintillatorMM, 0.05, 2.0, "detector CsI thickness (mm)");
  check(tube.binKeV, 0.1, 10.0, "spectrum bin width (keV)");
  XRaySpectrum spectrum;
  double total = 0.0;
  // Below 10 keV nothing passes 1 mm of aluminium; bin centres stop short of kVp.
  for (double e = 10.0 + 0.5 * tube.binKeV; e < tube.kVp; e += tube.binKeV)
  {
    const double photons = (tube.kVp - e) / e;
    const double filtered = photons *
      std::exp(-MassAttenuation(Material::Aluminium, e) * Density(Material::Aluminium) * 0.1 * tube.aluminiumMM -
        MassAttenuation(Material::Copper, e) * Density(Material::Copper) * 0.1 * tube.copperMM);
    const double absorbed = 1.0 -
      std::exp(-MassAttenuation(Material::CesiumIodide, e) * Density(Material::CesiumIodide) * 0.1 * tube.scintillatorMM);
    spectrum.keV.push_back(e);
    spectrum.weight.push_back(filtered * e * absorbed);
    total += spectrum.weight.back();
  }
  for (double& w : spectrum.weight)
    w /= total;
  return spectrum;
}

} // namespace xp
