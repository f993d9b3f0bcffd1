/**
 * @class vtkXPOverlayFilter
 * @brief Overlay of an X-ray and a DRR of the same view, for a person to judge the alignment.
 *
 * Port 0: the X-ray, port 1: the DRR (both unsigned short, 12-bit, one 2D image each, same size),
 * port 2 (optional): a mask (unsigned char, non-zero = valid). Output: RGB unsigned char on the
 * X-ray's grid (origin, spacing), composed as OverlayMode says (xpOverlays.h); no OpenGL.
 */
#ifndef vtkXPOverlayFilter_h
#define vtkXPOverlayFilter_h

#include "vtkImageAlgorithm.h"
#include "vtkXPReportingModule.h"

#include "xpOverlays.h"

class VTKXPREPORTING_EXPORT vtkXPOverlayFilter : public vtkImageAlgorithm
{
public:
  static vtkXPOverlayFilter* New();
  vtkTypeMacro(vtkXPOverlayFilter, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetXRayConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(0, output); }
  void SetDRRConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetMaskConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(2, output); }

  void SetMode(xp::OverlayMode mode);
  xp::OverlayMode GetMode() const { return this->Mode; }
  ///@{
  /** The modes by name, as VTK's filters and Python set them. */
  void SetModeToCheckerboard() { this->SetMode(xp::OverlayMode::Checkerboard); }
  void SetModeToColourBlend() { this->SetMode(xp::OverlayMode::ColourBlend); }
  void SetModeToEdges() { this->SetMode(xp::OverlayMode::Edges); }
  void SetModeToMaskedXRay() { this->SetMode(xp::OverlayMode::MaskedXRay); }
  ///@}

protected:
  vtkXPOverlayFilter();
  ~vtkXPOverlayFilter() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPOverlayFilter(const vtkXPOverlayFilter&) = delete;
  void operator=(const vtkXPOverlayFilter&) = delete;

  xp::OverlayMode Mode = xp::OverlayMode::Checkerboard;
};

#endif
