/**
 * @file xpStereoSimilarity.h
 * @brief The 6-DOF objective of Method.md, stage 3: MI(X-ray A, DRR A(T))^2 + MI(X-ray B, DRR B(T))^2,
 *        rendering only the rays of valid pixels, into buffers kept between evaluations.
 *
 * Equalised levels (the default): MI bins each image by its own ranks over the valid pixels: the
 * X-ray by its histogram, the DRR's line integrals by their distribution at the first pose
 * evaluated. With a high-pass, each image's ranks less their wide low-pass are ranked again. The bins then hold equal shares of the anatomy whatever the X-ray's grey-level
 * mapping (raw, logarithmic, processed) and however thick the patient is: with bins of equal width
 * over 12-bit transmission, a pelvis seen obliquely (transmission below 1 %) falls into the
 * first bin, and MI follows the faint body outline instead of the bone.
 */
#ifndef xpStereoSimilarity_h
#define xpStereoSimilarity_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpDRRProjector.h"
#include "xpImageLevels.h"
#include "xpMutualInformation.h"
#include "xpPose.h"
#include "xpRayCaster.h"
#include "xpViewMetrics.h"
#include "xpXRayView.h"

#include <memory>
#include <mutex>
#include <vector>

namespace xp
{

/** How MI sees the images (xpImageLevels.h). */
struct SimilarityLevels
{
  bool equalize = true;          ///< ranks; false: 12-bit values as they are
  double highPassSigmaMM = 0.0;  ///< with ranks: shading wider than this (mm on the panel) removed; 0 = kept
  /** > 0: the objective is the correlation of the X-ray's ranks with the DRR's line integrals, each
   *  less its low-pass of this sd (mm on the panel), summed over the views; MI is still measured.
   *  A small bone among other bones: MI over its shadow follows whichever neighbour fills the
   *  most bins, a correlation follows the bone's own outline and inside. */
  double correlationHighPassMM = 0.0;
};

/** Where similarities' time goes: rendering the DRRs, and the metric (levels, high-pass,
 *  histogram, correlation). Several similarities may add into one (SetCostSink). */
struct SimilarityCost
{
  long long drrs = 0;  ///< DRRs rendered (one per view per evaluation)
  long long rays = 0;  ///< rays cast (masked pixels cast none)
  double renderSeconds = 0.0;
  double metricSeconds = 0.0;

  SimilarityCost operator-(const SimilarityCost& earlier) const
  {
    return { drrs - earlier.drrs, rays - earlier.rays, renderSeconds - earlier.renderSeconds, metricSeconds - earlier.metricSeconds };
  }
};

/** An X-ray as the metric sees it (SimilarityLevels), prepared once per registration. */
struct PreparedXRay
{
  /** MI's levels: the equalised ranks over the valid pixels, less their shading and ranked again
   *  with a high-pass; empty without equalisation (MI then reads the X-ray's own values). */
  std::vector<uint16_t> levels;
  /** With a correlation objective: the ranks less their low-pass (empty otherwise). */
  std::vector<float> structure;
};

/** The X-ray's intensity preparation: its levels and structure as `levels` asks for them; throws
 *  xp::InputError when the X-ray or its mask does not cover the view's panel. */
VTKXPREGISTRATION_EXPORT PreparedXRay PrepareXRay(const RegistrationView& item, const SimilarityLevels& levels);

/**
 * The X-ray's MI levels on every pixel of its panel, where PrepareXRay's are 0 outside the mask:
 * the valid pixels' ranks and level table, the shading removed over the whole panel. For a
 * search that moves the X-ray under a masked DRR (the gate's halves), so that what the move
 * brings in is anatomy and not the mask's blanks. Without equalisation, the X-ray as it is.
 */
VTKXPREGISTRATION_EXPORT std::vector<uint16_t> WholePanelLevels(const RegistrationView& item, const SimilarityLevels& levels);

class VTKXPREGISTRATION_EXPORT StereoSimilarity
{
public:
  /**
   * @param volume         attenuation volume of the CT (kept by reference: it must outlive this)
   * @param plannedCTToRoom the planned set-up; poses are misalignments applied after it
   * @param roomIsocenter  centre of rotation of the poses (Room mm)
   */
  StereoSimilarity(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
    const Eigen::Vector3d& roomIsocenter, std::vector<RegistrationView> views, int bins = 64,
    const SimilarityLevels& levels = {});
  // The traced pixels and the high-pass keep pointers into the views' masks: not copied.
  StereoSimilarity(const StereoSimilarity&) = delete;
  StereoSimilarity& operator=(const StereoSimilarity&) = delete;

  /** The objective at a misalignment: sum over views of MI^2 (nats^2). Renders one DRR per view. */
  double Evaluate(const Pose& misalignment);
  /** View v's line integrals at the last pose evaluated (the panel's pixels, 0 where masked). */
  const std::vector<float>& LastIntegrals(size_t v) const;
  /**
   * The objective of given line integrals, one panel per view (LastIntegrals' layout), measured
   * as Evaluate measures a rendering; renders nothing (xpLinearizedRefinement.h). The next
   * Evaluate measures its own rendering again; until then the last levels are these.
   */
  double ObjectiveOf(const std::vector<std::vector<float>>& integrals);

