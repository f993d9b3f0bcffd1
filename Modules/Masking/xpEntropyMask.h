/**
 * @file xpEntropyMask.h
 * @brief Automatic exclusion of low-information regions of an X-ray (Method.md, stage 2).
 *
 * Half resolution (2x2 mean), 3x3 Gaussian ([1 2 1]/4 each way), grey levels binned
 * `binWidth` wide (12-bit input, 32 -> 128 bins), Shannon entropy (natural log) of every
 * `window` x `window` block normalised by ln(bins), H(X) = mean of the block entropies that
 * could be computed (windows inside the image), valid where H(W) >= thresholdScale * H(X), then
 * back to full size by pixel replication (a 7x7 window covers 14x14 pixels and leaves a margin).
 * Pixels whose window leaves the image have no entropy and are not valid.
 */
#ifndef xpEntropyMask_h
#define xpEntropyMask_h

#include "vtkXPMaskingModule.h"

#include <cstdint>
#include <vector>

namespace xp
{
struct XRayView;

struct EntropyMaskSettings
{
  int window = 7;              ///< block size at half resolution (odd)
  int binWidth = 32;           ///< grey levels per bin
  int maxValue = 4095;         ///< 12-bit input
  double thresholdScale = 1.0; ///< valid where H(W) >= scale * H(X)
};

struct EntropyMaskResult
{
  std::vector<uint8_t> mask;     ///< full size, 1 = valid
  std::vector<float> entropy;    ///< full size, block entropy in [0, 1] (0 where undefined)
  double imageEntropy = 0.0;     ///< H(X), normalised
  double validFraction = 0.0;    ///< after the ROI
};

/**
 * Computes the entropy mask of a columns x rows 12-bit image (any row order: the result has the
 * same order). `roi` (optional, same size, non-zero = allowed) is AND-combined.
 * Throws xp::InputError when the image is smaller than two windows at half resolution.
 */
VTKXPMASKING_EXPORT EntropyMaskResult ComputeEntropyMask(const uint16_t* image, int columns, int rows,
  const uint8_t* roi = nullptr, const EntropyMaskSettings& settings = {});

/**
 * Transfers a mask from the plane of `from` into the plane of `to` (row 0 first in both): every
 * pixel of `to` takes the mask value at the projection, through `to`'s source, of its centre
 * onto `from`'s panel (nearest pixel; outside = invalid). The DRR of a view is rendered on the
 * X-ray's own panel, so this is the identity there, but it is explicit, as the method requires,
 * and correct for a DRR rendered at another size.
 */
VTKXPMASKING_EXPORT std::vector<uint8_t> TransferMask(
  const std::vector<uint8_t>& mask, const XRayView& from, const XRayView& to);

/** The 1s of a columns x rows mask widened by `radius` pixels (a square); radius <= 0: as it is. */
VTKXPMASKING_EXPORT std::vector<uint8_t> DilateMask(const std::vector<uint8_t>& mask, int columns, int rows, int radius);

} // namespace xp

#endif
