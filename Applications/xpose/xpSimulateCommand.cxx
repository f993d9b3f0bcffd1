#include "xpCommands.h"
#include "xpDRRSetup.h"

#include "xpError.h"
#include "xpImageIO.h"
#include "xpPose.h"

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkPointData.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

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
  auto copy = vtkSmartPointer<vtkImageData>::New();
  copy->DeepCopy(ct);
  vtkDataArray* hu = copy->GetPointData()->GetScalars();
  for (vtkIdType i = 0; i < hu->GetNumberOfTuples(); ++i)
  {
    const double v = hu->GetTuple1(i);
    hu->SetTuple1(i, v > 100.0 ? 100.0 + 1.4 * (v - 100.0) : v);
  }
  return copy;
}

/**
 * Structures only the X-ray shows, as line integrals added on the panel: a couch rail along the
 * left edge and the corner of a fixation frame at the bottom right (rows counted from the top).
 */
void AddObjects(float* lineIntegral, int columns, int rows)
{
  for (int row = 0; row < rows; ++row)
  {
    for (int column = 0; column < columns; ++column)
    {
      // VTK rows run up: v is 0 at the bottom of the image as displayed.
      const double u = (column + 0.5) / columns, v = (row + 0.5) / rows;
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

int RunSimulate(const SimulateOptions& options)
{
  UseThreads(options.threads);
  const Pose pose = Pose::Parse(options.pose, "--pose");
  std::pair<int, int> size{ 0, 0 };
  if (!options.size.empty())
  {
    size = ParseSize(options.size, "--size");
  }
  if (options.noise < 0.0 || !std::isfinite(options.noise))
  {
    throw InputError("--noise", "must be 0 or more (12-bit grey levels at full transmission)");
  }
  DRRSetup setup = MakeDRRSetup(options.ct, options.series, options.geometry, options.isocenterInCT,
    options.kvContrast ? 0.0205 : 0.0193, "trilinear", 0.0);
  if (options.kvContrast)
  {
    setup.filter->SetInputData(KVContrastCT(setup.ct.image));
  }
  setup.filter->SetMisalignment(pose);
  setup.filter->SetOutputSize(size.first, size.second);

  std::mt19937 random(options.seed);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  StagedOutputDirectory output(options.outputDirectory);
  for (const XRayView& view : setup.geometry.views)
  {
    setup.filter->SetView(view);
    setup.filter->Update();
    vtkImageData* integral = setup.filter->GetOutput(1);
    if (integral->GetNumberOfPoints() == 0)
    {
      throw Error("view " + view.name, "rendering failed");
    }
    int dims[3];
    integral->GetDimensions(dims);
    std::vector<float> L(static_cast<const float*>(integral->GetScalarPointer()),
      static_cast<const float*>(integral->GetScalarPointer()) + integral->GetNumberOfPoints());
    if (options.addObjects)
    {
      AddObjects(L.data(), dims[0], dims[1]);
    }
    auto xray = vtkSmartPointer<vtkImageData>::New();
    xray->CopyStructure(integral);
    xray->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    auto* out = static_cast<uint16_t*>(xray->GetScalarPointer());
    for (size_t i = 0; i < L.size(); ++i)
    {
      double grey = 4095.0 * std::exp(-static_cast<double>(L[i]));
      if (options.kvContrast)
      {
        grey = 0.97 * grey + 0.03 * 4095.0 * 0.25; // scatter: a flat 0.75 % of the open field
      }
      // Quantum noise: the variance of a photon count grows with the signal.
      grey += options.noise * std::sqrt(grey / 4095.0) * gaussian(random);
      out[i] = static_cast<uint16_t>(std::clamp(std::lround(grey), 0L, 4095L));
    }
    WritePNG(xray, output.Path("xray_" + view.name + ".png"));
    std::printf("view %s: %dx%d simulated\n", view.name.c_str(), dims[0], dims[1]);
  }
  std::ofstream truth(output.Path("truth.json"));
  truth << "{\n  \"misalignment\": " << JsonPose(pose) << ",\n  \"correction\": " << JsonPose(pose.Inverse())
        << ",\n  \"convention\": \"IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)\""
        << ",\n  \"ct\": \"" << options.ct << "\",\n  \"geometry\": \"" << options.geometry << "\""
        << ",\n  \"size\": \"" << (options.size.empty() ? "panel" : options.size) << "\""
        << ",\n  \"noise\": " << options.noise << ",\n  \"kv_contrast\": " << (options.kvContrast ? "true" : "false")
        << ",\n  \"add_objects\": " << (options.addObjects ? "true" : "false") << ",\n  \"seed\": " << options.seed
        << "\n}\n";
  truth.close();
  if (!truth)
  {
    throw Error(options.outputDirectory, "cannot write truth.json");
  }
  output.Commit();
  std::printf("misalignment %s; wrote xray_NAME.png and truth.json to %s\n", pose.ToString().c_str(),
    options.outputDirectory.c_str());
  return ExitOk;
}

} // namespace xp
