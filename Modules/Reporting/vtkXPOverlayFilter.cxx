#include "vtkXPOverlayFilter.h"

#include "xpError.h"
#include "xpImageRows.h"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include <string>

vtkStandardNewMacro(vtkXPOverlayFilter);

vtkXPOverlayFilter::vtkXPOverlayFilter()
{
  this->SetNumberOfInputPorts(3);
  this->SetNumberOfOutputPorts(1);
}

void vtkXPOverlayFilter::SetMode(xp::OverlayMode mode)
{
  if (mode != this->Mode)
  {
    this->Mode = mode;
    this->Modified();
  }
}

int vtkXPOverlayFilter::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port == 2)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkXPOverlayFilter::RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  vtkDataObject::SetPointDataActiveScalarInfo(outputVector->GetInformationObject(0), VTK_UNSIGNED_CHAR, 3);
  return 1;
}

int vtkXPOverlayFilter::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  xp::RequestWholeExtents(inputVector, 3);
  return 1;
}

int vtkXPOverlayFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    vtkImageData* xray = vtkImageData::GetData(inputVector[0]);
    vtkImageData* drr = vtkImageData::GetData(inputVector[1]);
    vtkImageData* mask = this->GetNumberOfInputConnections(2) > 0 ? vtkImageData::GetData(inputVector[2]) : nullptr;
    int dims[3];
    xray->GetDimensions(dims);
    const char* names[3] = { "X-ray", "DRR", "mask" };
    vtkImageData* images[3] = { xray, drr, mask };
    for (int port = 0; port < 3; ++port)
    {
      if (!images[port])
        continue;
      int d[3];
      images[port]->GetDimensions(d);
      const int wanted = port < 2 ? VTK_UNSIGNED_SHORT : VTK_UNSIGNED_CHAR;
      if (d[0] != dims[0] || d[1] != dims[1] || d[2] != 1 || images[port]->GetScalarType() != wanted ||
        images[port]->GetNumberOfScalarComponents() != 1)
      {
        throw xp::InputError(names[port], std::string("must be a one-component 2D ") + (port < 2 ? "unsigned short" : "unsigned char") +
            " image with the X-ray's " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + " pixels");
      }
    }
    std::vector<uint8_t> valid;
    if (mask)
    {
      valid = xp::RowsTopFirst<uint8_t>(mask);
      for (uint8_t& v : valid)
        v = v != 0;
    }
    vtkSmartPointer<vtkImageData> overlay = xp::MakeOverlay(
      this->Mode, xp::RowsTopFirst<uint16_t>(xray), xp::RowsTopFirst<uint16_t>(drr), dims[0], dims[1], valid);
    vtkImageData* output = vtkImageData::GetData(outputVector);
    output->ShallowCopy(overlay);
    output->SetExtent(xray->GetExtent());
    output->SetOrigin(xray->GetOrigin());
    output->SetSpacing(xray->GetSpacing());
    output->SetDirectionMatrix(xray->GetDirectionMatrix());
  }
  catch (const xp::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPOverlayFilter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Mode: " << static_cast<int>(this->Mode) << "\n";
}
