#include "xpStereoSimilarity.h"

#include "xpError.h"
#include "xpImageLevels.h"
#include "xpMutualInformation.h"
#include "xpParallel.h"

#include <vtkSMPTools.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

namespace xp
{

namespace
{

/** The high-pass's sd in pixels: never below 3, where a narrower one on coarse pixels leaves
 *  little but noise and the edges' own sampling (80x60 panels of 5 mm with a 5 mm sd split
 *  the halves of a rigid phantom 1.05 mm apart). */
double HighPassPixels(double sigmaMM, const XRayView& view)
{
  return std::max(3.0, sigmaMM / view.pixelSpacing[0]);
}

/**
 * Ranks less their shading, ranked again: `levels` minus its low-pass (`sigmaMM` on the panel,
 * over `lowPassMask`'s pixels, every pixel without one), mapped through the level table of the
 * pixels `mask` keeps; with `clearOutside`, those it leaves out are 0.
 */
void RankWithoutShading(std::vector<uint16_t>& levels, const uint8_t* lowPassMask, const uint8_t* mask, bool clearOutside,
  const XRayView& view, double sigmaMM)
{
  std::vector<float> structure(levels.begin(), levels.end());
  SubtractLowPass(structure.data(), lowPassMask, view.Columns(), view.Rows(), HighPassPixels(sigmaMM, view));
  LevelTable table;
  table.Build(structure.data(), mask, static_cast<long long>(structure.size()));
  for (size_t i = 0; i < structure.size(); ++i)
    levels[i] = (clearOutside && mask && !mask[i]) ? 0 : table(structure[i]);
}

} // namespace

PreparedXRay PrepareXRay(const RegistrationView& item, const SimilarityLevels& levels)
{
  PreparedXRay prepared;
  const size_t pixels = static_cast<size_t>(item.view.Columns()) * item.view.Rows();
  if (item.xray.size() != pixels || (!item.mask.empty() && item.mask.size() != pixels))
    throw InputError("view " + item.view.name, "X-ray or mask size does not match the panel");
  const uint8_t* mask = item.mask.empty() ? nullptr : item.mask.data();
  if (levels.equalize)
    prepared.levels = EqualizedLevels(item.xray, item.mask);
  if (levels.correlationHighPassMM > 0.0)
  {
    const std::vector<uint16_t> ranks = levels.equalize ? prepared.levels : EqualizedLevels(item.xray, item.mask);
    prepared.structure.assign(ranks.begin(), ranks.end());
    SubtractLowPass(prepared.structure.data(), mask, item.view.Columns(), item.view.Rows(),
      levels.correlationHighPassMM / item.view.pixelSpacing[0]);
  }
  if (levels.equalize && levels.highPassSigmaMM > 0.0)
    RankWithoutShading(prepared.levels, mask, mask, true, item.view, levels.highPassSigmaMM);
  return prepared;
}

std::vector<uint16_t> WholePanelLevels(const RegistrationView& item, const SimilarityLevels& levels)
{
  if (!levels.equalize)
    return item.xray;
  std::vector<uint16_t> ranks = EqualizedLevels(item.xray, item.mask);
  if (levels.highPassSigmaMM > 0.0) // the shading over the whole panel, the table of the valid pixels
    RankWithoutShading(ranks, nullptr, item.mask.empty() ? nullptr : item.mask.data(), false, item.view, levels.highPassSigmaMM);
  return ranks;
}

StereoSimilarity::StereoSimilarity(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
  const Eigen::Vector3d& roomIsocenter, std::vector<RegistrationView> views, int bins, const SimilarityLevels& levels)
  : Volume(volume)
  , Planned(plannedCTToRoom)
  , Isocenter(roomIsocenter)
  , Items(std::move(views))
  , Projector(volume, Items)
  , Equalize(levels.equalize)
  , HighPassMM(levels.equalize ? levels.highPassSigmaMM : 0.0)
  , CorrelationMM(levels.correlationHighPassMM)
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
    this->DRRs.emplace_back(pixels);
    PreparedXRay prepared = PrepareXRay(item, levels);
    const uint8_t* mask = item.mask.empty() ? nullptr : item.mask.data();
    const int columns = item.view.Columns(), rows = item.view.Rows();
    this->MI.push_back(std::make_unique<MutualInformationMetric>(mask, columns, rows,
      this->Equalize ? std::move(prepared.levels) : item.xray, bins, this->Equalize,
      this->HighPassMM > 0.0 ? HighPassPixels(this->HighPassMM, item.view) : 0.0));
    if (this->CorrelationMM > 0.0)
      this->Correlation.push_back(std::make_unique<CorrelationMetric>(
        mask, columns, rows, std::move(prepared.structure), this->CorrelationMM / item.view.pixelSpacing[0]));
  }
  this->LastMI.assign(this->Items.size(), 0.0);
  this->LastNCC.assign(this->Items.size(), 0.0);
  this->DRRCurrent.assign(this->Items.size(), false);
}

