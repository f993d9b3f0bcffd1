/**
 * @file xpStorageNode.h
 * @brief A DICOM storage node (C-STORE SCP, through dcmtk) that keeps what it receives by study
 *        and says when a study has gone quiet, so that a treatment room's imaging system can
 *        send the CT and the X-ray pair and have them registered.
 */
#ifndef xpStorageNode_h
#define xpStorageNode_h

#include "vtkXPArchiveModule.h"

#include <atomic>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace xp
{

/** One instance received, as written under the node's folder. */
struct VTKXPARCHIVE_EXPORT ReceivedInstance
{
  std::string path;
  std::string callingAET;
  std::string studyUID, seriesUID, sopClassUID, sopInstanceUID;
  std::string modality;
  std::string patientPosition; ///< (0018,5100), empty when absent
};

struct VTKXPARCHIVE_EXPORT StorageNodeSettings
{
  int port = 104;
  std::string aeTitle = "XPOSE";
  /** Calling AE titles admitted; empty: any. */
  std::vector<std::string> allowedCallers;
  /** Received instances go to DIRECTORY/STUDY_UID/received/SERIES_UID/. */
  std::string directory;
  /** A study is handed over once nothing of it arrived for this long. */
  double settleSeconds = 10.0;
};

class VTKXPARCHIVE_EXPORT StorageNode
{
public:
  /** Called, on the node's thread, for a study that has gone quiet with new instances: all its
   *  instances received so far, in arrival order. What it throws is logged and the node serves on. */
  using StudyHandler = std::function<void(const std::string& studyUID, const std::vector<ReceivedInstance>& instances)>;
  /** One line per event (association, instance, refusal, study handed over). */
  using Logger = std::function<void(const std::string& line)>;

  /** Throws xp::InputError naming the option of a bad AE title, port or settle time. */
  StorageNode(StorageNodeSettings settings, StudyHandler handler, Logger log);
  ~StorageNode();

  /** Serves until `stop` is true (looked at every second, and after each association).
   *  Throws xp::InputError when the port cannot be opened. */
  void Serve(const std::atomic<bool>& stop);

  /** The storage SOP classes accepted: CT, RT Image, DX, CR, XA, Secondary Capture, REG. */
  static std::vector<std::string> AcceptedClasses();

private:
  class Provider;
  std::unique_ptr<Provider> Node;
};

} // namespace xp

#endif
