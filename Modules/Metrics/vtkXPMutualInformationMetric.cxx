#include "vtkXPMutualInformationMetric.h"

#include "xpError.h"
#include "xpMutualInformation.h"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include "xpImageRows.h"

#include <string>

vtkStandardNewMacro(vtkXPMutualInformationMetric);

vtkXPMutualInformationMetric::vtkXPMutualInformationMetric()
{
  this->SetNumberOfInputPorts(4);
  this->SetNumberOfOutputPorts(1);
}

int vtkXPMutualInformationMetric::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port >= 2)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkXPMutualInformationMetric::RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkInformation* info = outputVector->GetInformationObject(0);
  const int extent[6] = { 0, this->NumberOfBins - 1, 0, this->NumberOfBins - 1, 0, 0 };
  const double spacing[3] = { 1, 1, 1 }, origin[3] = { 0, 0, 0 };
  info->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  info->Set(vtkDataObject::SPACING(), spacing, 3);
  info->Set(vtkDataObject::ORIGIN(), origin, 3);
  vtkDataObject::SetPointDataActiveScalarInfo(info, VTK_FLOAT, 1);
  return 1;
}

int vtkXPMutualInformationMetric::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  xp::RequestWholeExtents(inputVector, 4);
  return 1;
}

int vtkXPMutualInformationMetric::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    vtkImageData* images[4] = {};
    for (int port = 0; port < 4; ++port)
    {
      images[port] = this->GetNumberOfInputConnections(port) > 0 ? vtkImageData::GetData(inputVector[port]) : nullptr;
    }
    int dims[3];
    images[0]->GetDimensions(dims);
    const char* names[4] = { "fixed image", "moving image", "fixed mask", "moving mask" };
    for (int port = 0; port < 4; ++port)
    {
      if (!images[port])
        continue;
      int d[3];
      images[port]->GetDimensions(d);
      const int wanted = port < 2 ? VTK_UNSIGNED_SHORT : VTK_UNSIGNED_CHAR;
      if (d[0] != dims[0] || d[1] != dims[1] || d[2] != dims[2] || images[port]->GetScalarType() != wanted ||
        images[port]->GetNumberOfScalarComponents() != 1)
      {
        throw xp::InputError(names[port], std::string("must be one-component ") + (port < 2 ? "unsigned short" : "unsigned char") +
            " with the fixed image's " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " pixels");
      }
    }
    const long long count = static_cast<long long>(dims[0]) * dims[1] * dims[2];
    const auto* fixed = static_cast<const uint16_t*>(images[0]->GetScalarPointer());
    const auto* moving = static_cast<const uint16_t*>(images[1]->GetScalarPointer());
    const auto* fixedMask = images[2] ? static_cast<const uint8_t*>(images[2]->GetScalarPointer()) : nullptr;
    const auto* movingMask = images[3] ? static_cast<const uint8_t*>(images[3]->GetScalarPointer()) : nullptr;
    xp::JointHistogram histogram(this->NumberOfBins);
    histogram.Compute(fixed, moving, count, fixedMask, movingMask);
    this->MutualInformation = histogram.MutualInformation();
    this->NormalizedMutualInformation = histogram.NormalizedMutualInformation();
    this->NormalizedCrossCorrelation = xp::PearsonCorrelation(fixed, moving, static_cast<size_t>(count), fixedMask, movingMask);
    this->NumberOfValidPixels = histogram.Samples();

    vtkImageData* output = vtkImageData::GetData(outputVector);
    output->SetExtent(0, this->NumberOfBins - 1, 0, this->NumberOfBins - 1, 0, 0);
    output->AllocateScalars(VTK_FLOAT, 1);
    auto* out = static_cast<float*>(output->GetScalarPointer());
    const int bins = this->NumberOfBins;
    for (int f = 0; f < bins; ++f)
      for (int m = 0; m < bins; ++m)
        out[m * bins + f] = static_cast<float>(histogram.Counts()[static_cast<size_t>(f) * bins + m]);
  }
  catch (const xp::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPMutualInformationMetric::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "NumberOfBins: " << this->NumberOfBins << "\n";
  os << indent << "MutualInformation: " << this->MutualInformation << "\n";
  os << indent << "NormalizedMutualInformation: " << this->NormalizedMutualInformation << "\n";
  os << indent << "NormalizedCrossCorrelation: " << this->NormalizedCrossCorrelation << "\n";
  os << indent << "NumberOfValidPixels: " << this->NumberOfValidPixels << "\n";
}
