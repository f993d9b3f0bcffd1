/**
 * @file xpOverlays.h
 * @brief The 2D pictures a person judges a registration by: an X-ray against a DRR of the same
 *        view, composed without OpenGL. Inputs are row 0 first; outputs RGB vtkImageData.
 */
#ifndef xpOverlays_h
#define xpOverlays_h

#include "vtkXPReportingModule.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <cstdint>
#include <vector>

namespace xp
{

enum class OverlayMode
{
  Checkerboard, ///< squares of X-ray and DRR in turn: edges must continue across the squares
  ColourBlend,  ///< X-ray in magenta, DRR in green: aligned structures turn grey
  Edges,        ///< the DRR's edges drawn in yellow on the X-ray
  MaskedXRay    ///< the X-ray where the mask is valid, the excluded regions dimmed and tinted
};

/**
 * One overlay of a 12-bit X-ray and a 12-bit DRR (same size). `mask` (1 = valid, may be empty)
 * sets the grey window from the valid pixels and, for MaskedXRay, what is dimmed. The DRR is
 * ignored by MaskedXRay and may be empty then.
 */
VTKXPREPORTING_EXPORT vtkSmartPointer<vtkImageData> MakeOverlay(OverlayMode mode, const std::vector<uint16_t>& xray,
  const std::vector<uint16_t>& drr, int columns, int rows, const std::vector<uint8_t>& mask = {});

/** A 12-bit image as display grey (1st..99th percentile window), RGB. */
VTKXPREPORTING_EXPORT vtkSmartPointer<vtkImageData> MakeGreyImage(const std::vector<uint16_t>& image, int columns, int rows);

/** A 0..1 map (entropy) in the viridis colour map, RGB. */
VTKXPREPORTING_EXPORT vtkSmartPointer<vtkImageData> MakeColourMap(const std::vector<float>& map, int columns, int rows);

} // namespace xp

#endif
