/**
 * @file xpDIMSEArchive.h
 * @brief A DICOM archive through DIMSE, as treatment-room systems and older archives speak it:
 *        C-FIND to list, C-GET to fetch, C-STORE to store, through dcmtk's SCU.
 *
 * Each operation is one association from the calling AE title to the called one. C-GET is used
 * rather than C-MOVE: the instances come back on the same association, so the archive needs no
 * route back to xpose, only its AE title (which most archives ask to be declared).
 */
#ifndef xpDIMSEArchive_h
#define xpDIMSEArchive_h

#include "vtkXPArchiveModule.h"
#include "xpDICOMArchive.h"

namespace xp
{

class VTKXPARCHIVE_EXPORT DIMSEArchive : public DICOMArchive
{
public:
  /** `url`: dicom://CALLED_AET@HOST:PORT. Throws xp::InputError naming --pacs or --aet when
   *  malformed (an AE title: 1 to 16 characters, no backslash or control characters). */
  DIMSEArchive(const std::string& url, const std::string& callingAET, const ArchiveAccess& access);

  const std::string& Address() const override { return this->URL; }
  /** A C-ECHO. */
  void CheckReachable() const override;
  std::vector<ArchivedSeries> SeriesOfStudy(const std::string& studyUID) const override;
  std::vector<std::string> FetchSeries(const std::string& seriesUID, const std::string& directory) const override;
  void FetchInstance(const std::string& sopInstanceUID, const std::string& path) const override;
  /** C-STORE, one association for all, the files in order. */
  void Store(const std::vector<std::string>& files) const override;

  const std::string& CalledAET() const { return this->Called; }
  const std::string& Host() const { return this->HostName; }
  int Port() const { return this->PortNumber; }
  const std::string& CallingAET() const { return this->Calling; }
  long TimeoutSeconds() const { return this->Timeout; }

private:
  std::string URL, Called, HostName, Calling;
  int PortNumber = 0;
  long Timeout = 120;
};

/** Checks an AE title (1-16 characters of the default repertoire, no backslash); throws
 *  xp::InputError naming `where` otherwise. */
VTKXPARCHIVE_EXPORT const std::string& CheckedAETitle(const std::string& title, const std::string& where);

} // namespace xp

#endif
