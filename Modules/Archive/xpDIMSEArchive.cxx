#include "xpDIMSEArchive.h"

#include "xpError.h"

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcfilefo.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmnet/scu.h>
#include <dcmtk/oflog/oflog.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <mutex>

namespace xp
{

namespace
{

/** What xpose fetches and stores: CTs, X-rays (RT Image, DX, CR, XA), and its own results. */
const char* const StorageClasses[] = { UID_CTImageStorage, UID_RTImageStorage,
  UID_DigitalXRayImageStorageForPresentation, UID_DigitalXRayImageStorageForProcessing, UID_ComputedRadiographyImageStorage,
  UID_XRayAngiographicImageStorage, UID_SecondaryCaptureImageStorage, UID_SpatialRegistrationStorage };

OFList<OFString> UncompressedSyntaxes()
{
  OFList<OFString> syntaxes;
  syntaxes.push_back(UID_LittleEndianExplicitTransferSyntax);
  syntaxes.push_back(UID_LittleEndianImplicitTransferSyntax);
  return syntaxes;
}

/** dcmtk's own log stays quiet: every failure reaches the user as an xp::Error naming the archive. */
void QuietDCMTK()
{
  static std::once_flag once;
  std::call_once(once, [] { OFLog::configure(OFLogger::OFF_LOG_LEVEL); });
}

std::string Text(DcmItem& item, const DcmTagKey& key)
{
  OFString value;
  item.findAndGetOFStringArray(key, value);
  return value.c_str();
}

/** dcmtk's SCU whose C-GET sub-operations write each instance received as 0001.dcm, ... in
 *  `directory` (through a .partial file, never a half-written one). */
class FetchingSCU : public DcmSCU
{
public:
  std::string Directory;
  std::vector<std::string> Files;
  std::string Failure;

protected:
  OFCondition handleSTORERequest(const T_ASC_PresentationContextID, DcmDataset* incoming, OFBool& continueSession,
    Uint16& status) override
  {
    continueSession = OFTrue;
    char name[32];
    std::snprintf(name, sizeof(name), "/%04zu.dcm", this->Files.size() + 1);
    const std::string path = this->Directory + name;
    DcmFileFormat file(incoming);
    delete incoming;
    const OFCondition saved = file.saveFile((path + ".partial").c_str(), EXS_Unknown);
    std::error_code error;
    if (saved.good())
      std::filesystem::rename(path + ".partial", path, error);
    if (saved.bad() || error)
    {
      std::filesystem::remove(path + ".partial", error);
      this->Failure = path + " cannot be written";
      status = STATUS_STORE_Refused_OutOfResources;
      return EC_Normal;
    }
    this->Files.push_back(path);
    status = STATUS_Success;
    return EC_Normal;
  }
};

/** An aborted or refused association: the archive's answer to an AE title it does not admit. */
void ThrowIfRefused(const OFCondition& condition, const DIMSEArchive& archive, const std::string& what)
{
  if (condition == DUL_PEERABORTEDASSOCIATION || condition == DUL_ASSOCIATIONREJECTED)
    throw InputError("--aet", archive.Address() + ": " + what + ": the archive ended the association (" + condition.text() +
        "); is xpose's AE title " + archive.CallingAET() + " declared there, with the right to do this?");
}

/** One association with the archive, with the presentation contexts given, or xp::InputError. */
void Associate(DcmSCU& scu, const DIMSEArchive& archive)
{
  QuietDCMTK();
  scu.setAETitle(archive.CallingAET().c_str());
  scu.setPeerHostName(archive.Host().c_str());
  scu.setPeerPort(static_cast<Uint16>(archive.Port()));
  scu.setPeerAETitle(archive.CalledAET().c_str());
  scu.setConnectionTimeout(10);
  scu.setACSETimeout(static_cast<Uint32>(archive.TimeoutSeconds()));
  scu.setDIMSETimeout(static_cast<Uint32>(archive.TimeoutSeconds()));
  scu.setDIMSEBlockingMode(DIMSE_NONBLOCKING);
  OFCondition condition = scu.initNetwork();
  if (condition.good())
    condition = scu.negotiateAssociation();
  if (condition.bad())
    throw InputError("--pacs", archive.Address() + " (calling as " + archive.CallingAET() + "): no association (" + condition.text() + ")");
}

T_ASC_PresentationContextID Context(DcmSCU& scu, const char* abstractSyntax, const DIMSEArchive& archive, const std::string& what)
{
  const T_ASC_PresentationContextID id = scu.findAnyPresentationContextID(abstractSyntax, "");
  if (id == 0)
    throw Error(archive.Address(), "the archive accepted no presentation context for " + what);
  return id;
}

/** A Study Root C-FIND: the matches' datasets. */
std::vector<DcmDataset> Find(const DIMSEArchive& archive, DcmDataset& keys, const std::string& what)
{
  DcmSCU scu;
  scu.addPresentationContext(UID_FINDStudyRootQueryRetrieveInformationModel, UncompressedSyntaxes());
  Associate(scu, archive);
  OFList<QRResponse*> responses;
  const OFCondition condition =
    scu.sendFINDRequest(Context(scu, UID_FINDStudyRootQueryRetrieveInformationModel, archive, "C-FIND"), &keys, &responses);
  std::vector<DcmDataset> matches;
  Uint16 last = STATUS_Success;
  for (QRResponse* response : responses)
  {
    if (response->m_dataset && DICOM_PENDING_STATUS(response->m_status))
      matches.push_back(*response->m_dataset);
    last = response->m_status;
    delete response;
  }
  scu.releaseAssociation();
  ThrowIfRefused(condition, archive, "C-FIND for " + what);
  if (condition.bad())
    throw Error(archive.Address(), "C-FIND for " + what + " failed (" + std::string(condition.text()) + ")");
  if (last != STATUS_Success && !DICOM_PENDING_STATUS(last))
  {
    char status[16];
    std::snprintf(status, sizeof(status), "0x%04x", last);
    throw Error(archive.Address(), "C-FIND for " + what + " ended with status " + status);
  }
  return matches;
}

/** A Study Root C-GET of `keys` into `directory`: the files written. */
std::vector<std::string> Get(const DIMSEArchive& archive, DcmDataset& keys, const std::string& directory, const std::string& what)
{
  FetchingSCU scu;
  scu.Directory = directory;
  scu.addPresentationContext(UID_GETStudyRootQueryRetrieveInformationModel, UncompressedSyntaxes());
  // The instances come back as C-STORE sub-operations: xpose takes the SCP role for them.
  for (const char* storage : StorageClasses)
    scu.addPresentationContext(storage, UncompressedSyntaxes(), ASC_SC_ROLE_SCP);
  Associate(scu, archive);
  OFList<RetrieveResponse*> responses;
  const OFCondition condition =
    scu.sendCGETRequest(Context(scu, UID_GETStudyRootQueryRetrieveInformationModel, archive, "C-GET"), &keys, &responses);
  Uint16 last = STATUS_Success;
  long failed = 0;
  for (RetrieveResponse* response : responses)
  {
    last = response->m_status;
    failed = std::max<long>(failed, response->m_numberOfFailedSubops);
    delete response;
  }
  scu.releaseAssociation();
  if (!scu.Failure.empty())
    throw Error(scu.Failure);
  ThrowIfRefused(condition, archive, "C-GET of " + what);
  if (condition.bad())
    throw Error(archive.Address(), "C-GET of " + what + " failed (" + std::string(condition.text()) + ")");
  if (last != STATUS_Success || failed > 0)
  {
    char status[16];
    std::snprintf(status, sizeof(status), "0x%04x", last);
    throw Error(archive.Address(), "C-GET of " + what + " ended with status " + status + ", " + std::to_string(failed) +
        " instances not sent");
  }
  if (scu.Files.empty())
    throw Error(archive.Address(), "C-GET of " + what + " sent no instance");
  return scu.Files;
}

} // namespace

const std::string& CheckedAETitle(const std::string& title, const std::string& where)
{
  const bool printable = std::all_of(title.begin(), title.end(), [](char c) { return c >= 0x20 && c < 0x7f && c != '\\'; });
  if (title.empty() || title.size() > 16 || !printable || title.find_first_not_of(' ') == std::string::npos)
    throw InputError(where, "'" + title.substr(0, 32) + "' is not an AE title (1 to 16 characters, no backslash)");
  return title;
}

DIMSEArchive::DIMSEArchive(const std::string& url, const std::string& callingAET, const ArchiveAccess& access)
  : URL(url)
  , Calling(CheckedAETitle(callingAET, "--aet"))
  , Timeout(access.timeoutSeconds)
{
  const std::string prefix = "dicom://";
  const std::string rest = url.compare(0, prefix.size(), prefix) == 0 ? url.substr(prefix.size()) : "";
  const size_t at = rest.find('@'), colon = rest.rfind(':');
  const std::string expected = "expected dicom://CALLED_AET@HOST:PORT, got '" + url + "'";
  if (at == std::string::npos || colon == std::string::npos || colon < at)
    throw InputError("--pacs", expected);
  this->Called = CheckedAETitle(rest.substr(0, at), "--pacs");
  this->HostName = rest.substr(at + 1, colon - at - 1);
  char* end = nullptr;
  const long port = std::strtol(rest.c_str() + colon + 1, &end, 10);
  if (this->HostName.empty() || this->HostName.find_first_of("/@ ") != std::string::npos || *end != '\0' || port < 1 || port > 65535)
    throw InputError("--pacs", expected);
  this->PortNumber = static_cast<int>(port);
  if (access.credentials.kind != ArchiveCredentials::Kind::None)
    throw InputError("--pacs-credentials", "a DIMSE archive (" + url + ") takes no credentials: it admits AE titles");
}

void DIMSEArchive::CheckReachable() const
{
  DcmSCU scu;
  scu.addPresentationContext(UID_VerificationSOPClass, UncompressedSyntaxes());
  Associate(scu, *this);
  const OFCondition condition = scu.sendECHORequest(Context(scu, UID_VerificationSOPClass, *this, "C-ECHO"));
  scu.releaseAssociation();
  if (condition.bad())
    throw InputError("--pacs", this->URL + ": no answer to C-ECHO (" + std::string(condition.text()) + ")");
}

std::vector<ArchivedSeries> DIMSEArchive::SeriesOfStudy(const std::string& studyUID) const
{
  DcmDataset keys;
  keys.putAndInsertString(DCM_QueryRetrieveLevel, "SERIES");
  keys.putAndInsertString(DCM_StudyInstanceUID, CheckedUID(studyUID, "--study").c_str());
  for (const DcmTagKey& key : { DCM_SeriesInstanceUID, DCM_Modality, DCM_SeriesDescription, DCM_NumberOfSeriesRelatedInstances })
    keys.insertEmptyElement(key);
  std::vector<ArchivedSeries> series;
  for (DcmDataset& match : Find(*this, keys, "study " + studyUID))
  {
    ArchivedSeries item;
    item.studyInstanceUID = studyUID;
    item.seriesInstanceUID = CheckedUID(Text(match, DCM_SeriesInstanceUID), this->URL + ": a series UID");
    item.modality = Text(match, DCM_Modality);
    item.description = Text(match, DCM_SeriesDescription);
    item.instances = std::atoi(Text(match, DCM_NumberOfSeriesRelatedInstances).c_str());
    series.push_back(item);
  }
  if (series.empty())
    throw InputError("--study", "the archive at " + this->URL + " holds no study " + studyUID);
  return series;
}

std::vector<std::string> DIMSEArchive::FetchSeries(const std::string& seriesUID, const std::string& directory) const
{
  DcmDataset query;
  query.putAndInsertString(DCM_QueryRetrieveLevel, "SERIES");
  query.putAndInsertString(DCM_SeriesInstanceUID, CheckedUID(seriesUID, "--ct-series").c_str());
  query.insertEmptyElement(DCM_StudyInstanceUID);
  std::vector<DcmDataset> found = Find(*this, query, "series " + seriesUID);
  if (found.size() != 1)
    throw InputError("--ct-series", "the archive at " + this->URL + " holds " + std::to_string(found.size()) + " series " + seriesUID +
        ", expected one");
  DcmDataset keys;
  keys.putAndInsertString(DCM_QueryRetrieveLevel, "SERIES");
  keys.putAndInsertString(DCM_StudyInstanceUID, CheckedUID(Text(found[0], DCM_StudyInstanceUID), this->URL + ": the study UID").c_str());
  keys.putAndInsertString(DCM_SeriesInstanceUID, seriesUID.c_str());
  return Get(*this, keys, directory, "series " + seriesUID);
}

void DIMSEArchive::FetchInstance(const std::string& sopInstanceUID, const std::string& path) const
{
  DcmDataset query;
  query.putAndInsertString(DCM_QueryRetrieveLevel, "IMAGE");
  query.putAndInsertString(DCM_SOPInstanceUID, CheckedUID(sopInstanceUID, "--xray-instance").c_str());
  query.insertEmptyElement(DCM_StudyInstanceUID);
  query.insertEmptyElement(DCM_SeriesInstanceUID);
  std::vector<DcmDataset> found = Find(*this, query, "instance " + sopInstanceUID);
  if (found.size() != 1)
    throw InputError("--xray-instance", "the archive at " + this->URL + " holds " + std::to_string(found.size()) + " instances " +
        sopInstanceUID + ", expected one");
  DcmDataset keys;
  keys.putAndInsertString(DCM_QueryRetrieveLevel, "IMAGE");
  keys.putAndInsertString(DCM_StudyInstanceUID, CheckedUID(Text(found[0], DCM_StudyInstanceUID), this->URL + ": the study UID").c_str());
  keys.putAndInsertString(DCM_SeriesInstanceUID, CheckedUID(Text(found[0], DCM_SeriesInstanceUID), this->URL + ": the series UID").c_str());
  keys.putAndInsertString(DCM_SOPInstanceUID, sopInstanceUID.c_str());
  const std::string staging = path + ".get";
  std::filesystem::remove_all(staging);
  std::filesystem::create_directories(staging);
  try
  {
    const std::vector<std::string> files = Get(*this, keys, staging, "instance " + sopInstanceUID);
    if (files.size() != 1)
      throw Error(this->URL, "C-GET of instance " + sopInstanceUID + " sent " + std::to_string(files.size()) + " instances, expected one");
    std::filesystem::rename(files.front(), path);
  }
  catch (...)
  {
    std::filesystem::remove_all(staging);
    throw;
  }
  std::filesystem::remove_all(staging);
}

void DIMSEArchive::Store(const std::vector<std::string>& files) const
{
  if (files.empty())
    return;
  // The SOP classes and transfer syntaxes of the files: one presentation context each.
  std::vector<std::pair<std::string, std::string>> classes(files.size());
  DcmSCU scu;
  for (size_t f = 0; f < files.size(); ++f)
  {
    DcmFileFormat file;
    if (file.loadFile(files[f].c_str(), EXS_Unknown, EGL_noChange, 4096, ERM_metaOnly).bad())
      this->ThrowStoreRefused(files, f, "not a DICOM file xpose can read");
    classes[f] = { Text(*file.getMetaInfo(), DCM_MediaStorageSOPClassUID), Text(*file.getMetaInfo(), DCM_TransferSyntaxUID) };
    if (std::find(classes.begin(), classes.begin() + static_cast<long>(f), classes[f]) != classes.begin() + static_cast<long>(f))
      continue;
    OFList<OFString> syntaxes;
    syntaxes.push_back(classes[f].second.c_str());
    scu.addPresentationContext(classes[f].first.c_str(), syntaxes);
  }
  Associate(scu, *this);
  for (size_t f = 0; f < files.size(); ++f)
  {
    const T_ASC_PresentationContextID id = scu.findPresentationContextID(classes[f].first.c_str(), classes[f].second.c_str());
    Uint16 status = 0;
    const OFCondition condition = id == 0 ? OFCondition(EC_IllegalCall) : scu.sendSTORERequest(id, files[f].c_str(), nullptr, status);
    std::string why;
    if (id == 0)
      why = "the archive accepted no presentation context for SOP class " + classes[f].first;
    else if (condition.bad())
      why = std::string("C-STORE failed: ") + condition.text();
    else if (status != STATUS_Success && !DICOM_WARNING_STATUS(status))
    {
      char text[16];
      std::snprintf(text, sizeof(text), "0x%04x", status);
      why = std::string("C-STORE status ") + text;
    }
    if (!why.empty())
    {
      scu.releaseAssociation();
      this->ThrowStoreRefused(files, f, why);
    }
  }
  scu.releaseAssociation();
}

} // namespace xp