const std::vector<uint16_t>& StereoSimilarity::LastDRR(size_t v) const
{
  this->FetchLastDRRs();
  if (!this->DRRCurrent[v])
  {
    const RegistrationView& item = this->Items[v];
    LineIntegralsTo12Bit(this->Projector.Integrals(v).data(), item.mask.empty() ? nullptr : item.mask.data(),
      static_cast<long long>(item.xray.size()), this->DRRs[v].data());
    this->DRRCurrent[v] = true;
  }
  return this->DRRs[v];
}

const std::vector<uint16_t>& StereoSimilarity::LastDRRLevels(size_t v) const
{
  // Without equalisation they are the 12-bit DRR, which the metric converted when it measured
  // (the GPU measures equalised levels only).
  this->FetchLastDRRs();
  return this->MI[v]->DRRLevels();
}

void StereoSimilarity::SetDevice(ComputeDevice device)
{
  this->Projector.SetDevice(device);
  this->GPUMetric.reset();
  this->FetchLastDRRs();
}

bool StereoSimilarity::MeasuresOnGPU() const
{
  return this->Projector.Device() == ComputeDevice::CUDA && this->Equalize && this->HighPassMM <= 0.0 && this->CorrelationMM <= 0.0 &&
    this->Projector.Stride() == RenderStride{} && this->MI.front()->Bins() <= 64;
}

void StereoSimilarity::SetUpGPUMetric()
{
  std::vector<GPUMutualInformation::View> views;
  for (size_t v = 0; v < this->Items.size(); ++v)
  {
    // The histogram's bins of a level (JointHistogram: level * bins / 4096), for both images.
    const MutualInformationMetric& metric = *this->MI[v];
    const int bins = metric.Bins();
    const auto binOf = [bins](uint16_t level) { return static_cast<uint8_t>(static_cast<long long>(level) * bins / RankLevels); };
    GPUMutualInformation::View view;
    view.source = this->Items[v].view.source;
    view.grid = this->Projector.Grid(v);
    view.pixels = &this->Projector.Traced(v);
    for (int pixel : this->Projector.Traced(v).Order())
      view.xrayBins.push_back(binOf(metric.XRayLevels()[static_cast<size_t>(pixel)]));
    const LevelTable& levels = metric.IntegralLevels();
    view.low = levels.Low();
    view.toCell = levels.ToCell();
    for (uint16_t level : levels.Levels())
      view.cellBins.push_back(binOf(level));
    views.push_back(std::move(view));
  }
  this->GPUMetric = std::make_unique<GPUMutualInformation>(this->Volume, views, this->MI.front()->Bins());
}

void StereoSimilarity::FetchLastDRRs() const
{
  std::lock_guard<std::mutex> lock(this->FetchMutex);
  if (this->HostCurrent)
    return;
  this->Projector.Render(this->LastPose);
  for (size_t v = 0; v < this->Items.size(); ++v)
  {
    this->MI[v]->SetDRRLevels(this->Projector.Integrals(v));
    this->DRRCurrent[v] = false;
  }
  this->HostCurrent = true;
}

