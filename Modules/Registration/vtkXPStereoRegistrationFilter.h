/**
 * @class vtkXPStereoRegistrationFilter
 * @brief 6-DOF pose of a CT from two X-ray views (METHOD.md): pre-alignment, entropy masks,
 *        masked mutual-information alignment and a quality gate, as one pipeline stage.
 *
 * Port 0: the CT (HU; origin/spacing/DirectionMatrix in LPS). Ports 1 and 2: the X-rays of the
 * geometry's first two views (unsigned short, 12-bit, VTK row order, sizes equal to the views').
 * Ports 3 and 4 (optional): user ROIs (unsigned char, non-zero = use). Outputs 0 and 1: the final
 * 12-bit DRRs (0 where masked); outputs 2 and 3: the masks used (255 valid). All on the X-ray grids.
 * The result (status, reasons, misalignment, correction, figures) is GetResult() after Update.
 */
#ifndef vtkXPStereoRegistrationFilter_h
#define vtkXPStereoRegistrationFilter_h

#include "vtkImageAlgorithm.h"
#include "vtkXPRegistrationModule.h"

#include "xpPose.h"
#include "xpStereoGeometry.h"
#include "xpStereoRegistration.h"

class VTKXPREGISTRATION_EXPORT vtkXPStereoRegistrationFilter : public vtkImageAlgorithm
{
public:
  static vtkXPStereoRegistrationFilter* New();
  vtkTypeMacro(vtkXPStereoRegistrationFilter, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetCTConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(0, output); }
  /** view 0 or 1 */
  void SetXRayConnection(int view, vtkAlgorithmOutput* output) { this->SetInputConnection(1 + view, output); }
  void SetROIConnection(int view, vtkAlgorithmOutput* output) { this->SetInputConnection(3 + view, output); }

  /** The room's X-ray system; its first two views must match the X-rays' sizes. */
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

  /** Method settings: entropy mask on/off, bins, evaluation limit, gate limits. */
  void SetSettings(const xp::StereoRegistrationSettings& settings);
  const xp::StereoRegistrationSettings& GetSettings() const { return this->Settings; }

  /** The outcome of the last update. */
  const xp::StereoRegistrationResult& GetResult() const { return this->Result; }

protected:
  vtkXPStereoRegistrationFilter();
  ~vtkXPStereoRegistrationFilter() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPStereoRegistrationFilter(const vtkXPStereoRegistrationFilter&) = delete;
  void operator=(const vtkXPStereoRegistrationFilter&) = delete;

  xp::StereoGeometry Geometry;
  xp::PatientSetup Setup;
  double MuWater = xp::WaterAttenuationPerMM;
  xp::StereoRegistrationSettings Settings;
  xp::StereoRegistrationResult Result;
};

#endif
