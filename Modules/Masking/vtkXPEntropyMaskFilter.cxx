#include "vtkXPEntropyMaskFilter.h"

#include "xpEntropyMask.h"
#include "xpError.h"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include "xpImageRows.h"

#include <algorithm>
#include <string>

vtkStandardNewMacro(vtkXPEntropyMaskFilter);

vtkXPEntropyMaskFilter::vtkXPEntropyMaskFilter()
{
  this->SetNumberOfInputPorts(2);
  this->SetNumberOfOutputPorts(2);
}

int vtkXPEntropyMaskFilter::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port == 1)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkXPEntropyMaskFilter::RequestInformation(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  // Same grid as the X-ray; only the scalar types differ.
  vtkInformation* in = inputVector[0]->GetInformationObject(0);
  for (int port = 0; port < 2; ++port)
  {
    vtkInformation* out = outputVector->GetInformationObject(port);
    out->CopyEntry(in, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    out->CopyEntry(in, vtkDataObject::SPACING());
    out->CopyEntry(in, vtkDataObject::ORIGIN());
    out->CopyEntry(in, vtkDataObject::DIRECTION());
    vtkDataObject::SetPointDataActiveScalarInfo(out, port == 0 ? VTK_UNSIGNED_CHAR : VTK_FLOAT, 1);
  }
  return 1;
}

int vtkXPEntropyMaskFilter::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // Block entropies and H(X) need the whole image.
  xp::RequestWholeExtents(inputVector, 2);
  return 1;
}

int vtkXPEntropyMaskFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    vtkImageData* xray = vtkImageData::GetData(inputVector[0]);
    vtkImageData* roi = this->GetNumberOfInputConnections(1) > 0 ? vtkImageData::GetData(inputVector[1]) : nullptr;
    int dims[3];
    xray->GetDimensions(dims);
    if (xray->GetScalarType() != VTK_UNSIGNED_SHORT || xray->GetNumberOfScalarComponents() != 1 || dims[2] != 1)
    {
      throw xp::InputError("X-ray input", "must be a one-component 2D unsigned short image (12-bit values)");
    }
    if (roi)
    {
      int r[3];
      roi->GetDimensions(r);
      if (r[0] != dims[0] || r[1] != dims[1] || roi->GetScalarType() != VTK_UNSIGNED_CHAR)
      {
        throw xp::InputError("ROI input", "must be unsigned char with the X-ray's " + std::to_string(dims[0]) + "x" +
            std::to_string(dims[1]) + " pixels");
      }
    }
    xp::EntropyMaskSettings settings;
    settings.window = this->WindowSize;
    settings.binWidth = this->BinWidth;
    settings.thresholdScale = this->ThresholdScale;
    const xp::EntropyMaskResult result = xp::ComputeEntropyMask(static_cast<const uint16_t*>(xray->GetScalarPointer()),
      dims[0], dims[1], roi ? static_cast<const uint8_t*>(roi->GetScalarPointer()) : nullptr, settings);
    this->ImageEntropy = result.imageEntropy;
    this->ValidFraction = result.validFraction;

    vtkImageData* mask = vtkImageData::GetData(outputVector, 0);
    vtkImageData* entropy = vtkImageData::GetData(outputVector, 1);
    for (vtkImageData* out : { mask, entropy })
    {
      out->CopyStructure(xray);
    }
    mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    entropy->AllocateScalars(VTK_FLOAT, 1);
    auto* m = static_cast<uint8_t*>(mask->GetScalarPointer());
    std::transform(result.mask.begin(), result.mask.end(), m, [](uint8_t v) { return static_cast<uint8_t>(v ? 255 : 0); });
    std::copy(result.entropy.begin(), result.entropy.end(), static_cast<float*>(entropy->GetScalarPointer()));
  }
  catch (const xp::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPEntropyMaskFilter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "WindowSize: " << this->WindowSize << "\n";
  os << indent << "BinWidth: " << this->BinWidth << "\n";
  os << indent << "ThresholdScale: " << this->ThresholdScale << "\n";
  os << indent << "ImageEntropy: " << this->ImageEntropy << "\n";
  os << indent << "ValidFraction: " << this->ValidFraction << "\n";
}
