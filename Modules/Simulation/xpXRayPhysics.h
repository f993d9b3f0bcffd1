/**
 * @file xpXRayPhysics.h
 * @brief A kV X-ray simulator that shares no shortcut with the DRR filter: the test images of
 *        xpose's accuracy come from here, not from the model under test.
 *
 * What it models, each behind its own switch:
 * - rays: exact path lengths through piecewise-constant voxels (Siddon), several rays over each
 *   pixel's area, CT values as they are (no air threshold);
 * - beam: a polyenergetic Kramers spectrum with filtration; every voxel is split into water and
 *   cortical bone by its HU, each with its own energy-dependent attenuation (xraylib), so the
 *   beam hardens and bone has its kV contrast;
 * - anatomy and room: the CT's table removed (body segmentation) and a carbon-fibre couch top
 *   fixed in the room under the patient;
 * - detector: scatter whose amount grows with the water-equivalent thickness, spread by a broad
 *   kernel; the heel effect; quantum (Poisson) and electronic noise; a Gaussian PSF;
 * - output: 12-bit raw transmission or a log-converted image (bone bright), row 0 at the top.
 */
#ifndef xpXRayPhysics_h
#define xpXRayPhysics_h

#include "vtkXPSimulationModule.h"

#include "xpPose.h"
#include "xpXRaySpectrum.h"
#include "xpXRayView.h"

#include <Eigen/Geometry>

#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

class vtkImageData;

namespace xp
{

struct VTKXPSIMULATION_EXPORT XRayPhysicsSettings
{
  TubeSettings tube;
  /** false: one energy, the spectrum's weighted mean (no beam hardening, bone contrast of that
   *  energy). */
  bool polyenergetic = true;
  int raysPerPixel = 2;            ///< per side: 2 = 2 x 2 rays spread over each pixel's area
  bool removeTable = false;        ///< render the segmented body only (xpBodyMask.h)
  bool couch = false;              ///< a carbon-fibre couch top fixed in the room under the patient
  /** Scatter-to-primary ratio behind 200 mm of water (it grows in proportion to the
   *  water-equivalent thickness); 0 = no scatter. */
  double scatterToPrimary = 0.0;
  double scatterSigmaMM = 30.0;    ///< sd of the scatter's spread on the panel
  double blurSigmaMM = 0.0;        ///< detector PSF: Gaussian sd on the panel; 0 = none
  double quantaPerMM2 = 0.0;       ///< open-field quanta per mm^2 of panel; 0 = no quantum noise
  double electronicNoise = 0.0;    ///< sd of the read-out noise, as a fraction of the open-field signal
  /** Heel effect: the open field falls by this fraction from the first row to the last one (the
   *  anode side), linearly. */
  double heel = 0.0;
  bool logOutput = false;          ///< 12-bit -ln(I / I0) (bone bright) instead of raw transmission

  /** Everything on at realistic values for a pelvis at 110 kVp with an anti-scatter grid. */
  static XRayPhysicsSettings Clinical();
  /** Checks every field; throws xp::InputError naming it. */
  void Validate() const;
  /** One line per setting, for truth.json and evaluation.json. */
  std::string Describe() const;
};

/** Raw 12-bit grey level of the open field at the panel centre, and the log images' full scale. */
constexpr double RawOpenField = 3600.0;
constexpr double LogFullScale = 10.0;

/** Per pixel of a view, top row first, relative to the open field at the panel centre. */
struct XRayComponents
{
  std::vector<float> primary;  ///< transmitted primary, no heel
  std::vector<float> scatter;  ///< scatter reaching the panel, no heel
  std::vector<float> signal;   ///< (primary + scatter) x heel, blurred by the PSF, before noise
};

class VTKXPSIMULATION_EXPORT XRayPhysicsSimulator
{
public:
  /**
   * @param ct              HU, any scalar type (the whole CT: anatomy beyond a planning CT's
   *                        ends belongs in the X-ray)
   * @param plannedCTToRoom the planned set-up; poses are misalignments applied after it
   * @param roomIsocenter   centre of rotation of the misalignments
   */
  XRayPhysicsSimulator(vtkImageData* ct, const Eigen::Isometry3d& plannedCTToRoom,
    const Eigen::Vector3d& roomIsocenter, const XRayPhysicsSettings& settings);

  /** The noise-free components of one view at a misalignment. */
  XRayComponents Render(const XRayView& view, const Pose& misalignment) const;
  /** The 12-bit image (noise drawn from `random`), top row first. */
  std::vector<uint16_t> Simulate(const XRayView& view, const Pose& misalignment, std::mt19937& random) const;

  /** Areal densities (g/cm^2) of water and bone along one ray from the source to a Room point. */
  std::array<double, 2> ArealDensities(const XRayView& view, const Eigen::Vector3d& panelPoint, const Pose& misalignment) const;

  const XRaySpectrum& Spectrum() const { return this->Energies; }
  const XRayPhysicsSettings& Settings() const { return this->Options; }
  /** Room Z (mm) of the couch top: 1 mm under the lowest body voxel at the planned pose. */
  double CouchTopZ() const { return this->CouchTop; }

private:
  struct Grid;
  XRayComponents RenderPrimary(const XRayView& view, const Pose& misalignment) const;
  void Finish(const XRayView& view, XRayComponents& components, std::mt19937* random) const;

  XRayPhysicsSettings Options;
  XRaySpectrum Energies;
  /** Per energy bin: mass attenuation (cm^2/g) of water, bone, carbon, polystyrene. */
  std::vector<std::array<float, 4>> MassMu;
  double WaterMuPerMM = 0.0; ///< at the mean energy, for water-equivalent thickness
  Eigen::Vector3i Dims = Eigen::Vector3i::Zero();
  /** Per voxel, x fastest: (water, bone) densities in g/cm^3. */
  std::vector<std::array<float, 2>> Densities;
  Eigen::Vector3d BoxLow = Eigen::Vector3d::Zero();  ///< voxel-corner coordinates of the matter's box
  Eigen::Vector3d BoxHigh = Eigen::Vector3d::Zero();
  Eigen::Affine3d PhysicalToCorner = Eigen::Affine3d::Identity(); ///< CT mm -> voxel corners (voxel i spans [i, i+1))
  Eigen::Isometry3d Planned = Eigen::Isometry3d::Identity();
  Eigen::Vector3d Isocenter = Eigen::Vector3d::Zero();
  double CouchTop = 0.0;
};

/** The effects that SwitchOff names, in the order of XRayPhysicsSettings. */
VTKXPSIMULATION_EXPORT const std::vector<std::string>& PhysicsEffects();
/**
 * Turns one effect off: "spectrum" (one energy), "pixel-area" (one ray per pixel), "table" (the
 * CT's table stays), "couch", "scatter", "blur", "quantum-noise", "electronic-noise", "heel",
 * "log" (raw transmission). Throws xp::InputError naming `option` for another name.
 */
VTKXPSIMULATION_EXPORT void SwitchOff(XRayPhysicsSettings& settings, const std::string& effect, const std::string& option);

/** HU -> (water, cortical bone) densities in g/cm^3: below 0 HU water mixed with air, above it
 *  water mixed with bone by volume, `boneHU` being the CT number of bone of `boneDensity`. */
VTKXPSIMULATION_EXPORT std::array<float, 2> WaterAndBone(double hu, double boneHU, double boneDensity);
/** The CT number of cortical bone at `keV`, from xraylib: 1000 (mu_bone / mu_water - 1). */
VTKXPSIMULATION_EXPORT double CorticalBoneHU(double keV);

} // namespace xp

#endif
