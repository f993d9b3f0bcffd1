/**
 * @file xpAccuracyEvaluation.h
 * @brief The trials of `xpose evaluate`: known misalignments, simulated X-rays, registrations
 *        by a registration session on them (xpRegistrationSession.h), and how far each ends from
 *        the truth.
 */
#ifndef xpAccuracyEvaluation_h
#define xpAccuracyEvaluation_h

#include "vtkXPEvaluationModule.h"
#include "xpEvaluation.h"
#include "xpEvaluationFolder.h"
#include "xpEvaluationScenario.h"
#include "xpStereoGeometry.h"
#include "xpStereoRegistration.h"
#include "xpTargetError.h"

#include <vtkSmartPointer.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

class vtkImageData;

namespace xp
{
class RegistrationSession;

/** Everything that makes trials comparable, apart from the inputs. */
struct AccuracyEvaluationSettings
{
  unsigned seed = 1;
  MisalignmentRange range;
  double successMTRE = 2.0;  ///< mm: an `ok` registration closer than this is a success
  int shrinkFactor = 1;      ///< panel pixels per registration pixel
  /** Also write each trial's X-rays, as registered, to xrays/trial_N_VIEW.png in the folder. */
  bool writeXRays = false;
  StereoRegistrationSettings registration;
};

/** The record of one registration of trial `trial` against its true misalignment. */
VTKXPEVALUATION_EXPORT TrialRecord MakeTrialRecord(int trial, const std::string& approach, const std::string& scenario,
  const Pose& truth, const StereoRegistrationResult& result, const std::vector<Eigen::Vector3d>& targets,
  const Eigen::Vector3d& roomIsocenter, double successMTRE, double seconds);

class VTKXPEVALUATION_EXPORT AccuracyEvaluation
{
public:
  /**
   * `ct`: the whole CT the X-rays are simulated from; the registration gets the scenario's
   * planning CT (EvaluationScenario::RegistrationCT), with the isocentre where the whole CT puts
   * it. `xrayCT`, when given, is what the X-rays show instead (another patient, or the same one
   * stretched), its centre at the same isocentre: such trials must end `failed`. Throws
   * xp::InputError when the CT has no target region.
   */
  AccuracyEvaluation(const EvaluationScenario& scenario, vtkImageData* ct, const PatientSetup& patient,
    const StereoGeometry& geometry, const AccuracyEvaluationSettings& settings, vtkImageData* xrayCT = nullptr);
  ~AccuracyEvaluation();

  size_t TargetCount() const { return this->Targets.size(); }

  /** Called after each registration with its record, the registrations done in this run and
   *  those this run has left to do. */
  using Progress = std::function<void(const TrialRecord& record, int registered, int remaining)>;

  /**
   * Registers trials 1..`trials` with each approach ("A": whole image, "B": entropy masks) that
   * `folder` does not hold yet, appending each record to it. A trial's misalignment and noise
   * depend only on the seed and its number, so a resumed run makes the same trials.
   */
  void Run(int trials, const std::vector<std::string>& approaches, EvaluationFolder& folder, const Progress& progress);

  /** The registration whose record the last Progress call had (its stages, costs and masks). */
  const StereoRegistrationResult& LastResult() const;

private:
  TrialRecord Register(int trial, const std::string& approach, const Pose& truth, const std::vector<RegistrationView>& views);

  std::string Scenario;
  AccuracyEvaluationSettings Settings;
  Eigen::Vector3d RoomIsocenter;
  std::vector<Eigen::Vector3d> Targets;
  TrialXRaySource XRays;
  std::unique_ptr<RegistrationSession> Session; ///< one for all trials: the CT's attenuation is kept
};

} // namespace xp

#endif
