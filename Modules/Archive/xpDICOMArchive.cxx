#include "xpDICOMArchive.h"

#include "xpDICOMwebArchive.h"
#include "xpDIMSEArchive.h"
#include "xpError.h"

namespace xp
{

namespace
{

std::string FileName(const std::string& path)
{
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

} // namespace

const std::string& CheckedUID(const std::string& uid, const std::string& where)
{
  if (uid.empty() || uid.size() > 64 || uid.find_first_not_of("0123456789.") != std::string::npos)
    throw InputError(where, "'" + uid.substr(0, 80) + "' is not a DICOM UID (digits and dots, 64 at most)");
  return uid;
}

std::string DICOMArchive::CTSeriesOfStudy(const std::string& studyUID) const
{
  std::vector<const ArchivedSeries*> cts;
  std::string found;
  const std::vector<ArchivedSeries> series = this->SeriesOfStudy(studyUID);
  for (const ArchivedSeries& s : series)
  {
    found += "\n  " + s.modality + " " + s.seriesInstanceUID + " (" + std::to_string(s.instances) + " images" +
      (s.description.empty() ? "" : ", " + s.description) + ")";
    if (s.modality == "CT")
      cts.push_back(&s);
  }
  if (cts.size() != 1)
    throw InputError("--study", "study " + studyUID + " holds " + (cts.empty() ? "no CT series" : "several CT series") +
        "; choose one with --ct-series. The archive holds:" + found);
  return cts.front()->seriesInstanceUID;
}

void DICOMArchive::ThrowStoreRefused(const std::vector<std::string>& files, size_t refused, const std::string& why, bool badInput) const
{
  std::string stored, notStored;
  for (size_t f = 0; f < refused; ++f)
    stored += " " + FileName(files[f]);
  for (size_t f = refused; f < files.size(); ++f)
    notStored += " " + FileName(files[f]);
  const std::string message = "not stored in " + this->Address() + " (" + why + "). Stored:" + (stored.empty() ? " none" : stored) +
    "; not stored:" + notStored;
  if (badInput)
    throw InputError(files[refused], message);
  throw Error(files[refused], message);
}

std::unique_ptr<DICOMArchive> OpenArchive(const std::string& url, const ArchiveAccess& access, const std::string& callingAET)
{
  if (url.compare(0, 8, "dicom://") == 0)
    return std::make_unique<DIMSEArchive>(url, callingAET, access);
  return std::make_unique<DICOMwebArchive>(url, access);
}

} // namespace xp