  /** MI per view of the last evaluation. */
  const std::vector<double>& LastMutualInformation() const { return this->LastMI; }
  /** With a correlation objective: the correlation per view of the last evaluation. */
  const std::vector<double>& LastCorrelation() const { return this->LastNCC; }
  /** The 12-bit DRR (transmission) of view v from the last evaluation (0 where masked). */
  const std::vector<uint16_t>& LastDRR(size_t v) const;
  /** The images as MI sees them: equalised levels, or the X-ray and the DRR as they are. */
  const std::vector<uint16_t>& XRayLevels(size_t v) const { return this->MI[v]->XRayLevels(); }
  const std::vector<uint16_t>& LastDRRLevels(size_t v) const;
  /** The intensity preparation this similarity measures with. */
  SimilarityLevels Levels() const { return { this->Equalize, this->HighPassMM, this->CorrelationMM }; }
  long long RenderedDRRs() const { return this->DRRCount; }
  /**
   * Render the DRR's rays on every `stride.columns`-th pixel of each row and on every
   * `stride.rows`-th row only, and fill the pixels between by bilinear interpolation (1 and 1:
   * every pixel rendered, the default). A CT of 1 mm voxels seen on 0.5 mm pixels at the
   * isocentre has no detail that the interpolation loses at stride 2 and 2, and a quarter of the
   * rays are cast. Call before the first evaluation.
   */
  void SetRenderStride(const RenderStride& stride);
  /**
   * Sample every `steps[a]`-th voxel plane along the rays' dominant CT index axis a
   * (RayCastSettings::planeSteps): { 2, 2, 2 } on a CT of 1 mm voxels halves a ray's samples and
   * keeps its resolution across the ray (1 to 4; the ray caster refuses others when it renders).
   * CPU only (refused here on the GPU). Call before the first evaluation.
   */
  void SetPlaneSteps(const std::array<int, 3>& steps);
  /** The same stride along rows and columns. */
  void SetRenderStride(int stride) { this->SetRenderStride(RenderStride{ stride, stride }); }
  /**
   * Where the DRRs' rays are cast (CPU by default; xpRayCaster.h). On the GPU, an objective of
   * MI on equalised levels without a high-pass and with every ray cast is measured there too,
   * from the second evaluation on (the first fixes the DRR's levels): the evaluation sends the
   * pose and gets the views' MI back, and the last DRRs are rendered again only when asked for.
   */
  void SetDevice(ComputeDevice device);
  ComputeDevice Device() const { return this->Projector.Device(); }
  /** Every later evaluation also adds its cost to `sink` (null: none); it must outlive this. */
  void SetCostSink(SimilarityCost* sink) { this->CostSink = sink; }
  const std::vector<RegistrationView>& Views() const { return this->Items; }

private:
  /** Whether the objective can be measured on the GPU (SetDevice), and its set-up there once
   *  the levels are fixed. */
  bool MeasuresOnGPU() const;
  void SetUpGPUMetric();
  /** After a GPU evaluation: the last pose's DRRs and levels on the host, for those who ask
   *  (once, whichever view's thread asks first). */
  void FetchLastDRRs() const;
  /** View v's metrics of line integrals: MI, and the correlation with a correlation objective. */
  void Measure(size_t v, const std::vector<float>& integrals);
  /** The objective of the views' last measures. */
  double Objective() const;

  const AttenuationVolume& Volume;
  Eigen::Isometry3d Planned;
  Eigen::Vector3d Isocenter;
  std::vector<RegistrationView> Items;
  /** Per view: its metrics (xpViewMetrics.h), run side by side; correlations only with a
   *  correlation objective. */
  std::vector<std::unique_ptr<MutualInformationMetric>> MI;
  std::vector<std::unique_ptr<CorrelationMetric>> Correlation;
  /** The DRRs' line integrals at the last pose: the views' panels and masks are Items'. */
  DRRProjector Projector;
  /** With equalised levels MI never reads the 12-bit DRRs: they are converted when asked for, not
   *  at every evaluation. */
  mutable std::vector<std::vector<uint16_t>> DRRs;
  mutable std::vector<uint8_t> DRRCurrent; ///< bytes, not bits: the views' metrics set theirs side by side
  bool Equalize = true;
  double HighPassMM = 0.0;
  /** The GPU's objective (SetDevice), and whether the host's DRRs are those of LastPose. */
  std::unique_ptr<GPUMutualInformation> GPUMetric;
  Eigen::Isometry3d LastPose = Eigen::Isometry3d::Identity();
  mutable bool HostCurrent = true;
  mutable std::mutex FetchMutex; ///< the views' checks ask for their DRRs from threads of their own
  double CorrelationMM = 0.0;
  std::vector<double> LastNCC;

  std::vector<double> LastMI;
  long long DRRCount = 0;
  SimilarityCost* CostSink = nullptr;
};

} // namespace xp

#endif
