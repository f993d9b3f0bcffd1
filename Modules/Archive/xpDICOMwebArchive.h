/**
 * @file xpDICOMwebArchive.h
 * @brief A DICOM archive through DICOMweb, the standard every current archive speaks: find
 *        (QIDO-RS), fetch (WADO-RS) and store (STOW-RS), over HTTP or HTTPS with credentials.
 *
 * Orthanc serves it through its DICOMweb plugin (Debian orthanc-dicomweb) at /dicom-web/;
 * dcm4chee, cloud DICOM stores and vendor archives at their own service roots.
 */
#ifndef xpDICOMwebArchive_h
#define xpDICOMwebArchive_h

#include "vtkXPArchiveModule.h"
#include "xpDICOMArchive.h"
#include "xpHTTPClient.h"

#include <string>
#include <vector>

namespace xp
{

class VTKXPARCHIVE_EXPORT DICOMwebArchive : public DICOMArchive
{
public:
  /**
   * `url`: the service root, http(s)://HOST[:PORT]/PATH. Throws xp::InputError naming --pacs for
   * another scheme, credentials in the URL, or no path (naming the URL to use instead).
   */
  DICOMwebArchive(const std::string& url, ArchiveAccess access);

  const std::string& Address() const override { return this->RootURL; }
  /** QIDO-RS /studies?limit=1 must answer a DICOM JSON list. */
  void CheckReachable() const override;
  std::vector<ArchivedSeries> SeriesOfStudy(const std::string& studyUID) const override;
  std::vector<std::string> FetchSeries(const std::string& seriesUID, const std::string& directory) const override;
  void FetchInstance(const std::string& sopInstanceUID, const std::string& path) const override;
  /** STOW-RS, one instance per request. */
  void Store(const std::vector<std::string>& files) const override;

private:
  /** A QIDO-RS query's answer as text ("[]" for 204 and 404: no match); xp::Error for a status. */
  std::string Query(const std::string& path) const;
  /** A WADO-RS retrieval: the DICOM files of the multipart answer. */
  std::vector<std::string> Retrieve(const std::string& path) const;

  std::string RootURL; ///< without a trailing '/'
  HTTPClient Client;
};

/**
 * The series of a QIDO-RS answer (application/dicom+json) and the failures of a STOW-RS answer,
 * read from the text the archive sent; throw xp::Error naming `where` when it is not DICOM JSON.
 * Exposed so that the tests can give them what a broken archive would.
 */
VTKXPARCHIVE_EXPORT std::vector<ArchivedSeries> ParseSeriesAnswer(const std::string& json, const std::string& where);
VTKXPARCHIVE_EXPORT std::vector<std::string> ParseStoreFailures(const std::string& json, const std::string& where);

} // namespace xp

#endif
