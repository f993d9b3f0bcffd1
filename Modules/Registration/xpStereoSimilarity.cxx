#include "xpStereoSimilarity.h"

#include "xpError.h"

namespace xp
{

StereoSimilarity::StereoSimilarity(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& roomIsocenter, std::vector<RegistrationView> views, int bins)
  : Volume(volume)
  , Planned(plannedCTToRoom)
  , Isocenter(roomIsocenter)
  , Items(std::move(views))
  , Histogram(bins)
{
  if (this->Items.empty())
  {
    throw InputError("registration", "no view to register");
  }
  for (const RegistrationView& item : this->Items)
  {
    const size_t pixels = static_cast<size_t>(item.view.Columns()) * item.view.Rows();
    if (item.xray.size() != pixels || (!item.mask.empty() && item.mask.size() != pixels))
    {
      throw InputError("view " + item.view.name, "X-ray or mask size does not match the panel");
    }
    this->Traced.emplace_back(item.view.Columns(), item.view.Rows(), item.mask.empty() ? nullptr : item.mask.data());
    this->Integrals.emplace_back(pixels);
    this->DRRs.emplace_back(pixels);
  }
  this->LastMI.assign(this->Items.size(), 0.0);
}

double StereoSimilarity::Evaluate(const Pose& misalignment)
{
  const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(this->Planned, misalignment, this->Isocenter);
  double objective = 0.0;
  for (size_t v = 0; v < this->Items.size(); ++v)
  {
    const RegistrationView& item = this->Items[v];
    const uint8_t* mask = item.mask.empty() ? nullptr : item.mask.data();
    const long long count = static_cast<long long>(item.xray.size());
    RenderLineIntegrals(this->Volume, ctToRoom, item.view.source, DetectorGrid::TopRowFirst(item.view),
      this->Traced[v], this->Integrals[v].data());
    LineIntegralsTo12Bit(this->Integrals[v].data(), mask, count, this->DRRs[v].data());
    this->Histogram.Compute(item.xray.data(), this->DRRs[v].data(), count, mask, mask);
    this->LastMI[v] = this->Histogram.MutualInformation();
    objective += this->LastMI[v] * this->LastMI[v];
    ++this->DRRCount;
  }
  return objective;
}

} // namespace xp
