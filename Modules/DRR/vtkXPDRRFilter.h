/**
 * @class vtkXPDRRFilter
 * @brief Digitally reconstructed radiograph of a CT for one X-ray view, optionally masked.
 *
 * Port 0: the CT (vtkImageData, HU, any scalar type; origin/spacing/DirectionMatrix give LPS mm).
 * Port 1 (optional): a validity mask on the output grid (unsigned char, non-zero = trace the ray).
 *
 * The CT is placed in the room by the PatientSetup (planned set-up, Coordinates.md), then moved by the patient Misalignment (mm, degrees). Outputs, all on the panel
 * grid with rows bottom-up as VTK stores them and placed in Room coordinates:
 *  - port 0: 12-bit transmission round(4095 exp(-integral)) as unsigned short (0 where masked);
 *  - port 1: the line integral of mu as float (0 where masked);
 *  - port 2: the validity of each pixel (255 traced, 0 masked) as unsigned char.
 * Masked pixels are not traced at all. The HU->mu volume is built once and reused while the CT
 * and MuWater stay the same, so rendering many poses costs only the rays.
 */
#ifndef vtkXPDRRFilter_h
#define vtkXPDRRFilter_h

#include "vtkImageAlgorithm.h"
#include "vtkXPDRRModule.h"

#include "xpAttenuationVolume.h"
#include "xpPose.h"
#include "xpRayCaster.h"
#include "xpXRayView.h"

#include <cstdint>
#include <memory>
#include <vector>

namespace xp
{
/**
 * The attenuation volume of a CT image (HU, any scalar type), with its index-to-LPS mapping from
 * the image's origin, spacing, DirectionMatrix and extent; where `keep` is given (one flag per
 * voxel, x fastest), its 0 voxels are air. Throws xp::InputError on bad input, and
 * std::invalid_argument when `keep` does not hold one flag per voxel.
 */
VTKXPDRR_EXPORT std::unique_ptr<AttenuationVolume> MakeAttenuationVolume(
  vtkImageData* ct, double muWater, const std::vector<uint8_t>* keep = nullptr);
}

class VTKXPDRR_EXPORT vtkXPDRRFilter : public vtkImageAlgorithm
{
public:
  static vtkXPDRRFilter* New();
  vtkTypeMacro(vtkXPDRRFilter, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetCTConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(0, output); }
  void SetMaskConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  /** The view to render; its panel size is the output size unless OutputSize is set. */
  void SetView(const xp::XRayView& view);
  const xp::XRayView& GetView() const { return this->View; }

  /** How the CT is placed in the room (default: HFS, its centre at a room isocentre at 0). */
  void SetPatientSetup(const xp::PatientSetup& setup);
  const xp::PatientSetup& GetPatientSetup() const { return this->Setup; }

  /** Patient misalignment in Room terms (Coordinates.md): translation mm, pitch/roll/yaw degrees. */
  void SetMisalignment(const xp::Pose& pose);
  const xp::Pose& GetMisalignment() const { return this->Misalignment; }

  ///@{
  /** The value types above in plain numbers and text, for Python. Each returns false on bad
   *  input and says why in GetLastError(). A geometry file's view becomes the view, and its
   *  isocentre the room isocentre. */
  bool SetViewFromGeometryFile(const char* path, int viewIndex);
  bool SetPatientPosition(const char* dicomPatientPosition);
  void SetIsocenterInCT(double x, double y, double z);
  void SetMisalignmentParameters(double tx, double ty, double tz, double pitch, double roll, double yaw);
  const char* GetLastError() const { return this->LastError.c_str(); }
  ///@}

  ///@{
  /** Attenuation of water in 1/mm: mu = MuWater (1 + HU/1000), clamped at 0. */
  vtkSetClampMacro(MuWater, double, 1e-6, 1.0);
  vtkGetMacro(MuWater, double);
  ///@}

  ///@{
  /** Sampling step along the ray (mm) for trilinear sampling; 0 = smallest voxel spacing. */
  vtkSetClampMacro(StepSize, double, 0.0, 100.0);
  vtkGetMacro(StepSize, double);
  ///@}

  ///@{
  /** 0 = trilinear at a fixed step (default), 1 = exact Siddon through nearest voxels. */
  vtkSetClampMacro(Method, int, 0, 1);
  vtkGetMacro(Method, int);
  ///@}

  ///@{
  /** Where the rays are cast: 0 = the CPU (default), 1 = an NVIDIA GPU (CUDA; trilinear rays on
   *  the voxel planes only, StepSize 0). Without a usable GPU, 1 fails the update with the reason. */
  vtkSetClampMacro(Device, int, 0, 1);
  vtkGetMacro(Device, int);
  ///@}

  ///@{
  /** Output columns and rows on the same panel (resampled pitch); 0 0 = the panel's own size. */
  vtkSetVector2Macro(OutputSize, int);
  vtkGetVector2Macro(OutputSize, int);
  ///@}

  /** The view actually rendered (OutputSize applied). */
  xp::XRayView GetOutputView() const;

  /** Rays traced by the last update. */
  vtkGetMacro(NumberOfTracedRays, long long);
  /** Seconds the last update spent casting rays, and building the attenuation volume (0 when reused). */
  vtkGetMacro(LastRenderSeconds, double);
  vtkGetMacro(LastPreparationSeconds, double);

protected:
  vtkXPDRRFilter();
  ~vtkXPDRRFilter() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPDRRFilter(const vtkXPDRRFilter&) = delete;
  void operator=(const vtkXPDRRFilter&) = delete;

  const xp::AttenuationVolume& Attenuation(vtkImageData* ct);

  xp::XRayView View;
  xp::Pose Misalignment;
  xp::PatientSetup Setup;
  std::string LastError;
  double MuWater = xp::WaterAttenuationPerMM;
  double StepSize = 0.0;
  int Method = 0;
  int Device = 0;
  int OutputSize[2] = { 0, 0 };
  long long NumberOfTracedRays = 0;
  double LastRenderSeconds = 0.0;
  double LastPreparationSeconds = 0.0;

  std::unique_ptr<xp::AttenuationVolume> Volume;
  vtkMTimeType VolumeTime = 0;
  double VolumeMuWater = 0.0;
};

#endif
