/**
 * @class vtkXPEntropyMaskFilter
 * @brief Block-entropy validity mask of a 12-bit X-ray (Method.md, stage 2), AND a user ROI.
 *
 * Port 0: the X-ray (unsigned short, 12-bit values). Port 1 (optional): a user ROI of the same
 * size (unsigned char, non-zero = allowed). Output 0: the mask (unsigned char, 255 valid, 0 not);
 * output 1: the block-entropy map (float, 0..1). Both on the input's grid.
 */
#ifndef vtkXPEntropyMaskFilter_h
#define vtkXPEntropyMaskFilter_h

#include "vtkImageAlgorithm.h"
#include "vtkXPMaskingModule.h"

class VTKXPMASKING_EXPORT vtkXPEntropyMaskFilter : public vtkImageAlgorithm
{
public:
  static vtkXPEntropyMaskFilter* New();
  vtkTypeMacro(vtkXPEntropyMaskFilter, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetROIConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }

  ///@{
  /** Block size at half resolution (odd; default 7, i.e. 14x14 pixels at full size). */
  vtkSetClampMacro(WindowSize, int, 3, 63);
  vtkGetMacro(WindowSize, int);
  ///@}
  ///@{
  /** Grey levels per histogram bin (default 32: 128 bins on 12-bit images). */
  vtkSetClampMacro(BinWidth, int, 1, 4095);
  vtkGetMacro(BinWidth, int);
  ///@}
  ///@{
  /** Valid where H(W) >= ThresholdScale * H(X) (default 1: the paper's rule). */
  vtkSetClampMacro(ThresholdScale, double, 0.0, 10.0);
  vtkGetMacro(ThresholdScale, double);
  ///@}

  /** H(X), the mean block entropy, and the valid fraction of the last update. */
  vtkGetMacro(ImageEntropy, double);
  vtkGetMacro(ValidFraction, double);

protected:
  vtkXPEntropyMaskFilter();
  ~vtkXPEntropyMaskFilter() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPEntropyMaskFilter(const vtkXPEntropyMaskFilter&) = delete;
  void operator=(const vtkXPEntropyMaskFilter&) = delete;

  int WindowSize = 7;
  int BinWidth = 32;
  double ThresholdScale = 1.0;
  double ImageEntropy = 0.0;
  double ValidFraction = 0.0;
};

#endif
