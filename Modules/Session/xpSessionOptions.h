/**
 * @file xpSessionOptions.h
 * @brief The checks of a registration's options, shared by every command and the session:
 *        text to values, each refusal naming the option.
 */
#ifndef xpSessionOptions_h
#define xpSessionOptions_h

#include "vtkXPSessionModule.h"

#include <Eigen/Core>

#include <string>
#include <utility>

namespace xp
{

struct StereoRegistrationSettings;

/** "1024x768" -> {1024, 768}; throws xp::InputError naming `field`. */
VTKXPSESSION_EXPORT std::pair<int, int> ParseSize(const std::string& text, const std::string& field);

/** "x,y,z" -> a point in mm; throws xp::InputError naming `field`. */
VTKXPSESSION_EXPORT Eigen::Vector3d ParsePoint(const std::string& text, const std::string& field);

/** Throws xp::InputError naming `option` unless low <= value <= high (NaN fails). */
VTKXPSESSION_EXPORT void CheckLimit(double value, double low, double high, const std::string& option);

/** Checks the registration settings the options set, naming the option of a value out of range. */
VTKXPSESSION_EXPORT void CheckRegistrationSettings(const StereoRegistrationSettings& settings);

/** "SEARCH/REFINEMENT" or one optimiser for both (xpPoseOptimizer.h) into `settings`; an unknown
 *  name is an InputError naming `option`. */
VTKXPSESSION_EXPORT void SetOptimizers(const std::string& text, StereoRegistrationSettings& settings, const std::string& option);

} // namespace xp

#endif
