#include "vtkXPStereoRegistrationFilter.h"

#include "vtkXPDRRFilter.h"
#include "xpError.h"

#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkStreamingDemandDrivenPipeline.h>

vtkStandardNewMacro(vtkXPStereoRegistrationFilter);

namespace
{

/** VTK rows run up; the kernels keep row 0 first. */
template <typename T>
std::vector<T> TopRowFirst(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  const T* in = static_cast<const T*>(image->GetScalarPointer());
  std::vector<T> out(static_cast<size_t>(dims[0]) * dims[1]);
  for (int row = 0; row < dims[1]; ++row)
    std::copy(in + static_cast<size_t>(dims[1] - 1 - row) * dims[0], in + static_cast<size_t>(dims[1] - row) * dims[0],
      out.begin() + static_cast<size_t>(row) * dims[0]);
  return out;
}

template <typename T>
void BottomRowFirst(const std::vector<T>& image, int columns, int rows, T scale, vtkImageData* out)
{
  T* p = static_cast<T*>(out->GetScalarPointer());
  for (int row = 0; row < rows; ++row)
    for (int column = 0; column < columns; ++column)
      p[static_cast<size_t>(rows - 1 - row) * columns + column] = static_cast<T>(image[static_cast<size_t>(row) * columns + column] * scale);
}

} // namespace

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

void vtkXPStereoRegistrationFilter::SetPatientPosition(xp::PatientPosition position)
{
  this->Position = position;
  this->Modified();
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
  for (int port = 0; port < 5; ++port)
  {
    if (vtkInformation* info = inputVector[port]->GetInformationObject(0))
    {
      int whole[6];
      info->Get(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), whole);
      info->Set(vtkStreamingDemandDrivenPipeline::UPDATE_EXTENT(), whole, 6);
    }
  }
  return 1;
}

int vtkXPStereoRegistrationFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  try
  {
    xp::ValidateStereoGeometry(this->Geometry, "registration geometry");
    vtkImageData* ct = vtkImageData::GetData(inputVector[0]);
    const std::unique_ptr<xp::AttenuationVolume> volume = xp::MakeAttenuationVolume(ct, this->MuWater);
    Eigen::Vector3d isoInCT(this->IsocenterInCT);
    if (this->UseCTCenterAsIsocenter)
    {
      int extent[6];
      ct->GetExtent(extent);
      const double middle[3] = { 0.5 * (extent[0] + extent[1]), 0.5 * (extent[2] + extent[3]), 0.5 * (extent[4] + extent[5]) };
      ct->TransformContinuousIndexToPhysicalPoint(middle, isoInCT.data());
    }
    const Eigen::Isometry3d planned = xp::PlannedCTToRoom(this->Position, isoInCT, this->Geometry.isocenter);
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
      item.xray = TopRowFirst<uint16_t>(xray);
      if (roi)
      {
        int r[3];
        roi->GetDimensions(r);
        if (roi->GetScalarType() != VTK_UNSIGNED_CHAR || r[0] != dims[0] || r[1] != dims[1])
        {
          throw xp::InputError("ROI " + view.name, "must be unsigned char with the X-ray's size");
        }
        item.mask = TopRowFirst<uint8_t>(roi);
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
        const int columns = views[v].view.Columns(), rows = views[v].view.Rows();
        if (kind == 0)
          BottomRowFirst<uint16_t>(this->Result.drrs[v], columns, rows, 1, out);
        else
          BottomRowFirst<uint8_t>(this->Result.masks[v], columns, rows, 255, out);
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
  os << indent << "PatientPosition: " << xp::ToString(this->Position) << "\n";
  os << indent << "UseCTCenterAsIsocenter: " << this->UseCTCenterAsIsocenter << "\n";
  os << indent << "MuWater: " << this->MuWater << "\n";
  os << indent << "EntropyMask: " << this->Settings.entropyMask << ", bins " << this->Settings.bins
     << ", max evaluations " << this->Settings.maxEvaluations << "\n";
  os << indent << "Result: " << (this->Result.ok ? "ok" : "failed or not run") << ", " << this->Result.misalignment.ToString() << "\n";
}
