#include "vtkXPStereoRegistrationFilter.h"

#include "vtkXPDRRFilter.h"
#include "xpError.h"
#include "xpImageGeometry.h"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include "xpImageRows.h"

vtkStandardNewMacro(vtkXPStereoRegistrationFilter);


vtkXPStereoRegistrationFilter::vtkXPStereoRegistrationFilter()
{
  this->SetNumberOfInputPorts(5);
  this->SetNumberOfOutputPorts(4);
}

void vtkXPStereoRegistrationFilter::SetGeometry(const xp::StereoGeometry& geometry)
{
  this->Geometry = geometry;
  this->Modified();
}

void vtkXPStereoRegistrationFilter::SetPatientSetup(const xp::PatientSetup& setup)
{
  if (setup != this->Setup)
  {
    this->Setup = setup;
    this->Modified();
  }
}

void vtkXPStereoRegistrationFilter::SetSettings(const xp::StereoRegistrationSettings& settings)
{
  this->Settings = settings;
  this->Modified();
}

int vtkXPStereoRegistrationFilter::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port >= 3)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestInformation(
  vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  for (int port = 0; port < 4; ++port)
  {
    vtkInformation* in = inputVector[1 + port % 2]->GetInformationObject(0);
    vtkInformation* out = outputVector->GetInformationObject(port);
    out->CopyEntry(in, vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT());
    out->CopyEntry(in, vtkDataObject::SPACING());
    out->CopyEntry(in, vtkDataObject::ORIGIN());
    vtkDataObject::SetPointDataActiveScalarInfo(out, port < 2 ? VTK_UNSIGNED_SHORT : VTK_UNSIGNED_CHAR, 1);
  }
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  xp::RequestWholeExtents(inputVector, 5);
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    xp::ValidateStereoGeometry(this->Geometry, "registration geometry");
    vtkImageData* ct = vtkImageData::GetData(inputVector[0]);
    const std::unique_ptr<xp::AttenuationVolume> volume = xp::MakeAttenuationVolume(ct, this->MuWater);
    if ((this->Setup.roomIsocenter - this->Geometry.isocenter).norm() > 1e-6)
    {
      throw xp::InputError("patient set-up: room isocentre", "differs from the geometry's isocentre");
    }
    const Eigen::Isometry3d planned = this->Setup.PlannedCTToRoom(xp::ImageCenter(ct));
    std::vector<xp::RegistrationView> views;
    for (int v = 0; v < 2; ++v)
    {
      vtkImageData* xray = vtkImageData::GetData(inputVector[1 + v]);
      vtkImageData* roi = this->GetNumberOfInputConnections(3 + v) > 0 ? vtkImageData::GetData(inputVector[3 + v]) : nullptr;
      const xp::XRayView& view = this->Geometry.views[v];
      int dims[3];
      xray->GetDimensions(dims);
      if (xray->GetScalarType() != VTK_UNSIGNED_SHORT || dims[0] != view.Columns() || dims[1] != view.Rows())
      {
        throw xp::InputError("X-ray " + view.name, "must be unsigned short with the view's " + std::to_string(view.Columns()) +
            "x" + std::to_string(view.Rows()) + " pixels");
      }
      xp::RegistrationView item;
      item.view = view;
      item.xray = xp::RowsTopFirst<uint16_t>(xray);
      if (roi)
      {
        int r[3];
        roi->GetDimensions(r);
        if (roi->GetScalarType() != VTK_UNSIGNED_CHAR || r[0] != dims[0] || r[1] != dims[1])
        {
          throw xp::InputError("ROI " + view.name, "must be unsigned char with the X-ray's size");
        }
        item.mask = xp::RowsTopFirst<uint8_t>(roi);
        for (uint8_t& m : item.mask)
          m = m ? 1 : 0;
      }
      views.push_back(std::move(item));
    }
    this->Result = xp::RegisterStereo(*volume, planned, this->Geometry.isocenter, views, this->Settings);
    for (int v = 0; v < 2; ++v)
    {
      for (int kind = 0; kind < 2; ++kind)
      {
        vtkImageData* out = vtkImageData::GetData(outputVector, 2 * kind + v);
        out->CopyStructure(vtkImageData::GetData(inputVector[1 + v]));
        out->AllocateScalars(kind == 0 ? VTK_UNSIGNED_SHORT : VTK_UNSIGNED_CHAR, 1);
        if (kind == 0)
          xp::CopyRowsTopFirst<uint16_t>(this->Result.drrs[v], out);
        else
          xp::CopyRowsTopFirst<uint8_t>(this->Result.masks[v], out, 255);
      }
    }
  }
  catch (const xp::Error& e)
  {
    this->Result = xp::StereoRegistrationResult{};
    this->Result.reasons.push_back(e.what());
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPStereoRegistrationFilter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "Geometry: " << this->Geometry.name << " (" << this->Geometry.views.size() << " views)\n";
  os << indent << "PatientSetup: " << this->Setup.Describe() << "\n";
  os << indent << "MuWater: " << this->MuWater << "\n";
  os << indent << "EntropyMask: " << this->Settings.entropyMask << ", bins " << this->Settings.bins
     << ", max evaluations " << this->Settings.maxEvaluations << "\n";
  os << indent << "Result: " << (this->Result.ok ? "ok" : "failed or not run") << ", " << this->Result.misalignment.ToString() << "\n";
}
