/**
 * @class vtkXPStereoRegistrationFilter
 * @brief 6-DOF pose of a CT from N X-ray views (Method.md): pre-alignment, entropy masks,
 *        masked mutual-information alignment and a quality gate, as one pipeline stage. This is
 *        the registration `xpose register` and `xpose evaluate` run.
 *
 * Input port 0: the CT (HU; origin/spacing/DirectionMatrix in LPS).
 * Input port 1 (repeatable): one X-ray per view of the geometry, in its order (unsigned short,
 * any bit depth up to 16, VTK row order, the panel's full size).
 * Input port 2 (optional, repeatable): none, or one ROI per view (unsigned char, non-zero = use).
 *
 * With a shrink factor f, the X-rays and ROIs are box-averaged by f and registered on panels of
 * 1/f the pixels. Outputs, three per view v, on that registration grid: 3v the final 12-bit DRR
 * (0 where masked), 3v+1 the validity mask (255 valid), 3v+2 the block-entropy map (float, 0-1;
 * zeros without entropy masks).
 *
 * The result (status, failures with codes and reasons, misalignment, correction, figures) is
 * GetResult() after Update. A run fires ProgressEvent (GetProgress, GetProgressText: the stage)
 * and, for every similarity evaluation, EvaluationEvent (GetLastObjective).
 */
#ifndef vtkXPStereoRegistrationFilter_h
#define vtkXPStereoRegistrationFilter_h

#include "vtkCommand.h"
#include "vtkImageAlgorithm.h"
#include "vtkXPRegistrationModule.h"

#include "xpPose.h"
#include "xpStereoGeometry.h"
#include "xpStereoRegistration.h"

#include <memory>
#include <string>

class VTKXPREGISTRATION_EXPORT vtkXPStereoRegistrationFilter : public vtkImageAlgorithm
{
public:
  static vtkXPStereoRegistrationFilter* New();
  vtkTypeMacro(vtkXPStereoRegistrationFilter, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetCTConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(0, output); }
  void SetCTData(vtkDataObject* ct) { this->SetInputData(0, ct); }
  /** One per view, in the geometry's order. */
  void AddXRayConnection(vtkAlgorithmOutput* output) { this->AddInputConnection(1, output); }
  void AddXRayData(vtkDataObject* xray) { this->AddInputData(1, xray); }
  /** None, or one per view in the same order. */
  void AddROIConnection(vtkAlgorithmOutput* output) { this->AddInputConnection(2, output); }
  void AddROIData(vtkDataObject* roi) { this->AddInputData(2, roi); }
  /** Forgets the X-rays and ROIs, for the next registration with the same CT. */
  void RemoveAllXRaysAndROIs();

  /** The room's X-ray system, one output triple per view. */
  void SetGeometry(const xp::StereoGeometry& geometry);
  const xp::StereoGeometry& GetGeometry() const { return this->Geometry; }

  /** How the CT is placed in the room; its room isocentre must be the geometry's. */
  void SetPatientSetup(const xp::PatientSetup& setup);
  const xp::PatientSetup& GetPatientSetup() const { return this->Setup; }
  ///@{
  /** Attenuation of water (1/mm) for the DRRs. */
  vtkSetClampMacro(MuWater, double, 1e-6, 1.0);
  vtkGetMacro(MuWater, double);
  ///@}
  ///@{
  /** Registers on the X-rays box-averaged by this factor, which must divide every panel. */
  vtkSetClampMacro(ShrinkFactor, int, 1, 64);
  vtkGetMacro(ShrinkFactor, int);
  ///@}

  /** Method settings: entropy mask on/off, bins, evaluation limit, gate limits. */
  void SetSettings(const xp::StereoRegistrationSettings& settings);
  const xp::StereoRegistrationSettings& GetSettings() const { return this->Settings; }

