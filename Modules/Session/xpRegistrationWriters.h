/**
 * @file xpRegistrationWriters.h
 * @brief What a registration session's result is written as: its result folder (result.json, and
 *        per view the final DRR, mask and entropy map), and the DICOM objects a planning system
 *        reads (Spatial Registration, the planned DRRs as RT Images, the report as a Secondary
 *        Capture). Each writes into a staged folder: all of a run's files arrive, or none.
 */
#ifndef xpRegistrationWriters_h
#define xpRegistrationWriters_h

#include "vtkXPSessionModule.h"

#include "xpDICOMSeries.h"
#include "xpRTImage.h"
#include "xpRegistrationSources.h"

#include <string>

namespace xp
{

class RegistrationSession;

/** result.json last, after the images: a folder with a result.json holds that run's complete
 *  output, and an earlier run's images that this one does not write are removed. */
VTKXPSESSION_EXPORT void WriteRegistrationFolder(const RegistrationSession& session, const std::string& directory);

/**
 * The CT series that DICOM output refers to, checked before any work: `option` (--dicom-out)
 * needs the CT as a DICOM series with a Study Instance UID and a Frame of Reference UID.
 */
VTKXPSESSION_EXPORT CTSeriesInfo DICOMSeriesForOutput(const std::string& ct, const std::string& series, const std::string& option);

/** Checks, before any work, that every imager of `geometry` can be written as an RT Image
 *  (panels normal to the beam axis, not mirrored); throws xp::InputError naming `option`. */
VTKXPSESSION_EXPORT void CheckRTImageViews(const StereoGeometry& geometry, const std::string& option);

/** The RT Image of the 12-bit DRR the filter rendered last (output 0) for its output view. */
VTKXPSESSION_EXPORT RTImageDRR RTImageOfLastDRR(const DRRSetup& setup, const std::string& description);

/**
 * DICOM output in `directory`: reg.dcm, the estimated misalignment in the CT's coordinates from
 * its Frame of Reference (none for a failed result), the DRRs at the planned set-up as RT Images,
 * whole panels, the references a viewer shows beside the X-rays, and, when `reportSummaryPNG` is
 * given, the report's summary as a Secondary Capture. Returns what it wrote, in words.
 */
VTKXPSESSION_EXPORT std::string WriteDICOMRegistration(const RegistrationSession& session, const CTSeriesInfo& ct,
  const std::string& directory, const std::string& reportSummaryPNG);

} // namespace xp

#endif
