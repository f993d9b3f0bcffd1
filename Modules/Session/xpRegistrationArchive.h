/**
 * @file xpRegistrationArchive.h
 * @brief A registration session's archive: its inputs fetched from a DICOM archive by UID (a
 *        source), and its DICOM results stored back into the study (a writer).
 */
#ifndef xpRegistrationArchive_h
#define xpRegistrationArchive_h

#include "vtkXPSessionModule.h"

#include <string>
#include <vector>

namespace xp
{

class DICOMArchive;

/** Where FetchRegistrationInputs put what it fetched. */
struct ArchivedInputs
{
  std::string ctFolder;            ///< the CT series' instances, 0001.dcm, ...
  std::string ctSeries;            ///< its Series Instance UID
  std::vector<std::string> xrays;  ///< one file per X-ray, in the order of their UIDs
};

/**
 * Fetches into `folder` (emptied first; kept afterwards, so that `xpose report` can rebuild the
 * pictures) the CT series, the one CT series of `study` unless `ctSeries` names it, into
 * folder/ct, and each X-ray instance into folder/xray_N.dcm. Throws xp::InputError naming the
 * option or the UID the archive does not have.
 */
VTKXPSESSION_EXPORT ArchivedInputs FetchRegistrationInputs(const DICOMArchive& archive, const std::string& study,
  const std::string& ctSeries, const std::vector<std::string>& xrayInstances, const std::string& folder);

/**
 * Stores the DICOM results of `directory` (WriteDICOMRegistration's) in the archive: the RT Image
 * DRRs and the report's Secondary Capture first, the REG (written for an `ok` result only) last:
 * an archive cannot take an instance back, so the REG that a planning system acts on is stored
 * only when everything it refers to was. Returns the files stored, in order.
 */
VTKXPSESSION_EXPORT std::vector<std::string> StoreRegistrationDICOM(const DICOMArchive& archive, const std::string& directory);

} // namespace xp

#endif