  ///@{
  /** The value types above in plain numbers and text, for Python. Each returns false on bad
   *  input and says why in GetLastError(). A geometry file becomes the geometry, and its
   *  isocentre the room isocentre of the patient set-up. */
  bool ReadGeometry(const char* path);
  bool SetPatientPosition(const char* dicomPatientPosition);
  void SetIsocenterInCT(double x, double y, double z);
  void SetEntropyMask(bool on);
  bool GetEntropyMask() const { return this->Settings.entropyMask; }
  /** The CT with its table or the body alone, whichever the X-rays match better
   *  (StereoRegistrationSettings::chooseTable; `xpose register`'s default); off: the CT as given. */
  void SetChooseTable(bool on);
  bool GetChooseTable() const { return this->Settings.chooseTable; }
  /** After an update: ok (the correction may be applied) or failed. */
  bool GetResultOk() const { return this->Result.ok; }
  /** tx, ty, tz (mm), pitch, roll, yaw (degrees) in Room terms (Coordinates.md). */
  vtkGetVector6Macro(MisalignmentParameters, double);
  vtkGetVector6Macro(CorrectionParameters, double);
  /** The result as the record `xpose register` writes to result.json, without its inputs. */
  std::string GetResultJSON() const;
  const char* GetLastError() const { return this->LastError.c_str(); }
  ///@}

  /** The outcome of the last update (on refused inputs: not ok, one InvalidInput failure). */
  const xp::StereoRegistrationResult& GetResult() const { return this->Result; }
  /** Fired after every similarity evaluation (VTK 9.1 has no IterationEvent). */
  enum
  {
    EvaluationEvent = vtkCommand::UserEvent + 3071
  };
  /** During EvaluationEvent: the similarity just evaluated. */
  vtkGetMacro(LastObjective, double);

  /** Throws xp::InputError, naming `what`, unless `xray` is an unsigned 16-bit single-sample image of
   *  the panel's size: the check every X-ray gets, here and in the commands that read files. */
  static void CheckXRay(vtkImageData* xray, const xp::XRayView& panel, const std::string& what);

  /** The views a registration runs on: each X-ray checked (CheckXRay, distinct from the
   *  others), ROIs binarised, both box-averaged by `shrinkFactor` onto panels resampled to
   *  match. `rois` is empty or one per X-ray. Throws xp::InputError naming the input: by its
   *  entry in `names` (a file, say) where given, else by its port and imager. */
  static std::vector<xp::RegistrationView> PrepareViews(const xp::StereoGeometry& geometry,
    const std::vector<vtkImageData*>& xrays, const std::vector<vtkImageData*>& rois, int shrinkFactor,
    const std::vector<std::string>& names = {});

  vtkAlgorithmOutput* GetDRROutputPort(int view) { return this->GetOutputPort(3 * view); }
  vtkAlgorithmOutput* GetMaskOutputPort(int view) { return this->GetOutputPort(3 * view + 1); }
  vtkAlgorithmOutput* GetEntropyOutputPort(int view) { return this->GetOutputPort(3 * view + 2); }

protected:
  vtkXPStereoRegistrationFilter();
  ~vtkXPStereoRegistrationFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPStereoRegistrationFilter(const vtkXPStereoRegistrationFilter&) = delete;
  void operator=(const vtkXPStereoRegistrationFilter&) = delete;

  /** The CT's attenuation, kept while the CT and MuWater stay the same. */
  const xp::AttenuationVolume& Attenuation(vtkImageData* ct);
  /** With Settings.chooseTable: the body alone's attenuation (xpBodyMask.h), kept like the CT's;
   *  null where nothing outside the body is a table (TableCM3 0). */
  const xp::AttenuationVolume* BodyAttenuation(vtkImageData* ct);
  void WriteOutputs(vtkInformationVector* outputVector);
  /** The result and the parameter copies Python reads, always together. */
  void SetResult(xp::StereoRegistrationResult result);
  /** A result that refuses the inputs (not ok, one InvalidInput failure). */
  void Refused(const std::string& message);

  xp::StereoGeometry Geometry;
  xp::PatientSetup Setup;
  double MuWater = xp::WaterAttenuationPerMM;
  int ShrinkFactor = 1;
  xp::StereoRegistrationSettings Settings;
  xp::StereoRegistrationResult Result;
  double LastObjective = 0.0;
  double MisalignmentParameters[6] = { 0, 0, 0, 0, 0, 0 };
  double CorrectionParameters[6] = { 0, 0, 0, 0, 0, 0 };
  std::string LastError;

  std::unique_ptr<xp::AttenuationVolume> Volume;
  vtkImageData* VolumeSource = nullptr; ///< compared, never dereferenced
  vtkMTimeType VolumeTime = 0;
  double VolumeMuWater = 0.0;
  std::unique_ptr<xp::AttenuationVolume> BodyVolume;
  double TableCM3 = 0.0;
  vtkImageData* BodySource = nullptr; ///< compared, never dereferenced
  vtkMTimeType BodyTime = 0;
  double BodyMuWater = 0.0;
};

#endif