double StereoSimilarity::Evaluate(const Pose& misalignment)
{
  const Eigen::Isometry3d ctToRoom = MisalignedCTToRoom(this->Planned, misalignment, this->Isocenter);
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  if (this->GPUMetric)
  {
    // Rays, histograms and MI on the GPU: the views' MI come back, nothing else.
    std::vector<double> mi;
    const long long rays = this->GPUMetric->Evaluate({ ctToRoom }, mi);
    this->LastMI = mi;
    this->LastPose = ctToRoom;
    this->HostCurrent = false;
    double objective = 0.0;
    for (double value : mi)
      objective += value * value;
    this->DRRCount += static_cast<long long>(this->Items.size());
    if (this->CostSink)
    {
      this->CostSink->drrs += static_cast<long long>(this->Items.size());
      this->CostSink->rays += rays;
      this->CostSink->renderSeconds += std::chrono::duration<double>(Clock::now() - start).count();
    }
    return objective;
  }
  this->LastPose = ctToRoom;
  const long long rays = this->Projector.Render(ctToRoom); // each DRR on every thread, or the views in one launch on the GPU
  for (size_t v = 0; v < this->Items.size(); ++v)
    this->DRRCurrent[v] = false;
  const Clock::time_point rendered = Clock::now();
  // The views' metrics read and write only their own buffers: one thread each.
  vtkSMPTools::For(size_t{ 0 }, this->Items.size(), size_t{ 1 },
    [this](size_t first, size_t last)
    {
      for (size_t v = first; v < last; ++v)
        this->Measure(v, this->Projector.Integrals(v));
    });
  const double objective = this->Objective();
  this->DRRCount += static_cast<long long>(this->Items.size());
  if (this->MeasuresOnGPU()) // the levels are fixed now: the next evaluations measure on the GPU
    this->SetUpGPUMetric();
  if (this->CostSink)
  {
    const Clock::time_point measured = Clock::now();
    this->CostSink->drrs += static_cast<long long>(this->Items.size());
    this->CostSink->rays += rays;
    this->CostSink->renderSeconds += std::chrono::duration<double>(rendered - start).count();
    this->CostSink->metricSeconds += std::chrono::duration<double>(measured - rendered).count();
  }
  return objective;
}

void StereoSimilarity::Measure(size_t v, const std::vector<float>& integrals)
{
  this->LastMI[v] = this->MI[v]->Measure(integrals);
  if (!this->Correlation.empty())
    this->LastNCC[v] = this->Correlation[v]->Measure(integrals);
}

double StereoSimilarity::Objective() const
{
  double objective = 0.0;
  for (size_t v = 0; v < this->Items.size(); ++v)
    objective += this->CorrelationMM > 0.0 ? this->LastNCC[v] : this->LastMI[v] * this->LastMI[v];
  return objective;
}

const std::vector<float>& StereoSimilarity::LastIntegrals(size_t v) const
{
  this->FetchLastDRRs();
  return this->Projector.Integrals(v);
}

double StereoSimilarity::ObjectiveOf(const std::vector<std::vector<float>>& integrals)
{
  bool fits = integrals.size() == this->Items.size();
  for (size_t v = 0; fits && v < this->Items.size(); ++v)
    fits = integrals[v].size() == this->Items[v].xray.size();
  if (!fits)
    throw Error("stereo similarity", "line integrals must hold one panel per view");
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  this->FetchLastDRRs(); // the host's state stays that of LastPose, as LastIntegrals reads it
  vtkSMPTools::For(size_t{ 0 }, this->Items.size(), size_t{ 1 },
    [this, &integrals](size_t first, size_t last)
    {
      for (size_t v = first; v < last; ++v)
        this->Measure(v, integrals[v]);
    });
  if (this->CostSink)
    this->CostSink->metricSeconds += std::chrono::duration<double>(Clock::now() - start).count();
  return this->Objective();
}

void StereoSimilarity::SetPlaneSteps(const std::array<int, 3>& steps)
{
  if (this->Device() == ComputeDevice::CUDA && steps != std::array<int, 3>{ { 1, 1, 1 } })
    throw InputError("plane step", "the GPU samples every voxel plane: 1 only");
  this->Projector.SetPlaneSteps(steps);
}

void StereoSimilarity::SetRenderStride(const RenderStride& stride)
{
  this->GPUMetric.reset(); // its pixel lists are the old stride's
  this->FetchLastDRRs();
  this->Projector.SetStride(stride);
}

} // namespace xp
