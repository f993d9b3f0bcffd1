/**
 * @file xpStereoSimilarity.h
 * @brief The 6-DOF objective of METHOD.md step 4: MI(X-ray A, DRR A(T))^2 + MI(X-ray B, DRR B(T))^2,
 *        rendering only the rays of valid pixels, into buffers kept between evaluations.
 */
#ifndef xpStereoSimilarity_h
#define xpStereoSimilarity_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpMutualInformation.h"
#include "xpPose.h"
#include "xpRayCaster.h"
#include "xpXRayView.h"

#include <vector>

namespace xp
{

/** One view of a registration: its geometry, its X-ray and the pixels that count. */
struct RegistrationView
{
  XRayView view;                 ///< the panel as rendered (size = the images' size)
  std::vector<uint16_t> xray;    ///< 12-bit, row 0 first
  std::vector<uint8_t> mask;     ///< 1 = valid; empty = all valid
};

class VTKXPREGISTRATION_EXPORT StereoSimilarity
{
public:
  /**
   * @param volume         attenuation volume of the CT (kept by reference: it must outlive this)
   * @param plannedCTToRoom the planned set-up; poses are misalignments applied after it
   * @param roomIsocenter  centre of rotation of the poses (Room mm)
   */
  StereoSimilarity(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom,
    const Eigen::Vector3d& roomIsocenter, std::vector<RegistrationView> views, int bins = 64);

  /** The objective at a misalignment: sum over views of MI^2 (nats^2). Renders one DRR per view. */
  double Evaluate(const Pose& misalignment);

  /** MI per view of the last evaluation. */
  const std::vector<double>& LastMutualInformation() const { return this->LastMI; }
  /** The 12-bit DRR of view v from the last evaluation (0 where masked). */
  const std::vector<uint16_t>& LastDRR(size_t v) const { return this->DRRs[v]; }
  long long RenderedDRRs() const { return this->DRRCount; }
  const std::vector<RegistrationView>& Views() const { return this->Items; }

private:
  const AttenuationVolume& Volume;
  Eigen::Isometry3d Planned;
  Eigen::Vector3d Isocenter;
  std::vector<RegistrationView> Items;
  JointHistogram Histogram;
  std::vector<TracedPixels> Traced; ///< per view, built once: the mask is fixed
  std::vector<std::vector<float>> Integrals; ///< 0 at masked pixels, which are never traced
  std::vector<std::vector<uint16_t>> DRRs;
  std::vector<double> LastMI;
  long long DRRCount = 0;
};

} // namespace xp

#endif
