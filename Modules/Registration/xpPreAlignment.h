/**
 * @file xpPreAlignment.h
 * @brief The 5+1-DOF pre-alignment of Method.md, stage 1: per view a 2D/2D registration of the
 *        DRR onto the X-ray (shift u, shift v, in-plane rotation; MI; downhill simplex), then
 *        inverse projection of both 2D results into one 3D rigid update, repeated while it helps.
 */
#ifndef xpPreAlignment_h
#define xpPreAlignment_h

#include "vtkXPRegistrationModule.h"

#include "xpPose.h"
#include "xpStereoSimilarity.h"

#include <Eigen/Core>
#include <vector>

namespace xp
{

/** A 2D rigid motion on the panel: pixels, and degrees about `center` (pixel coordinates). */
struct Motion2D
{
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  double rotation = 0.0;
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  /** Scale along the panel's columns and rows about `center`, before the rotation (1, 1: rigid):
   *  T p = R S (p - center) + center + shift. */
  Eigen::Vector2d scale = Eigen::Vector2d::Ones();
};

/** A pixel of a panel image, by column and row. */
struct PixelIndex
{
  int column, row;
};

/** How many pixels WarpPixels warps at a time: the widest this CPU has (AVX-512: eight, AVX2:
 *  four, else one), or a given number. Every width gives the same values, bit for bit. */
enum class WarpLanes
{
  Widest = 0,
  One = 1,
  Four = 4,  ///< AVX2
  Eight = 8, ///< AVX-512 (F, VL and BW)
};

/** Whether this CPU can warp `lanes` pixels at a time (Widest and One: always). */
VTKXPREGISTRATION_EXPORT bool WarpLanesAvailable(WarpLanes lanes);

/**
 * moving(T^-1 p) at each of `pixels` (columns x rows `moving`, row 0 first): bilinear, rounded
 * half up; `valid` is 1 where the source lies inside `moving` and 0 (with a value of 0) where it
 * does not. Only the pixels a mask keeps are warped: the gate's 2D registrations of masked halves
 * (a tenth of a view or less) warp nothing else. On all threads, `lanes` pixels at a time (an
 * Error where the CPU has not those lanes), bit for bit the values of one at a time.
 */
VTKXPREGISTRATION_EXPORT void WarpPixels(const std::vector<uint16_t>& moving, int columns, int rows, const Motion2D& motion,
  const std::vector<PixelIndex>& pixels, std::vector<uint16_t>& out, std::vector<uint8_t>& valid,
  WarpLanes lanes = WarpLanes::Widest);

/**
 * Registers `moving` onto `fixed` (both columns x rows, 12-bit, row 0 first): the motion T such
 * that fixed(p) ~ moving(T^-1 p), maximising MI over pixels valid in `fixedMask` (null = all)
 * whose source lies inside `moving`. Rotation is about `center`. The search's first steps are
 * `initialStepPixels` (0: 3 % of the width, for a motion still to find) and 2 degrees.
 */
VTKXPREGISTRATION_EXPORT Motion2D Register2D(const std::vector<uint16_t>& fixed, const std::vector<uint16_t>& moving,
  int columns, int rows, const Eigen::Vector2d& center, const uint8_t* fixedMask = nullptr, int bins = 32,
  double initialStepPixels = 0.0);

/**
 * How far apart (pixels) the two halves of a view's valid pixels register, each on its own: the
 * pixels `mask` keeps are split at their median column, and again at their median row, and each
 * half of `fixed` is registered with `moving` (Register2D, first steps `initialStepPixels`); the
 * larger of the two splits' distances between their halves' shifts. A rigid fit of the right
 * anatomy leaves both halves where the whole is; an anatomy no rigid pose fits pulls them apart.
 * 0 without valid pixels.
 */
VTKXPREGISTRATION_EXPORT double HalvesApart(const std::vector<uint16_t>& fixed, const std::vector<uint16_t>& moving,
  const std::vector<uint8_t>& mask, int columns, int rows, const Eigen::Vector2d& center, int bins, double initialStepPixels);

/**
 * The same question asked of both halves at once: `xray` registered under `drr` (the DRR's
 * pixels that `mask` keeps) with a scale along each panel axis as well as the shift and rotation,
 * about the valid pixels' centroid; returns how far apart that scale moves the centroids of the
 * halves HalvesApart splits (pixels, the larger of the two splits), and the fitted motion in
 * `motion` when given. One registration of all the valid pixels is far steadier on noisy images
 * than two of half of them each. The X-ray moves, not the DRR: a DRR rendered only where the
 * mask keeps pixels holds nothing between them, and a DRR moved over the X-ray brings those
 * blanks in, which holds a search where it starts. So `xray` must hold its levels on every pixel
 * (WholePanelLevels). 0 without valid pixels.
 */
VTKXPREGISTRATION_EXPORT double StretchedHalvesApart(const std::vector<uint16_t>& drr, const std::vector<uint16_t>& xray,
  const std::vector<uint8_t>& mask, int columns, int rows, int bins, double initialStepPixels, Motion2D* motion = nullptr);

/**
 * The 3D misalignment increment (about `isocenter`) whose projections best explain the 2D motions
 * of the views: translations by least squares on the shifts of the isocentre's projections,
 * rotations as the smallest rotation that gives the in-plane rotations (the rotation about the
 * axis perpendicular to both central rays is not observable and stays 0).
 */
VTKXPREGISTRATION_EXPORT Pose InverseProjection(
  const std::vector<XRayView>& views, const std::vector<Motion2D>& motions, const Eigen::Vector3d& isocenter);

struct PreAlignmentResult
{
  Pose pose;
  int iterations = 0;
  long long drrs = 0;
  double objective = 0.0; ///< sum of MI^2 over the views, unmasked renderer
};

/**
 * Repeats render -> 2D/2D per view -> inverse projection -> update while the stereo objective
 * improves (at most `maxIterations`). `similarity` provides the X-rays, masks and rendering.
 */
VTKXPREGISTRATION_EXPORT PreAlignmentResult PreAlign(
  StereoSimilarity& similarity, const Pose& start, const Eigen::Vector3d& isocenter, int maxIterations = 6);

} // namespace xp

#endif
