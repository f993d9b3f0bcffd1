/**
 * @file xpEdgeAgreement.h
 * @brief How close the DRR's edges at a result lie to the X-ray's own edges: a measure a reader
 *        can check against the overlay, and one that a consistent but wrong optimum does not pass.
 *
 * Both images are smoothed a little, scaled to 8 bits over their own range within the region, and
 * given to Canny: the DRR with its upper threshold at the 75th percentile of its non-zero gradient
 * magnitudes, the X-ray at whichever of a few percentiles gives about as many edge pixels as the
 * DRR has (a noise-free DRR and a noisy X-ray have gradients of different sizes, and a noisy
 * X-ray's weakest edges are noise). For each DRR edge
 * pixel inside the region (eroded, so that the region's border is no edge), the distance to the
 * nearest X-ray edge; the median of those distances is the measure. The same median with the DRR's
 * edges shifted by `shiftPixels` along the rows and along the columns (four shifts, the median of
 * their medians) says what the X-ray's edge density alone would give: a result that lies on the
 * anatomy is well below it.
 */
#ifndef xpEdgeAgreement_h
#define xpEdgeAgreement_h

#include "vtkXPRegistrationModule.h"

#include <cstdint>
#include <vector>

namespace xp
{

struct EdgeAgreement
{
  double medianPixels = -1.0;        ///< DRR edges to the nearest X-ray edge; -1: no DRR edge in the region
  double shiftedMedianPixels = -1.0; ///< the same with the DRR's edges shifted (the chance level)
  long long drrEdgePixels = 0;       ///< DRR edge pixels counted
};

/**
 * `xray` and `drr`: columns x rows, row 0 first, any monotone grey scale (the polarity does not
 * matter). `region` (same size, non-zero = counted; empty = all) limits both.
 */
VTKXPREGISTRATION_EXPORT EdgeAgreement MeasureEdgeAgreement(const std::vector<uint16_t>& xray,
  const std::vector<uint16_t>& drr, const std::vector<uint8_t>& region, int columns, int rows, int shiftPixels);

} // namespace xp

#endif
