#include "vtkXPDRRFilter.h"

#include "xpCatchErrors.h"
#include "xpStereoGeometry.h"

#include "xpAttenuationVolume.h"
#include "xpError.h"
#include "xpImageGeometry.h"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>

#include "xpImageRows.h"

#include <chrono>
#include <stdexcept>
#include <string>
#include <vector>

vtkStandardNewMacro(vtkXPDRRFilter);

vtkXPDRRFilter::vtkXPDRRFilter()
{
  this->SetNumberOfInputPorts(2);
  this->SetNumberOfOutputPorts(3);
}

vtkXPDRRFilter::~vtkXPDRRFilter() = default;

void vtkXPDRRFilter::SetView(const xp::XRayView& view)
{
  this->View = view;
  this->Modified();
}

void vtkXPDRRFilter::SetPatientSetup(const xp::PatientSetup& setup)
{
  if (setup != this->Setup)
  {
    this->Setup = setup;
    this->Modified();
  }
}

void vtkXPDRRFilter::SetMisalignment(const xp::Pose& pose)
{
  this->Misalignment = pose;
  this->Modified();
}

bool vtkXPDRRFilter::SetViewFromGeometryFile(const char* path, int viewIndex)
{
  return xp::CatchErrors(this, this->LastError, [&]
    {
      const xp::StereoGeometry geometry = xp::ReadStereoGeometry(path ? path : "");
      if (viewIndex < 0 || viewIndex >= static_cast<int>(geometry.views.size()))
        throw xp::InputError(path, "has no view " + std::to_string(viewIndex));
      this->SetView(geometry.views[viewIndex]);
      xp::PatientSetup setup = this->Setup;
      setup.roomIsocenter = geometry.isocenter;
      this->SetPatientSetup(setup);
    });
}

bool vtkXPDRRFilter::SetPatientPosition(const char* dicomPatientPosition)
{
  return xp::CatchErrors(this, this->LastError, [&]
    {
      xp::PatientSetup setup = this->Setup;
      setup.position = xp::ParsePatientPosition(dicomPatientPosition ? dicomPatientPosition : "", "patient position");
      this->SetPatientSetup(setup);
    });
}

void vtkXPDRRFilter::SetIsocenterInCT(double x, double y, double z)
{
  xp::PatientSetup setup = this->Setup;
  setup.isocenterInCT = Eigen::Vector3d(x, y, z);
  this->SetPatientSetup(setup);
}

void vtkXPDRRFilter::SetMisalignmentParameters(double tx, double ty, double tz, double pitch, double roll, double yaw)
{
  const double parameters[6] = { tx, ty, tz, pitch, roll, yaw };
  this->SetMisalignment(xp::Pose::FromParameters(parameters));
}

xp::XRayView vtkXPDRRFilter::GetOutputView() const
{
  if (this->OutputSize[0] > 0 && this->OutputSize[1] > 0)
  {
    return this->View.Resampled(this->OutputSize[0], this->OutputSize[1]);
  }
  return this->View;
}

int vtkXPDRRFilter::FillInputPortInformation(int port, vtkInformation* info)
{
  info->Set(vtkAlgorithm::INPUT_REQUIRED_DATA_TYPE(), "vtkImageData");
  if (port == 1)
  {
    info->Set(vtkAlgorithm::INPUT_IS_OPTIONAL(), 1);
  }
  return 1;
}

int vtkXPDRRFilter::FillOutputPortInformation(int, vtkInformation* info)
{
  info->Set(vtkDataObject::DATA_TYPE_NAME(), "vtkImageData");
  return 1;
}

