#include "xpModelXRaySimulator.h"

#include "xpError.h"
#include "xpImageRows.h"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <algorithm>
#include <cmath>

namespace xp
{

namespace
{

/**
 * kV contrast: at diagnostic energies bone attenuates more, relative to water, than the DRR's
 * linear HU model says (photoelectric effect in calcium). Above 100 HU the X-ray sees 40 % more
 * contrast, with a water attenuation 6 % higher: the X-ray is a monotone but non-linear
 * re-weighting of the DRR, not a copy.
 */
vtkSmartPointer<vtkImageData> KVContrastCT(vtkImageData* ct)
{
  // A float copy: the re-weighted HU are fractional, and may exceed a 16-bit CT's range.
  auto copy = vtkSmartPointer<vtkImageData>::New();
  copy->CopyStructure(ct);
  copy->SetDirectionMatrix(ct->GetDirectionMatrix());
  vtkDataArray* in = ct->GetPointData()->GetScalars();
  vtkNew<vtkFloatArray> hu;
  hu->SetName("HU");
  hu->SetNumberOfValues(in->GetNumberOfTuples());
  for (vtkIdType i = 0; i < in->GetNumberOfTuples(); ++i)
  {
    const double v = in->GetTuple1(i);
    hu->SetValue(i, static_cast<float>(v > 100.0 ? 100.0 + 1.4 * (v - 100.0) : v));
  }
  copy->GetPointData()->SetScalars(hu);
  return copy;
}

/**
 * Structures only the X-ray shows, as line integrals added on a top-row-first panel: a couch rail
 * along the left edge and the corner of a fixation frame at the bottom right.
 */
void AddObjects(std::vector<float>& lineIntegral, int columns, int rows)
{
  for (int row = 0; row < rows; ++row)
  {
    for (int column = 0; column < columns; ++column)
    {
      const double u = (column + 0.5) / columns, v = 1.0 - (row + 0.5) / rows; // v = 0 at the bottom
      float& L = lineIntegral[static_cast<size_t>(row) * columns + column];
      if (u > 0.04 && u < 0.10)
        L += 2.5f; // couch rail: carbon and aluminium, strongly attenuating
      const bool frameBar = (u > 0.70 && v > 0.10 && v < 0.14) || (u > 0.70 && u < 0.74 && v < 0.30);
      if (frameBar)
        L += 1.2f;
    }
  }
}

} // namespace

XRaySimulator::XRaySimulator(vtkImageData* ct, const PatientSetup& patient, const XRaySimulation& simulation)
  : Simulation(simulation)
  , CT(simulation.kvContrast ? KVContrastCT(ct) : vtkSmartPointer<vtkImageData>(ct))
  , Filter(vtkSmartPointer<vtkXPDRRFilter>::New())
{
  if (!(simulation.noise >= 0.0 && std::isfinite(simulation.noise)))
  {
    throw InputError("--noise", "must be 0 or more (12-bit grey levels at full transmission)");
  }
  this->Filter->SetInputData(this->CT);
  this->Filter->SetPatientSetup(patient);
  // kV contrast: bone attenuates more than in the DRR model, and water a little more too.
  this->Filter->SetMuWater(simulation.kvContrast ? 0.0205 : WaterAttenuationPerMM);
}

std::vector<uint16_t> XRaySimulator::Simulate(const XRayView& view, const Pose& misalignment, std::mt19937& random)
{
  this->Filter->SetView(view);
  this->Filter->SetMisalignment(misalignment);
  this->Filter->Update();
  vtkImageData* integral = this->Filter->GetOutput(1);
  if (integral->GetNumberOfPoints() == 0)
  {
    throw Error("view " + view.name, "rendering failed");
  }
  std::vector<float> L = RowsTopFirst<float>(integral);
  if (this->Simulation.addObjects)
  {
    AddObjects(L, view.Columns(), view.Rows());
  }
  std::normal_distribution<double> gaussian(0.0, 1.0);
  std::vector<uint16_t> xray(L.size());
  for (size_t i = 0; i < L.size(); ++i)
  {
    double grey = 4095.0 * std::exp(-static_cast<double>(L[i]));
    if (this->Simulation.kvContrast)
    {
      grey = 0.97 * grey + 0.03 * 4095.0 * 0.25; // scatter: a flat 0.75 % of the open field
    }
    // Quantum noise: the variance of a photon count grows with the signal.
    grey += this->Simulation.noise * std::sqrt(grey / 4095.0) * gaussian(random);
    xray[i] = static_cast<uint16_t>(std::clamp(std::lround(grey), 0L, 4095L));
  }
  return xray;
}

} // namespace xp
