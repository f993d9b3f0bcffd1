#include "xpRegistrationWriters.h"

#include "vtkXPStereoRegistrationFilter.h"
#include "xpDICOMXRay.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpImageRows.h"
#include "xpRTImageGeometry.h"
#include "xpRegistrationSession.h"
#include "xpSpatialRegistration.h"

#include <vtkImageData.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <optional>
#include <sys/stat.h>

namespace xp
{

namespace
{

/** A float map in [0, 1] as 8-bit grey. */
vtkSmartPointer<vtkImageData> EntropyAsGrey(vtkImageData* map)
{
  auto grey = vtkSmartPointer<vtkImageData>::New();
  grey->CopyStructure(map);
  grey->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  const auto* in = static_cast<const float*>(map->GetScalarPointer());
  auto* out = static_cast<uint8_t*>(grey->GetScalarPointer());
  for (vtkIdType i = 0; i < map->GetNumberOfPoints(); ++i)
    out[i] = static_cast<uint8_t>(std::lround(255.0 * std::clamp(in[i], 0.0f, 1.0f)));
  return grey;
}

} // namespace

void WriteRegistrationFolder(const RegistrationSession& session, const std::string& directory)
{
  vtkXPStereoRegistrationFilter* registration = session.Filter();
  const std::vector<RegistrationView>& views = session.Inputs().views;
  StagedOutputDirectory output(directory);
  for (size_t v = 0; v < views.size(); ++v)
  {
    const int port = 3 * static_cast<int>(v);
    const std::string& name = views[v].view.name;
    WritePNG(registration->GetOutput(port + 1), output.Path("mask_" + name + ".png"));
    WritePNG(registration->GetOutput(port), output.Path("drr_" + name + ".png"));
    if (session.Settings().entropyMask)
      WritePNG(EntropyAsGrey(registration->GetOutput(port + 2)), output.Path("entropy_" + name + ".png"));
  }
  // The record last: a folder with a result.json holds that run's complete output.
  std::ofstream recordFile(output.Path("result.json"));
  recordFile << RegistrationRecordJSON(session.Record());
  recordFile.close();
  if (!recordFile)
  {
    throw Error(directory + "/result.json", "cannot be written");
  }
  output.ReplaceEarlier({ "drr_*.png", "mask_*.png", "entropy_*.png" });
  output.Commit();
}

CTSeriesInfo DICOMSeriesForOutput(const std::string& ct, const std::string& series, const std::string& option)
{
  struct stat status;
  if (stat(ct.c_str(), &status) != 0 || !S_ISDIR(status.st_mode))
    throw InputError(option, "needs the CT as a DICOM series (a folder): DICOM output refers to its study and Frame of Reference");
  CTSeriesInfo info = ScanCTSeries(ct, series);
  if (info.studyInstanceUID.empty())
    throw InputError(info.files.front(), "Study Instance UID (0020,000D) missing: " + option + " cannot join the CT's study");
  if (info.frameOfReferenceUID.empty())
    throw InputError(info.files.front(), "Frame of Reference UID (0020,0052) missing: " + option + " cannot refer to it");
  return info;
}

void CheckRTImageViews(const StereoGeometry& geometry, const std::string& option)
{
  for (const XRayView& view : geometry.views)
  {
    try
    {
      RTImageGeometryOf(view, geometry.isocenter);
    }
    catch (const InputError& e)
    {
      throw InputError(option, std::string(e.what()) + ": its DRR cannot be written as an RT Image");
    }
  }
}

RTImageDRR RTImageOfLastDRR(const DRRSetup& setup, const std::string& description)
{
  RTImageDRR image;
  image.view = setup.filter->GetOutputView();
  image.roomIsocenter = setup.geometry.isocenter;
  image.isocenterInCT = setup.patient.IsocenterInCT(ImageCenter(setup.ct.image));
  image.patientPosition = setup.ct.patientPosition;
  image.pixels = RowsTopFirst<uint16_t>(setup.filter->GetOutput(0));
  image.description = description;
  return image;
}

std::string WriteDICOMRegistration(const RegistrationSession& session, const CTSeriesInfo& ct,
  const std::string& directory, const std::string& reportSummaryPNG)
{
  if (!session.FromFiles())
    throw Error(directory, "DICOM output refers to the CT series and X-ray files a session was read from: this one has none");
  const StereoRegistrationResult& result = session.Result();
  const RegistrationInputs& inputs = session.Inputs();
  StagedOutputDirectory output(directory);
  const DRRSetup& setup = inputs.setup;
  const std::string series = NewDICOMUID();
  for (size_t v = 0; v < setup.geometry.views.size(); ++v)
  {
    const XRayView& view = setup.geometry.views[v];
    setup.filter->SetView(view);
    setup.filter->SetMisalignment(Pose{});
    setup.filter->SetInputData(1, nullptr);
    setup.filter->SetOutputSize(0, 0);
    setup.filter->Update();
    WriteRTImageDRR(ct, RTImageOfLastDRR(setup, "DRR by xpose at the planned set-up"), series, static_cast<int>(v) + 1,
      output.Path("drr_" + view.name + ".dcm"));
  }
  std::string written = "the DRRs as RT Images (drr_NAME.dcm)";
  if (result.ok)
  {
    SpatialRegistration registration;
    registration.ctToSession = MisalignmentInCT(inputs.planned, result.misalignment, setup.patient.roomIsocenter);
    registration.contentDescription = "xpose: patient misalignment; table correction = inverse";
    for (const std::string& xray : session.Sources().xrays) // DICOM X-rays are the session's images
      if (const std::optional<InstanceReference> reference = ReadInstanceReference(xray))
        registration.sessionImages.push_back(*reference);
    const std::string uid = WriteSpatialRegistration(ct, registration, output.Path("reg.dcm"));
    written += " and the Spatial Registration " + uid + " (reg.dcm)";
  }
  else
  {
    written += "; no Spatial Registration: the registration failed";
  }
  if (!reportSummaryPNG.empty())
  {
    // The report's summary picture as a Secondary Capture beside them, for any DICOM viewer.
    WriteSecondaryCapture(ct, reportSummaryPNG,
      std::string("xpose registration report: status ") + (result.ok ? "ok" : "FAILED, do not apply"), output.Path("report.dcm"));
    written += ", the report (report.dcm)";
  }
  output.ReplaceEarlier({ "reg.dcm", "drr_*.dcm", "report.dcm" });
  output.Commit();
  return written;
}

} // namespace xp
