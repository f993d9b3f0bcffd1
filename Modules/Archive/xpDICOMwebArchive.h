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
#include "xpHTTPClient.h"

#include <string>
#include <vector>

namespace xp
{

/** A series of a study as the archive lists it. */
struct VTKXPARCHIVE_EXPORT ArchivedSeries
{
  std::string studyInstanceUID;
  std::string seriesInstanceUID;
  std::string modality;
  std::string description;
  int instances = 0;
};

class VTKXPARCHIVE_EXPORT DICOMwebArchive
{
public:
  /**
   * `url`: the service root, http(s)://HOST[:PORT]/PATH. Throws xp::InputError naming --pacs for
   * another scheme, credentials in the URL, or no path (naming the URL to use instead).
   */
  DICOMwebArchive(const std::string& url, ArchiveAccess access);

  /** Throws xp::InputError naming the URL when no DICOMweb service answers there. */
  void CheckReachable() const;

  /** The series of the study; throws xp::InputError naming --study when there is no such study. */
  std::vector<ArchivedSeries> SeriesOfStudy(const std::string& studyUID) const;

  /** The one CT series of a study; several or none give an xp::InputError listing the series. */
  std::string CTSeriesOfStudy(const std::string& studyUID) const;

  /** Every instance of the series written into `directory` (which must exist) as 0001.dcm, ...
   *  (no name comes from the archive); returns the files. */
  std::vector<std::string> FetchSeries(const std::string& seriesUID, const std::string& directory) const;

  /** One instance by SOP Instance UID, written to `path`. */
  void FetchInstance(const std::string& sopInstanceUID, const std::string& path) const;

  /**
   * Stores the files one by one, in order, and stops at the first the archive refuses: DICOMweb
   * cannot take a stored instance back, so a caller puts last what must only be stored when all
   * before it were (the REG). A refusal throws xp::Error listing what was stored and what not.
   */
  void Store(const std::vector<std::string>& files) const;

  const std::string& Root() const { return this->RootURL; }

private:
  /** A QIDO-RS query's answer as text ("[]" for 204 and 404: no match); xp::Error for a status. */
  std::string Query(const std::string& path) const;
  /** A WADO-RS retrieval: the DICOM files of the multipart answer. */
  std::vector<std::string> Retrieve(const std::string& path) const;

  std::string RootURL; ///< without a trailing '/'
  HTTPClient Client;
};

/** Checks a UID before it goes into a URL: digits and dots, 64 characters at most. Throws
 *  xp::InputError naming `where` otherwise. */
VTKXPARCHIVE_EXPORT const std::string& CheckedUID(const std::string& uid, const std::string& where);

/**
 * The series of a QIDO-RS answer (application/dicom+json) and the failures of a STOW-RS answer,
 * read from the text the archive sent; throw xp::Error naming `where` when it is not DICOM JSON.
 * Exposed so that the tests can give them what a broken archive would.
 */
VTKXPARCHIVE_EXPORT std::vector<ArchivedSeries> ParseSeriesAnswer(const std::string& json, const std::string& where);
VTKXPARCHIVE_EXPORT std::vector<std::string> ParseStoreFailures(const std::string& json, const std::string& where);

} // namespace xp

#endif
