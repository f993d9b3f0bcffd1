/**
 * @file xpReportContent.h
 * @brief What the report of a registration shows, gathered from its record and its inputs.
 */
#ifndef xpReportContent_h
#define xpReportContent_h

#include "vtkXPReportingModule.h"
#include "xpReport.h"

#include <cstdint>
#include <string>
#include <vector>

class vtkXPDRRFilter;

namespace xp
{
struct RegistrationRecord;
struct RegistrationView;

/**
 * The report's numbers from a registration's record: status, reasons, misalignment and
 * correction with their convention, objective, effort, stage timings and the convergence trace.
 * `title` says what was registered. The views are added with ReportViewOf.
 */
VTKXPREPORTING_EXPORT ReportContent ReportContentOf(const RegistrationRecord& record, const std::string& title);

/**
 * View `index` of the registration: its X-ray and ROI as registered (`item`), the mask the
 * registration used (`mask`, row 0 first), the block entropy recomputed from the same X-ray and
 * ROI when it used entropy masks (`entropyMask`), the record's similarity for the view, and the
 * whole-image DRRs at the planned pose and at the record's misalignment, rendered by `drr` (a
 * filter whose CT is placed as the registration's was).
 */
VTKXPREPORTING_EXPORT ReportView ReportViewOf(const RegistrationRecord& record, size_t index,
  const RegistrationView& item, std::vector<uint8_t> mask, bool entropyMask, vtkXPDRRFilter* drr);

} // namespace xp

#endif