int vtkXPDRRFilter::RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  const xp::XRayView view = this->GetOutputView();
  if (view.Columns() < 1 || view.Rows() < 1)
  {
    vtkErrorMacro(<< "no view set");
    return 0;
  }
  // Rows bottom-up: VTK row 0 is detector row rows-1, so the j axis runs against column_direction.
  const Eigen::Vector3d origin = view.PixelCenter(0, view.Rows() - 1);
  const Eigen::Vector3d jAxis = -view.columnDirection;
  const Eigen::Vector3d kAxis = view.rowDirection.cross(jAxis);
  const double direction[9] = { view.rowDirection[0], jAxis[0], kAxis[0], view.rowDirection[1], jAxis[1], kAxis[1],
    view.rowDirection[2], jAxis[2], kAxis[2] };
  const double spacing[3] = { view.pixelSpacing[0], view.pixelSpacing[1], 1.0 };
  const int extent[6] = { 0, view.Columns() - 1, 0, view.Rows() - 1, 0, 0 };
  const int types[3] = { VTK_UNSIGNED_SHORT, VTK_FLOAT, VTK_UNSIGNED_CHAR };
  for (int port = 0; port < 3; ++port)
  {
    vtkInformation* info = outputVector->GetInformationObject(port);
    info->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
    info->Set(vtkDataObject::SPACING(), spacing, 3);
    info->Set(vtkDataObject::ORIGIN(), origin.data(), 3);
    info->Set(vtkDataObject::DIRECTION(), direction, 9);
    vtkDataObject::SetPointDataActiveScalarInfo(info, types[port], 1);
  }
  return 1;
}

int vtkXPDRRFilter::RequestUpdateExtent(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector*)
{
  // Every ray may cross any part of the CT, and the mask covers the whole panel.
  xp::RequestWholeExtents(inputVector, 2);
  return 1;
}

std::unique_ptr<xp::AttenuationVolume> xp::MakeAttenuationVolume(
  vtkImageData* ct, double muWater, const std::vector<uint8_t>* keepFlags)
{
  vtkDataArray* scalars = ct ? ct->GetPointData()->GetScalars() : nullptr;
  if (!scalars || scalars->GetNumberOfComponents() != 1)
  {
    throw xp::InputError("CT input", "needs one scalar component in HU");
  }
  int dims[3];
  ct->GetDimensions(dims);
  const Eigen::Vector3i size(dims[0], dims[1], dims[2]);
  if (keepFlags && keepFlags->size() != static_cast<size_t>(scalars->GetNumberOfTuples()))
  {
    throw std::invalid_argument("MakeAttenuationVolume: " + std::to_string(keepFlags->size()) +
      " voxels to keep or leave out for a CT of " + std::to_string(scalars->GetNumberOfTuples()));
  }
  const uint8_t* keep = keepFlags ? keepFlags->data() : nullptr;
  // The readers keep HU as 16-bit integers or floats; other types are converted here.
  if (scalars->GetDataType() == VTK_SHORT)
  {
    return std::make_unique<xp::AttenuationVolume>(
      static_cast<const int16_t*>(scalars->GetVoidPointer(0)), keep, size, xp::IndexToPhysical(ct), muWater);
  }
  std::vector<float> hu;
  const float* values = nullptr;
  if (scalars->GetDataType() == VTK_FLOAT)
  {
    values = static_cast<const float*>(scalars->GetVoidPointer(0));
  }
  else
  {
    hu.resize(static_cast<size_t>(scalars->GetNumberOfTuples()));
    for (vtkIdType i = 0; i < scalars->GetNumberOfTuples(); ++i)
    {
      hu[i] = static_cast<float>(scalars->GetTuple1(i));
    }
    values = hu.data();
  }
  return std::make_unique<xp::AttenuationVolume>(values, keep, size, xp::IndexToPhysical(ct), muWater);
}

const xp::AttenuationVolume& vtkXPDRRFilter::Attenuation(vtkImageData* ct)
{
  if (!this->Volume || ct->GetMTime() != this->VolumeTime || this->MuWater != this->VolumeMuWater)
  {
    this->Volume = xp::MakeAttenuationVolume(ct, this->MuWater);
    this->VolumeTime = ct->GetMTime();
    this->VolumeMuWater = this->MuWater;
  }
  return *this->Volume;
}

