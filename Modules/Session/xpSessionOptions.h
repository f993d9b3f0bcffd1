/**
 * @file xpSessionOptions.h
 * @brief The checks of a registration's options, shared by every command and the session, each
 *        refusal naming the option (sizes and points as text: xpValueText.h).
 */
#ifndef xpSessionOptions_h
#define xpSessionOptions_h

#include "vtkXPSessionModule.h"
#include "xpValueText.h" // ParseSize, ParsePoint

#include <Eigen/Core>

#include <string>
#include <utility>

namespace xp
{

struct StereoRegistrationSettings;

/** Throws xp::InputError naming `option` unless low <= value <= high (NaN fails). */
VTKXPSESSION_EXPORT void CheckLimit(double value, double low, double high, const std::string& option);

/** Checks the registration settings the options set, naming the option of a value out of range. */
VTKXPSESSION_EXPORT void CheckRegistrationSettings(const StereoRegistrationSettings& settings);

/** "SEARCH/REFINEMENT" or one optimiser for both (xpPoseOptimizer.h) into `settings`; an unknown
 *  name is an InputError naming `option`. */
VTKXPSESSION_EXPORT void SetOptimizers(const std::string& text, StereoRegistrationSettings& settings, const std::string& option);
/** The default settings' optimisers as SetOptimizers reads them: "SEARCH/REFINEMENT", or one name
 *  for both: what every command and the session start from. */
VTKXPSESSION_EXPORT std::string DefaultOptimizers();

} // namespace xp

#endif
