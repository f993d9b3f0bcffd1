/**
 * @file xpQualityGate.h
 * @brief The last step of a registration: may the table be moved by this result? Checks of the
 *        measured evidence against the limits of StereoRegistrationSettings, each failure with a
 *        code for programs and a sentence for people.
 *
 * The gate reads numbers only; measuring them (MI over the valid pixels, a view's own 2D
 * residual) is the registration's work. A false `failed` costs the patient a repeat X-ray; a
 * false `ok` moves the table wrongly: Algorithms.md gives the measured distributions the limits
 * come from.
 */
#ifndef xpQualityGate_h
#define xpQualityGate_h

#include "vtkXPRegistrationModule.h"

#include "xpPose.h"

#include <array>
#include <string>
#include <vector>

namespace xp
{
struct StereoRegistrationSettings;

enum class GateCode
{
  InvalidInput,        ///< the inputs were refused before any registration (filter only)
  NotConverged,        ///< the optimiser stopped on its evaluation limit
  TranslationTooLarge, ///< beyond maxTranslation
  RotationTooLarge,    ///< beyond maxRotation
  AmbiguousPose,       ///< two searches ended apart, equally good: the images do not fix the pose
  TooFewPixels,        ///< a view's masks leave too few pixels for its MI to mean anything
  LowExplained,        ///< a view's final DRR explains too little of its X-ray
  UncoveredAnatomy,    ///< a view shows anatomy where the CT has none at the result
  ViewDisagrees,       ///< a view's own 2D registration still wants to move
  NotDistinct,         ///< a similarity the optimiser did not use scores a neighbouring pose higher
  Uncertain,           ///< along some axis the objective is too flat (or no maximum) at the result
  HalvesDisagree,      ///< a view's halves, registered each on its own, move apart: no rigid fit
  RestartsDisagree     ///< refinements from starts around the result end elsewhere (bones)
};

/** Stable lower-case name of a code, as result.json writes it ("low_explained", ...). */
VTKXPREGISTRATION_EXPORT const char* GateCodeName(GateCode code);

struct GateFailure
{
  GateCode code;
  int view = -1;       ///< the view concerned, -1 for the whole result
  std::string message; ///< one sentence for the report
};

/** What one view says about the result. */
struct ViewEvidence
{
  std::string name;
  long long validPixels = 0;      ///< registered: entropy mask, ROI and CT coverage
  long long pixels = 0;           ///< of the view (0: not known, the fraction is not checked)
  double explained = 0.0;         ///< MI / H(X-ray) over the valid pixels
  double uncovered = 0.0;         ///< fraction of valid pixels with anatomy the CT does not cover
  double residualMM = 0.0;        ///< the view's own 2D registration's shift, mm at the isocentre
  double residualDegrees = 0.0;   ///< and in-plane rotation
  /** The largest distance (mm at the isocentre) between the 2D registrations of the view's two
   *  halves (left/right, top/bottom), each on its own (HalvesApart) or both at once with a
   *  stretch (StretchedHalvesApart). */
  double halvesApartMM = 0.0;
};

/** The failures' messages, in order. */
VTKXPREGISTRATION_EXPORT std::vector<std::string> GateMessages(const std::vector<GateFailure>& failures);

/** Everything the gate judges. */
struct GateEvidence
{
  Pose misalignment;
  /** Where the registration started: the limits on the motion bound the change from there. */
  Pose start;
  bool converged = false;
  std::string stopReason;         ///< the optimiser's, when it did not converge
  /** Two refined search ends apart and equally good (StereoRegistrationSettings). */
  bool ambiguous = false;
  double searchApartMM = 0.0, searchApartDegrees = 0.0;
  std::vector<ViewEvidence> views;
  std::array<double, 6> uncertainty{}; ///< per axis: mm, mm, mm, degrees, degrees, degrees
  double peakMargin = 0.0;             ///< the result's least lead over its translated held-out neighbours
  /** Refinements restarted around the result (bones; negative = not run): the farthest end. */
  double restartsApartMM = -1.0, restartsApartDegrees = -1.0;
};

/** The failures, in a fixed order (whole result, then each view); empty = ok. */
VTKXPREGISTRATION_EXPORT std::vector<GateFailure> CheckQuality(
  const GateEvidence& evidence, const StereoRegistrationSettings& settings);

/** Throws xp::InputError when a gate limit is NaN, negative or out of range: such a limit would
 *  switch its check off without a word. */
VTKXPREGISTRATION_EXPORT void ValidateGateLimits(const StereoRegistrationSettings& settings);

} // namespace xp

#endif
