/**
 * @file xpXRaySpectrum.h
 * @brief The energy side of a kV X-ray: a filtered tube spectrum as the detector weighs it, and
 *        the mass attenuation of the materials a ray crosses, from xraylib's tables.
 */
#ifndef xpXRaySpectrum_h
#define xpXRaySpectrum_h

#include "vtkXPSimulationModule.h"

#include <string>
#include <vector>

namespace xp
{

/** Materials of the simulation, with xraylib's NIST compositions and densities. */
enum class Material
{
  Water,       ///< "Water, Liquid"
  CorticalBone, ///< "Bone, Cortical (ICRP)"
  Aluminium,
  Copper,
  Carbon,      ///< carbon-fibre couch skins (graphite cross sections)
  Polystyrene, ///< couch foam core
  CesiumIodide ///< the detector's scintillator
};

/** Mass attenuation coefficient with coherent scattering (cm^2/g) at `keV`, from xraylib. */
VTKXPSIMULATION_EXPORT double MassAttenuation(Material material, double keV);
/** Nominal density (g/cm^3) from xraylib's tables. */
VTKXPSIMULATION_EXPORT double Density(Material material);
VTKXPSIMULATION_EXPORT std::string Name(Material material);

struct TubeSettings
{
  double kVp = 100.0;             ///< tube voltage
  double aluminiumMM = 2.5;       ///< inherent + added aluminium filtration
  double copperMM = 0.0;          ///< added copper filtration
  double scintillatorMM = 0.6;    ///< CsI thickness of the flat panel
  double binKeV = 2.0;            ///< width of an energy bin
};

/**
 * The spectrum in energy bins, each with the weight of its contribution to the detector signal:
 * Kramers' law for a thick tungsten target (photons per keV proportional to (kVp - E) / E; the
 * characteristic lines are left out), attenuated by the filtration, times E times the energy
 * absorbed in the CsI scintillator (an energy-integrating detector). Weights sum to 1.
 */
struct XRaySpectrum
{
  std::vector<double> keV;
  std::vector<double> weight;

  /** Weighted mean energy: the energy of the monochromatic equivalent. */
  double MeanEnergy() const;
};

/** Throws xp::InputError naming the field when a setting is outside 40-150 kVp and so on. */
VTKXPSIMULATION_EXPORT XRaySpectrum KramersSpectrum(const TubeSettings& tube);

} // namespace xp

#endif