int vtkXPDRRFilter::RequestData(vtkInformation*, vtkInformationVector** inputVector, vtkInformationVector* outputVector)
{
  vtkImageData* ct = vtkImageData::GetData(inputVector[0]);
  vtkImageData* maskImage = this->GetNumberOfInputConnections(1) > 0 ? vtkImageData::GetData(inputVector[1]) : nullptr;
  const xp::XRayView view = this->GetOutputView();
  const long long count = static_cast<long long>(view.Columns()) * view.Rows();
  try
  {
    if (!ct || ct->GetNumberOfPoints() == 0)
    {
      throw xp::InputError("CT input", "empty");
    }
    const uint8_t* mask = nullptr;
    if (maskImage)
    {
      int dims[3];
      maskImage->GetDimensions(dims);
      if (dims[0] != view.Columns() || dims[1] != view.Rows() || maskImage->GetScalarType() != VTK_UNSIGNED_CHAR ||
        maskImage->GetNumberOfScalarComponents() != 1)
      {
        throw xp::InputError("mask input", "must be unsigned char with the output's " + std::to_string(view.Columns()) +
            "x" + std::to_string(view.Rows()) + " pixels, got " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]));
      }
      mask = static_cast<const uint8_t*>(maskImage->GetScalarPointer());
    }
    using Clock = std::chrono::steady_clock;
    const Clock::time_point prepareStart = Clock::now();
    const xp::AttenuationVolume& volume = this->Attenuation(ct);
    const Clock::time_point renderStart = Clock::now();
    this->LastPreparationSeconds = std::chrono::duration<double>(renderStart - prepareStart).count();
    const Eigen::Isometry3d ctToRoom = xp::MisalignedCTToRoom(
      this->Setup.PlannedCTToRoom(xp::ImageCenter(ct)), this->Misalignment, this->Setup.roomIsocenter);

    vtkImageData* outputs[3];
    for (int port = 0; port < 3; ++port)
    {
      outputs[port] = vtkImageData::GetData(outputVector, port);
      outputs[port]->SetExtent(0, view.Columns() - 1, 0, view.Rows() - 1, 0, 0);
    }
    outputs[0]->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    outputs[1]->AllocateScalars(VTK_FLOAT, 1);
    outputs[2]->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
    outputs[0]->GetPointData()->GetScalars()->SetName("Transmission12");
    outputs[1]->GetPointData()->GetScalars()->SetName("LineIntegral");
    outputs[2]->GetPointData()->GetScalars()->SetName("Valid");
    float* integrals = static_cast<float*>(outputs[1]->GetScalarPointer());
    xp::RayCastSettings settings;
    settings.method = this->Method == 1 ? xp::RayCastMethod::Siddon : xp::RayCastMethod::Trilinear;
    settings.stepSize = this->StepSize;
    settings.device = this->Device == 1 ? xp::ComputeDevice::CUDA : xp::ComputeDevice::CPU;
    this->NumberOfTracedRays = xp::RenderLineIntegrals(
      volume, ctToRoom, view.source, xp::DetectorGrid::BottomRowFirst(view), mask, integrals, settings);
    this->LastRenderSeconds = std::chrono::duration<double>(Clock::now() - renderStart).count();
    xp::LineIntegralsTo12Bit(integrals, mask, count, static_cast<uint16_t*>(outputs[0]->GetScalarPointer()));
    uint8_t* valid = static_cast<uint8_t*>(outputs[2]->GetScalarPointer());
    for (long long i = 0; i < count; ++i)
    {
      valid[i] = (!mask || mask[i]) ? 255 : 0;
    }
  }
  catch (const xp::Error& e)
  {
    vtkErrorMacro(<< e.what());
    return 0;
  }
  return 1;
}

void vtkXPDRRFilter::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "View: " << this->View.name << " (" << this->View.Columns() << "x" << this->View.Rows() << ")\n";
  os << indent << "OutputSize: " << this->OutputSize[0] << " " << this->OutputSize[1] << "\n";
  os << indent << "PatientSetup: " << this->Setup.Describe() << "\n";
  os << indent << "Misalignment: " << this->Misalignment.ToString() << "\n";
  os << indent << "MuWater: " << this->MuWater << "\n";
  os << indent << "StepSize: " << this->StepSize << "\n";
  os << indent << "Method: " << (this->Method == 1 ? "Siddon" : "Trilinear") << "\n";
  os << indent << "Device: " << (this->Device == 1 ? "CUDA" : "CPU") << "\n";
}
