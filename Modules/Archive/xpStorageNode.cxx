#include "xpStorageNode.h"

#include "xpDIMSEArchive.h"
#include "xpError.h"

#include <dcmtk/config/osconfig.h>
#include <dcmtk/dcmdata/dcdeftag.h>
#include <dcmtk/dcmdata/dcuid.h>
#include <dcmtk/dcmnet/dstorscp.h>
#include <dcmtk/oflog/oflog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>

namespace xp
{

namespace
{

using Clock = std::chrono::steady_clock;

std::string Text(DcmItem& item, const DcmTagKey& key)
{
  OFString value;
  item.findAndGetOFStringArray(key, value);
  return value.c_str();
}

bool IsUID(const std::string& text)
{
  return !text.empty() && text.size() <= 64 && text.find_first_not_of("0123456789.") == std::string::npos;
}

} // namespace

/** dcmtk's storage SCP, told what to admit and what to do with what it stored. */
class StorageNode::Provider : public DcmStorageSCP
{
public:
  Provider(StorageNodeSettings settings, StudyHandler handler, Logger log)
    : Settings(std::move(settings))
    , Handle(std::move(handler))
    , Log(std::move(log))
  {
  }

  StorageNodeSettings Settings;
  StudyHandler Handle;
  Logger Log;
  const std::atomic<bool>* Stop = nullptr;

  /** What the node knows of a study: its instances and when the last arrived. */
  struct Study
  {
    std::vector<ReceivedInstance> instances;
    Clock::time_point last;
    bool handed = true; ///< no instance since the handler last saw it
  };
  mutable std::map<std::string, Study> Studies;
  mutable std::string Caller;

  /** Hands over every study that has new instances and has been quiet for the settle time. */
  void HandOverSettled()
  {
    const Clock::time_point now = Clock::now();
    for (auto& [uid, study] : this->Studies)
    {
      if (study.handed || std::chrono::duration<double>(now - study.last).count() < this->Settings.settleSeconds)
        continue;
      study.handed = true;
      this->Log("study " + uid + ": quiet for " + std::to_string(static_cast<int>(this->Settings.settleSeconds)) + " s with " +
        std::to_string(study.instances.size()) + " instances");
      try
      {
        this->Handle(uid, study.instances);
      }
      catch (const std::exception& e)
      {
        this->Log("study " + uid + ": " + e.what());
      }
    }
  }

protected:
  OFBool checkCalledAETitleAccepted(const OFString& called) override
  {
    const bool accepted = called == this->Settings.aeTitle.c_str();
    if (!accepted)
      this->Log("association refused: called AE title '" + std::string(called.c_str()) + "' is not " + this->Settings.aeTitle);
    return accepted;
  }

  OFBool checkCallingAETitleAccepted(const OFString& calling) override
  {
    const std::vector<std::string>& allowed = this->Settings.allowedCallers;
    const bool accepted = allowed.empty() || std::find(allowed.begin(), allowed.end(), calling.c_str()) != allowed.end();
    if (!accepted)
      this->Log("association refused: calling AE title '" + std::string(calling.c_str()) + "' is not allowed (--allow-aet)");
    this->Caller = calling.c_str();
    return accepted;
  }

  void notifyAssociationAcknowledge() override { this->Log("association from " + this->Caller + " accepted"); }

  void notifyAssociationTermination() override { this->HandOverSettled(); }

  void notifyConnectionTimeout() override { this->HandOverSettled(); }

  OFBool stopAfterConnectionTimeout() override { return this->Stop && this->Stop->load(); }

  OFBool stopAfterCurrentAssociation() override { return this->Stop && this->Stop->load(); }

