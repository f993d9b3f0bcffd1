// Renders a DRR of a water cube with the installed vtkXPDRRFilter and checks the centre pixel;
// and a registration session, whose sources are checked before any work, refuses a missing CT.
#include <vtkXPDRRFilter.h>
#include <xpError.h>
#include <xpRegistrationSession.h>

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <cmath>
#include <cstdio>
#include <string>

int main()
{
  vtkNew<vtkImageData> ct;
  ct->SetDimensions(40, 40, 40);
  ct->SetOrigin(-19.5, -19.5, -19.5);
  vtkNew<vtkFloatArray> hu;
  hu->SetNumberOfValues(40 * 40 * 40);
  hu->FillValue(0.0f); // water
  ct->GetPointData()->SetScalars(hu);

  xp::XRayView view;
  view.name = "AP";
  view.source = { 0, 0, -1000 };
  view.detectorCenter = { 0, 0, 500 };
  view.rowDirection = { 1, 0, 0 };
  view.columnDirection = { 0, -1, 0 };
  view.pixelSpacing = { 1, 1 };
  view.size = { 31, 31 };

  vtkNew<vtkXPDRRFilter> drr;
  drr->SetInputData(ct);
  drr->SetView(view);
  drr->SetMuWater(0.02);
  drr->Update();
  const float centre = static_cast<float*>(drr->GetOutput(1)->GetScalarPointer())[15 * 31 + 15];
  std::printf("line integral through 40 mm of water: %.4f (expected %.4f)\n", centre, 0.02 * 40);
  if (!(std::abs(centre - 0.8) < 1e-3))
    return 1;

  xp::RegistrationSources sources;
  sources.ct = "no-such-ct";
  sources.geometry = XPOSE_GEOMETRY;
  sources.xrays = { "a.png", "b.png" };
  try
  {
    xp::RegistrationSession session(sources);
  }
  catch (const xp::InputError& e)
  {
    std::printf("session refused: %s\n", e.what());
    return std::string(e.what()).find("no-such-ct") != std::string::npos ? 0 : 1;
  }
  return 1;
}
