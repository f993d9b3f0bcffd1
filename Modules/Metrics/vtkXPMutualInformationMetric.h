/**
 * @class vtkXPMutualInformationMetric
 * @brief Similarity of two 12-bit images over the pixels valid in both masks.
 *
 * Port 0: fixed image (X-ray), port 1: moving image (DRR), both unsigned short of one size.
 * Ports 2 and 3 (optional): unsigned char masks for the fixed and the moving image (non-zero =
 * valid). Output: the joint histogram as a bins x bins float image (fixed bin along x), for
 * reports. After Update: mutual information, normalised MI, NCC and the valid pixel count.
 */
#ifndef vtkXPMutualInformationMetric_h
#define vtkXPMutualInformationMetric_h

#include "vtkImageAlgorithm.h"
#include "vtkXPMetricsModule.h"

class VTKXPMETRICS_EXPORT vtkXPMutualInformationMetric : public vtkImageAlgorithm
{
public:
  static vtkXPMutualInformationMetric* New();
  vtkTypeMacro(vtkXPMutualInformationMetric, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  void SetFixedConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(0, output); }
  void SetMovingConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(1, output); }
  void SetFixedMaskConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(2, output); }
  void SetMovingMaskConnection(vtkAlgorithmOutput* output) { this->SetInputConnection(3, output); }

  ///@{
  /** Histogram bins per axis (32 to 64 is typical). */
  vtkSetClampMacro(NumberOfBins, int, 2, 1024);
  vtkGetMacro(NumberOfBins, int);
  ///@}

  vtkGetMacro(MutualInformation, double);
  vtkGetMacro(NormalizedMutualInformation, double);
  vtkGetMacro(NormalizedCrossCorrelation, double);
  vtkGetMacro(NumberOfValidPixels, long long);

protected:
  vtkXPMutualInformationMetric();
  ~vtkXPMutualInformationMetric() override = default;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

private:
  vtkXPMutualInformationMetric(const vtkXPMutualInformationMetric&) = delete;
  void operator=(const vtkXPMutualInformationMetric&) = delete;

  int NumberOfBins = 64;
  double MutualInformation = 0.0;
  double NormalizedMutualInformation = 1.0;
  double NormalizedCrossCorrelation = 0.0;
  long long NumberOfValidPixels = 0;
};

#endif
