/**
 * @file xpReport.h
 * @brief The visual report of one registration: index.html and summary.png with the pictures,
 *        the correction table, the convergence plot and the 3D room scene, written off-screen.
 */
#ifndef xpReport_h
#define xpReport_h

#include "vtkXPReportingModule.h"

#include "xpCouch.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace xp
{

/** One view, all images row 0 first at the registration resolution. */
struct ReportView
{
  std::string name;
  int columns = 0, rows = 0;
  std::vector<uint16_t> xray;      ///< 12-bit
  std::vector<uint16_t> drrStart;  ///< 12-bit DRR at the start (planned) pose, whole image
  std::vector<uint16_t> drrFinal;  ///< 12-bit DRR at the result, whole image
  std::vector<float> entropy;      ///< 0..1 block entropy; empty without entropy masks
  std::vector<uint8_t> mask;       ///< 1 = used by the registration
  std::vector<uint8_t> roi;        ///< the user ROI, 1 = allowed; empty = the whole image
  double similarity = 0.0;         ///< MI at the result (nats)
  double explained = 0.0;          ///< MI / H(X-ray)
  double validFraction = 1.0;
  /** The median distance (mm at the isocentre) from the final DRR's edges to the X-ray's, and
   *  with the DRR moved 3 mm; -1: not measured (xpEdgeAgreement.h). */
  double edgeDistanceMM = -1.0, edgeDistanceMovedMM = -1.0;
};

struct ReportContent
{
  std::string title;               ///< what was registered (CT and X-rays)
  bool ok = false;
  std::vector<std::string> reasons;
  Pose misalignment, correction;
  std::optional<CouchMotion> couch; ///< an ok result's couch motion (xpCouch.h)
  std::string convention;
  double objective = 0.0;
  long long drrCount = 0;
  int evaluations = 0;
  std::vector<std::pair<std::string, double>> seconds; ///< per stage, in order
  std::vector<ReportView> views;
  std::vector<double> trace;                          ///< objective per 6-DOF evaluation
  std::vector<std::pair<std::string, int>> stages;    ///< stage name, first evaluation
  /** The 3D room scene (xpRoomScene.h) as rendered by the caller, who owns the display it
   *  needs; null when there is none, and `roomNote` says why. */
  vtkSmartPointer<vtkImageData> room;
  std::string roomNote = "no 3D scene was asked for";
};

/** Writes the report into `directory` (created; files replaced; nothing half-written). */
VTKXPREPORTING_EXPORT void WriteReport(const ReportContent& content, const std::string& directory);

} // namespace xp

#endif