  void notifyInstanceStored(
    const OFString& filename, const OFString& sopClassUID, const OFString& sopInstanceUID, DcmDataset* dataset) const override
  {
    ReceivedInstance instance;
    instance.callingAET = this->Caller;
    instance.sopClassUID = sopClassUID.c_str();
    instance.sopInstanceUID = sopInstanceUID.c_str();
    if (dataset)
    {
      instance.studyUID = Text(*dataset, DCM_StudyInstanceUID);
      instance.seriesUID = Text(*dataset, DCM_SeriesInstanceUID);
      instance.modality = Text(*dataset, DCM_Modality);
      instance.patientPosition = Text(*dataset, DCM_PatientPosition);
    }
    std::error_code error;
    if (!IsUID(instance.studyUID) || !IsUID(instance.seriesUID))
    {
      std::filesystem::remove(filename.c_str(), error);
      this->Log("instance " + instance.sopInstanceUID + " from " + this->Caller + " dropped: no valid Study or Series Instance UID");
      return;
    }
    Study& study = this->Studies[instance.studyUID];
    // One folder per series: a CT series' folder is what a CT reader takes.
    const std::string folder = this->Settings.directory + "/" + instance.studyUID + "/received/" + instance.seriesUID;
    char name[32];
    std::snprintf(name, sizeof(name), "/%05zu.dcm", study.instances.size() + 1);
    instance.path = folder + name;
    std::filesystem::create_directories(folder, error);
    if (!error)
      std::filesystem::rename(filename.c_str(), instance.path, error);
    if (error)
    {
      this->Log("instance " + instance.sopInstanceUID + " could not be kept: " + error.message());
      return;
    }
    study.instances.push_back(instance);
    study.last = Clock::now();
    study.handed = false;
    this->Log("received " + (instance.modality.empty() ? std::string("?") : instance.modality) + " " + instance.sopInstanceUID +
      " of study " + instance.studyUID + " from " + this->Caller);
  }
};

std::vector<std::string> StorageNode::AcceptedClasses()
{
  return { UID_CTImageStorage, UID_RTImageStorage, UID_DigitalXRayImageStorageForPresentation,
    UID_DigitalXRayImageStorageForProcessing, UID_ComputedRadiographyImageStorage, UID_XRayAngiographicImageStorage,
    UID_SecondaryCaptureImageStorage, UID_SpatialRegistrationStorage };
}

StorageNode::StorageNode(StorageNodeSettings settings, StudyHandler handler, Logger log)
{
  CheckedAETitle(settings.aeTitle, "--aet");
  for (const std::string& caller : settings.allowedCallers)
    CheckedAETitle(caller, "--allow-aet");
  if (settings.port < 1 || settings.port > 65535)
    throw InputError("--port", "expected 1 to 65535, got " + std::to_string(settings.port));
  if (!(settings.settleSeconds >= 0.0 && settings.settleSeconds <= 3600.0))
    throw InputError("--settle", "expected 0 to 3600 seconds");
  OFLog::configure(OFLogger::OFF_LOG_LEVEL);
  const std::string incoming = settings.directory + "/incoming";
  std::filesystem::create_directories(incoming);
  this->Node = std::make_unique<Provider>(std::move(settings), std::move(handler), std::move(log));
  Provider& node = *this->Node;
  node.setPort(static_cast<Uint16>(node.Settings.port));
  node.setAETitle(node.Settings.aeTitle.c_str());
  node.setConnectionBlockingMode(DUL_NOBLOCK);
  node.setConnectionTimeout(1);
  node.setACSETimeout(30);
  node.setDIMSETimeout(60);
  node.setOutputDirectory(incoming.c_str());
  node.setFilenameGenerationMode(DcmStorageSCP::FGM_UniqueFromNewUID); // no name comes from a sender
  OFList<OFString> syntaxes;
  syntaxes.push_back(UID_LittleEndianExplicitTransferSyntax);
  syntaxes.push_back(UID_LittleEndianImplicitTransferSyntax);
  // dcmtk's default profile holds Verification (C-ECHO) already: a second entry would void it.
  for (const std::string& sopClass : AcceptedClasses())
  {
    const OFCondition added = node.addPresentationContext(sopClass.c_str(), syntaxes);
    if (added.bad())
      throw Error("storage node", "SOP class " + sopClass + " not accepted by dcmtk's SCP (" + added.text() + ")");
  }
  const OFCondition profile = node.setAndCheckAssociationProfile("DEFAULT");
  if (profile.bad())
    throw Error("storage node", std::string("dcmtk's SCP refused its presentation contexts (") + profile.text() + ")");
}

StorageNode::~StorageNode() = default;

void StorageNode::Serve(const std::atomic<bool>& stop)
{
  this->Node->Stop = &stop;
  const OFCondition condition = this->Node->listen();
  if (condition.bad() && condition != NET_EC_StopAfterConnectionTimeout && condition != NET_EC_StopAfterAssociation)
    throw InputError("--port", "cannot serve on port " + std::to_string(this->Node->Settings.port) + " (" + condition.text() + ")");
}

} // namespace xp
