/**
 * @file xpOrthanc.h
 * @brief A DICOM archive through Orthanc's REST API (plain HTTP): find a study's CT series, fetch
 *        series and instances by UID, and store results so that nothing is left half-stored.
 */
#ifndef xpOrthanc_h
#define xpOrthanc_h

#include "vtkXPIOModule.h"

#include <string>
#include <vector>

namespace xp
{

/** A series of a study as the archive lists it. */
struct ArchivedSeries
{
  std::string seriesInstanceUID;
  std::string modality;
  std::string description;
  int instances = 0;
};

class VTKXPIO_EXPORT OrthancArchive
{
public:
  /** `url`: http://HOST:PORT (no TLS). Throws xp::InputError naming --pacs when malformed. */
  explicit OrthancArchive(const std::string& url);

  /** Throws xp::InputError naming the URL when no Orthanc answers there. */
  void CheckReachable() const;

  /** The series of the study with this Study Instance UID; throws xp::InputError when the
   *  archive holds no such study. */
  std::vector<ArchivedSeries> SeriesOfStudy(const std::string& studyUID) const;

  /** The one CT series of a study; several or none give an xp::InputError listing the series found. */
  std::string CTSeriesOfStudy(const std::string& studyUID) const;

  /** Downloads every instance of a series into `directory` (which must exist); returns the files. */
  std::vector<std::string> FetchSeries(const std::string& seriesUID, const std::string& directory) const;

  /** Downloads one instance by SOP Instance UID to `path`. */
  void FetchInstance(const std::string& sopInstanceUID, const std::string& path) const;

  /**
   * Stores the files in the archive, in order. When one is refused, those this call stored are
   * deleted again and xp::Error names the file: nothing is left half-stored.
   */
  void Store(const std::vector<std::string>& files) const;

private:
  struct Response
  {
    int status = 0;
    std::string body;
  };
  Response Request(const std::string& method, const std::string& path, const std::string& body = "",
    const std::string& contentType = "application/json") const;
  /** GET `path`, which must answer 200 (the `what` of the error otherwise). */
  std::string Get(const std::string& path) const;
  /** The Orthanc identifiers of the resources at `level` whose `tag` is `value`. */
  std::vector<std::string> Find(const std::string& level, const std::string& tag, const std::string& value) const;

  std::string Url, Host;
  int Port = 0;
};

} // namespace xp

#endif
