/**
 * @file xpEvaluationScenario.h
 * @brief What an evaluation's X-rays are made of: the scenario, its simulator and the planning CT
 *        the registration gets.
 */
#ifndef xpEvaluationScenario_h
#define xpEvaluationScenario_h

#include "vtkXPEvaluationModule.h"
#include "xpDetector.h"
#include "xpModelXRaySimulator.h"
#include "xpPose.h"
#include "xpStereoSimilarity.h"
#include "xpXRayPhysics.h"

#include <vtkSmartPointer.h>

#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

class vtkImageData;

namespace xp
{

/**
 * One of the scenarios of `xpose evaluate`:
 * - clean: the DRR model, no noise; noisy: with quantum noise and kV contrast; objects: also
 *   X-ray-only objects (couch rail, frame corner) - all made by xpModelXRaySimulator.h;
 * - truncated: like noisy, but the registration's CT has half the X-rays' length;
 * - clinical: the independent physics simulator (xpXRayPhysics.h) with every effect on, a
 *   planning CT of 80 % of the length, and no CT table; `without` switches effects off
 *   ("truncation" or any XRayPhysicsEffects() name);
 * - plastimatch: line integrals from `plastimatch drr` (xpPlastimatchRenderer.h), one ray per
 *   pixel, no scatter or blur, the whole CT for the registration.
 * A detector (xpDetector.h) makes the images of the plastimatch scenario (linear12 unless
 * given) and, when given, of the clinical one (whose own output is otherwise 12-bit log).
 */
class VTKXPEVALUATION_EXPORT EvaluationScenario
{
public:
  /** `noise`: the DRR-model scenarios' quantum noise (XRaySimulation::noise). Throws
   *  xp::InputError naming --scenario or --without when they do not fit. */
  EvaluationScenario(const std::string& name, const std::vector<std::string>& without, double noise, bool removeTable,
    const std::optional<DetectorSettings>& detector = std::nullopt);

  const std::string& Name() const { return this->Scenario; }
  bool UsesPhysics() const { return this->Scenario == "clinical"; }
  bool UsesPlastimatch() const { return this->Scenario == "plastimatch"; }
  /** The detector that makes the images, when not the simulator's own. */
  const std::optional<DetectorSettings>& Detector() const { return this->DetectorModel; }
  /** Whether the registration's CT leaves out the table (--remove-table). */
  bool RemovesTable() const { return this->RemoveTable; }
  const XRayPhysicsSettings& Physics() const { return this->PhysicsSettings; }
  const XRaySimulation& Model() const { return this->ModelSettings; }

  /** The fraction of the CT's slices the registration gets (1: all of them). */
  double RegistrationCTLength() const { return this->Scenario == "truncated" ? 0.5 : this->Truncation ? 0.8 : 1.0; }
  /** The planning CT the registration gets: cut to the scenario's length, without the table
   *  where it is removed. */
  vtkSmartPointer<vtkImageData> RegistrationCT(vtkImageData* ct) const;

  /** How the X-rays are made, as JSON (evaluation.json's "x_rays"). */
  std::string DescribeXRays() const;

private:
  std::string Scenario;
  std::vector<std::string> Without;
  bool RemoveTable = true;
  bool Truncation = false;
  XRayPhysicsSettings PhysicsSettings = XRayPhysicsSettings::Clinical();
  XRaySimulation ModelSettings;
  std::optional<DetectorSettings> DetectorModel;
};

/** `ct` stretched by `factor` along its index axis `axis` (0, 1, 2) about its centre: the same
 *  voxels with that spacing scaled, an anatomy no rigid pose maps onto the original. */
VTKXPEVALUATION_EXPORT vtkSmartPointer<vtkImageData> StretchedCT(vtkImageData* ct, int axis, double factor);

/** The slices of `ct` whose index lies in the central `fraction` of its length (same placement). */
VTKXPEVALUATION_EXPORT vtkSmartPointer<vtkImageData> CropSlices(vtkImageData* ct, double fraction);

/** Makes the X-rays of every view for a trial's true misalignment, at the registration size. */
class VTKXPEVALUATION_EXPORT TrialXRaySource
{
public:
  /** `ct` is the whole CT the X-rays see; `panels` the geometry's views at full size. */
  TrialXRaySource(const EvaluationScenario& scenario, vtkImageData* ct, const PatientSetup& patient,
    const std::vector<XRayView>& panels, int shrinkFactor);
  ~TrialXRaySource();

  std::vector<RegistrationView> Simulate(const Pose& truth, std::mt19937& random);

private:
  std::vector<XRayView> Panels;
  int Factor = 1;
  std::unique_ptr<XRaySimulator> OwnModel;
  std::unique_ptr<XRayPhysicsSimulator> Physics;
  std::unique_ptr<class PlastimatchRenderer> Plastimatch;
  std::optional<DetectorSettings> DetectorModel;
};

} // namespace xp

#endif
