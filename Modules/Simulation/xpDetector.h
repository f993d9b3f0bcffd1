/**
 * @file xpDetector.h
 * @brief How a flat panel turns the radiation reaching it into the numbers of an image file:
 *        quantum and electronic noise, then one of the formats X-rays arrive in.
 *
 * The renderers of `xpose evaluate` (the physics simulator, plastimatch) give the signal as a
 * fraction of the open field; this stage makes of it the images a registration meets in a
 * clinic, so that no limit is chosen on one grey-level mapping:
 * - linear12: raw transmission, 12 bits (the open field at 3600, as xpose's own DRR PNGs);
 * - linear16: raw transmission, 16 bits (the open field at 57600 of 65535), as a panel's raw
 *   image;
 * - log: -ln(I / I0), bone bright, 12 bits over 0..10;
 * - processed: a "for presentation" image: log, unsharp mask (sd 10 mm, amount 1), window
 *   from the 0.5th to the 99.5th percentile, gamma 0.8, 8 bits.
 */
#ifndef xpDetector_h
#define xpDetector_h

#include "vtkXPSimulationModule.h"

#include <cstdint>
#include <random>
#include <string>
#include <vector>

namespace xp
{

enum class DetectorFormat
{
  Linear12,
  Linear16,
  Log,
  Processed
};

/** "linear12", ... and back; throws xp::InputError naming `option` for another name. */
VTKXPSIMULATION_EXPORT const char* DetectorFormatName(DetectorFormat format);
VTKXPSIMULATION_EXPORT DetectorFormat ParseDetectorFormat(const std::string& name, const std::string& option);

struct VTKXPSIMULATION_EXPORT DetectorSettings
{
  DetectorFormat format = DetectorFormat::Linear12;
  /** Poisson quanta per pixel at full transmission; 0 = no quantum noise. */
  double quanta = 20000.0;
  /** Read-out noise, sd as a fraction of the open field. */
  double electronicNoise = 0.001;
  /** Throws xp::InputError naming the option of a value out of range. */
  void Validate() const;
  /** As JSON, for evaluation.json. */
  std::string Describe() const;
};

/** The largest value a format stores (4095, 65535 or 255). */
VTKXPSIMULATION_EXPORT int DetectorMaxValue(DetectorFormat format);

/**
 * The image of a columns x rows signal (fraction of the open field, row 0 at the top) with noise
 * drawn from `random`; `pixelSpacingMM` sets the unsharp mask's width in pixels.
 */
VTKXPSIMULATION_EXPORT std::vector<uint16_t> DetectImage(const std::vector<float>& signal, int columns, int rows,
  double pixelSpacingMM, const DetectorSettings& settings, std::mt19937& random);

/** Separable Gaussian blur of a columns x rows image (sd in pixels), edges replicated. */
VTKXPSIMULATION_EXPORT void GaussianBlur(std::vector<float>& image, int columns, int rows, double sigmaPixels);

} // namespace xp

#endif
