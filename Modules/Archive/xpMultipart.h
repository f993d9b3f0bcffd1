/**
 * @file xpMultipart.h
 * @brief multipart/related bodies (RFC 2387), as DICOMweb sends instances (WADO-RS) and takes
 *        them (STOW-RS).
 */
#ifndef xpMultipart_h
#define xpMultipart_h

#include "vtkXPArchiveModule.h"

#include <string>
#include <vector>

namespace xp
{

struct VTKXPARCHIVE_EXPORT MultipartPart
{
  std::string contentType; ///< the part's Content-Type header, empty when it has none
  std::string body;
};

/** A parameter of a Content-Type header (`boundary`, `type`), unquoted; empty when absent. */
VTKXPARCHIVE_EXPORT std::string ContentTypeParameter(const std::string& contentType, const std::string& name);

/** The parts of a multipart body whose boundary is `boundary`; throws xp::Error naming `where`
 *  when the body is not such a multipart (no delimiter, a part cut short, no closing delimiter). */
VTKXPARCHIVE_EXPORT std::vector<MultipartPart> SplitMultipart(
  const std::string& body, const std::string& boundary, const std::string& where);

/** One multipart/related body: each of `parts` with Content-Type `partType`. */
VTKXPARCHIVE_EXPORT std::string JoinMultipart(
  const std::vector<std::string>& parts, const std::string& partType, const std::string& boundary);

/** A boundary of random letters that no DICOM file here contains (checked by the caller's
 *  JoinMultipart use: a part holding it is refused). */
VTKXPARCHIVE_EXPORT std::string NewBoundary();

} // namespace xp

#endif
