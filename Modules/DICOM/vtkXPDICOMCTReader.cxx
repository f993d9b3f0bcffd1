#include "vtkXPDICOMCTReader.h"

#include "xpDICOMSeries.h"
#include "xpError.h"
#include "xpPageMemory.h"

#include <vtkFloatArray.h>
#include <vtkShortArray.h>
#include <vtkImageData.h>
#include <vtkInformation.h>
#include <vtkInformationVector.h>
#include <vtkObjectFactory.h>
#include <vtkPointData.h>
#include <vtkStreamingDemandDrivenPipeline.h>


vtkStandardNewMacro(vtkXPDICOMCTReader);

vtkXPDICOMCTReader::vtkXPDICOMCTReader()
{
  this->SetNumberOfInputPorts(0);
}

vtkXPDICOMCTReader::~vtkXPDICOMCTReader() = default;

std::string vtkXPDICOMCTReader::GetPatientPosition() const
{
  return this->Info ? this->Info->patientPosition : std::string();
}

int vtkXPDICOMCTReader::RequestInformation(
  vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  this->ErrorText.clear();
  try
  {
    this->Info = std::make_unique<xp::CTSeriesInfo>(xp::ScanCTSeries(this->DirectoryName, this->SeriesInstanceUID));
  }
  catch (const xp::Error& e)
  {
    this->Info.reset();
    this->ErrorText = e.what();
    vtkErrorMacro(<< e.what());
    return 0;
  }
  const xp::CTSeriesInfo& info = *this->Info;
  const int extent[6] = { 0, info.columns - 1, 0, info.rows - 1, 0, static_cast<int>(info.files.size()) - 1 };
  double direction[9];
  for (int r = 0; r < 3; ++r)
  {
    for (int c = 0; c < 3; ++c)
    {
      direction[3 * r + c] = info.direction(r, c);
    }
  }
  vtkInformation* outInfo = outputVector->GetInformationObject(0);
  outInfo->Set(vtkStreamingDemandDrivenPipeline::WHOLE_EXTENT(), extent, 6);
  outInfo->Set(vtkDataObject::SPACING(), info.spacing.data(), 3);
  outInfo->Set(vtkDataObject::ORIGIN(), info.origin.data(), 3);
  outInfo->Set(vtkDataObject::DIRECTION(), direction, 9);
  vtkDataObject::SetPointDataActiveScalarInfo(outInfo, info.wholeHU16 ? VTK_SHORT : VTK_FLOAT, 1);
  return 1;
}

int vtkXPDICOMCTReader::RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector* outputVector)
{
  if (!this->Info)
  {
    return 0;
  }
  const xp::CTSeriesInfo& info = *this->Info;
  vtkImageData* output = vtkImageData::GetData(outputVector);
  const vtkIdType count = static_cast<vtkIdType>(info.columns) * info.rows * static_cast<vtkIdType>(info.files.size());
  vtkSmartPointer<vtkDataArray> scalars;
  try
  {
    // Filled once by the threads that decode it, then read out of order (xpPageMemory.h).
    if (info.wholeHU16)
    {
      vtkSmartPointer<vtkShortArray> values = xp::NewPageShortArray(count);
      xp::ReadCTSeriesVoxels(info, values->GetPointer(0));
      scalars = values;
    }
    else
    {
      vtkSmartPointer<vtkFloatArray> values = xp::NewPageFloatArray(count);
      xp::ReadCTSeriesVoxels(info, values->GetPointer(0));
      scalars = values;
    }
  }
  catch (const xp::Error& e)
  {
    this->ErrorText = e.what();
    vtkErrorMacro(<< e.what());
    return 0;
  }
  scalars->SetName("HU");
  output->SetDimensions(info.columns, info.rows, static_cast<int>(info.files.size()));
  output->SetSpacing(info.spacing.data());
  output->SetOrigin(info.origin.data());
  output->SetDirectionMatrix(info.direction(0, 0), info.direction(0, 1), info.direction(0, 2), info.direction(1, 0),
    info.direction(1, 1), info.direction(1, 2), info.direction(2, 0), info.direction(2, 1), info.direction(2, 2));
  output->GetPointData()->SetScalars(scalars);
  return 1;
}

void vtkXPDICOMCTReader::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "DirectoryName: " << this->DirectoryName << "\n";
  os << indent << "SeriesInstanceUID: " << this->SeriesInstanceUID << "\n";
  os << indent << "PatientPosition: " << this->GetPatientPosition() << "\n";
}
