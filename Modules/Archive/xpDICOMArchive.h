/**
 * @file xpDICOMArchive.h
 * @brief What xpose asks of a DICOM archive, whichever protocol it speaks: list a study's
 *        series, fetch a series or an instance by UID, store results in order. DICOMweb
 *        (xpDICOMwebArchive.h) and DIMSE (xpDIMSEArchive.h) implement it; OpenArchive picks
 *        one by the URL's scheme.
 */
#ifndef xpDICOMArchive_h
#define xpDICOMArchive_h

#include "vtkXPArchiveModule.h"
#include "xpArchiveAccess.h"

#include <memory>
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

class VTKXPARCHIVE_EXPORT DICOMArchive
{
public:
  virtual ~DICOMArchive() = default;

  /** Where the archive is, as printed (never with credentials). */
  virtual const std::string& Address() const = 0;

  /** Throws xp::InputError naming the address when no archive of this kind answers there. */
  virtual void CheckReachable() const = 0;

  /** The series of the study; throws xp::InputError naming --study when there is no such study. */
  virtual std::vector<ArchivedSeries> SeriesOfStudy(const std::string& studyUID) const = 0;

  /** The one CT series of a study; several or none give an xp::InputError listing the series. */
  std::string CTSeriesOfStudy(const std::string& studyUID) const;

  /** Every instance of the series written into `directory` (which must exist) as 0001.dcm, ...
   *  (no name comes from the archive); returns the files. */
  virtual std::vector<std::string> FetchSeries(const std::string& seriesUID, const std::string& directory) const = 0;

  /** One instance by SOP Instance UID, written to `path`. */
  virtual void FetchInstance(const std::string& sopInstanceUID, const std::string& path) const = 0;

  /**
   * Stores the files one by one, in order, and stops at the first the archive refuses: neither
   * DICOMweb nor DIMSE can take a stored instance back, so a caller puts last what must only be
   * stored when all before it were (the REG). A refusal throws xp::Error listing what was stored
   * and what was not.
   */
  virtual void Store(const std::vector<std::string>& files) const = 0;

protected:
  /** The xp::Error of a refused store: `files[refused]` and why, what was stored, what not. */
  [[noreturn]] void ThrowStoreRefused(
    const std::vector<std::string>& files, size_t refused, const std::string& why, bool badInput = false) const;
};

/**
 * The archive at `url`: http(s)://HOST:PORT/PATH is DICOMweb, dicom://CALLED_AET@HOST:PORT is
 * DIMSE (xpose calling as `callingAET`). Throws xp::InputError naming --pacs for anything else.
 */
VTKXPARCHIVE_EXPORT std::unique_ptr<DICOMArchive> OpenArchive(
  const std::string& url, const ArchiveAccess& access, const std::string& callingAET);

/** Checks a UID before it goes into a URL or a query: digits and dots, 64 characters at most.
 *  Throws xp::InputError naming `where` otherwise. */
VTKXPARCHIVE_EXPORT const std::string& CheckedUID(const std::string& uid, const std::string& where);

} // namespace xp

#endif
