#include "xpEvaluationScenario.h"

#include "xpBodyMask.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpPlastimatchRenderer.h"
#include "xpStereoRegistration.h"

#include <vtkImageData.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>

namespace xp
{

EvaluationScenario::EvaluationScenario(const std::string& name, const std::vector<std::string>& without, double noise,
  bool removeTable, const std::optional<DetectorSettings>& detector)
  : Scenario(name)
  , Without(without)
  , RemoveTable(removeTable)
  , DetectorModel(detector)
{
  const std::set<std::string> scenarios{ "clean", "noisy", "objects", "truncated", "clinical", "plastimatch" };
  if (!scenarios.count(name))
  {
    throw InputError("--scenario", "expected clean, noisy, objects, truncated, clinical or plastimatch, got '" + name + "'");
  }
  if (detector && !this->UsesPhysics() && !this->UsesPlastimatch())
  {
    throw InputError("--detector", "makes the images of the clinical and plastimatch scenarios only");
  }
  if (this->UsesPlastimatch() && !this->DetectorModel)
    this->DetectorModel = DetectorSettings{};
  if (this->DetectorModel)
    this->DetectorModel->Validate();
  if (!this->UsesPhysics() && !without.empty())
  {
    throw InputError("--without", "switches off effects of the clinical scenario");
  }
  this->Truncation = this->UsesPhysics();
  for (const std::string& effect : without)
  {
    if (effect == "truncation")
      this->Truncation = false;
    else
      SwitchOff(this->PhysicsSettings, effect, "--without");
  }
  this->ModelSettings.noise = name == "clean" ? 0.0 : noise;
  this->ModelSettings.kvContrast = name != "clean";
  this->ModelSettings.addObjects = name == "objects";
}

vtkSmartPointer<vtkImageData> EvaluationScenario::RegistrationCT(vtkImageData* ct) const
{
  // Truncated: the X-rays see the whole patient, the registration a CT of half its length;
  // clinical: of 80 % of its length.
  vtkSmartPointer<vtkImageData> cut = ct;
  if (this->RegistrationCTLength() < 1.0)
    cut = CropSlices(ct, this->RegistrationCTLength());
  return this->RemovesTable() ? BodyOnly(cut) : cut;
}

std::string EvaluationScenario::DescribeXRays() const
{
  const std::string detector = this->DetectorModel ? ", \"detector\": " + this->DetectorModel->Describe() : "";
  if (this->UsesPlastimatch())
  {
    return "{ \"renderer\": \"plastimatch drr -i exact (xpPlastimatchRenderer.h)\"" + detector + " }";
  }
  if (!this->UsesPhysics())
  {
    return "\"the DRR model (xpModelXRaySimulator.h)\"";
  }
  std::string off;
  for (const std::string& effect : this->Without)
    off += (off.empty() ? "\"" : ", \"") + effect + "\"";
  return "{ \"simulator\": \"physics (xpXRayPhysics.h)\", \"planning_ct_cut_to\": " +
    std::string(this->Truncation ? "0.8" : "1") + ", \"without\": [" + off +
    "], \"settings\": " + this->PhysicsSettings.Describe() + detector + " }";
}

vtkSmartPointer<vtkImageData> StretchedCT(vtkImageData* ct, int axis, double factor)
{
  if (!(axis >= 0 && axis <= 2 && factor > 0.0 && std::isfinite(factor)))
  {
    throw InputError("--xray-stretch", "expects an axis 0, 1 or 2 and a positive factor");
  }
  const Eigen::Vector3d center = ImageCenter(ct);
  auto stretched = vtkSmartPointer<vtkImageData>::New();
  stretched->ShallowCopy(ct);
  double spacing[3];
  ct->GetSpacing(spacing);
  spacing[axis] *= factor;
  stretched->SetSpacing(spacing);
  // Keep the centre where it was: move the origin by the change of the half extent.
  const Eigen::Vector3d shift = center - ImageCenter(stretched);
  double origin[3];
  stretched->GetOrigin(origin);
  stretched->SetOrigin(origin[0] + shift[0], origin[1] + shift[1], origin[2] + shift[2]);
  return stretched;
}

vtkSmartPointer<vtkImageData> CropSlices(vtkImageData* ct, double fraction)
{
  int dims[3];
  ct->GetDimensions(dims);
  const int keep = std::max(1, static_cast<int>(std::lround(dims[2] * fraction)));
  const int first = (dims[2] - keep) / 2;
  auto cropped = vtkSmartPointer<vtkImageData>::New();
  cropped->SetDimensions(dims[0], dims[1], keep);
  cropped->SetSpacing(ct->GetSpacing());
  cropped->SetDirectionMatrix(ct->GetDirectionMatrix());
  const Eigen::Vector3d origin = IndexToPhysical(ct) * Eigen::Vector3d(0, 0, first);
  cropped->SetOrigin(origin.data());
  cropped->AllocateScalars(ct->GetScalarType(), 1);
  const size_t slice = static_cast<size_t>(dims[0]) * dims[1] * ct->GetScalarSize();
  std::memcpy(cropped->GetScalarPointer(), static_cast<const char*>(ct->GetScalarPointer()) + slice * first, slice * keep);
  return cropped;
}

TrialXRaySource::TrialXRaySource(const EvaluationScenario& scenario, vtkImageData* ct, const PatientSetup& patient,
  const std::vector<XRayView>& panels, int shrinkFactor)
  : Panels(panels)
  , Factor(shrinkFactor)
  , DetectorModel(scenario.Detector())
{
  if (scenario.UsesPlastimatch())
    this->Plastimatch =
      std::make_unique<PlastimatchRenderer>(ct, patient.PlannedCTToRoom(ImageCenter(ct)), patient.roomIsocenter);
  else if (scenario.UsesPhysics())
    this->Physics = std::make_unique<XRayPhysicsSimulator>(
      ct, patient.PlannedCTToRoom(ImageCenter(ct)), patient.roomIsocenter, scenario.Physics());
  else
    this->OwnModel = std::make_unique<XRaySimulator>(ct, patient, scenario.Model());
}

TrialXRaySource::~TrialXRaySource() = default;

std::vector<RegistrationView> TrialXRaySource::Simulate(const Pose& truth, std::mt19937& random)
{
  std::vector<RegistrationView> views;
  for (const XRayView& panel : this->Panels)
  {
    RegistrationView item;
    item.view = panel.Resampled(panel.Columns() / this->Factor, panel.Rows() / this->Factor);
    if (this->Plastimatch)
    {
      std::vector<float> signal = this->Plastimatch->LineIntegrals(item.view, truth);
      for (float& s : signal)
        s = std::exp(-s);
      item.xray = DetectImage(signal, item.view.Columns(), item.view.Rows(), item.view.pixelSpacing[0], *this->DetectorModel, random);
    }
    else if (this->Physics && this->DetectorModel)
    {
      const XRayComponents components = this->Physics->Render(item.view, truth);
      item.xray = DetectImage(
        components.signal, item.view.Columns(), item.view.Rows(), item.view.pixelSpacing[0], *this->DetectorModel, random);
    }
    else if (this->Physics)
    {
      // Rendered at the registration size: its rays spread over each (binned) pixel's area.
      item.xray = this->Physics->Simulate(item.view, truth, random);
    }
    else
    {
      const std::vector<uint16_t> xray = this->OwnModel->Simulate(panel, truth, random);
      item.xray = this->Factor > 1 ? ShrinkImage(xray, panel.Columns(), this->Factor) : xray;
    }
    views.push_back(std::move(item));
  }
  return views;
}

} // namespace xp
