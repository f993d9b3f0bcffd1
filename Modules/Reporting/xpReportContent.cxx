#include "xpReportContent.h"

#include "vtkXPDRRFilter.h"
#include "xpEntropyMask.h"
#include "xpImageRows.h"
#include "xpRegistrationRecord.h"
#include "xpStereoSimilarity.h"

namespace xp
{

namespace
{

/** The whole-image 12-bit DRR of `view` at `misalignment`. */
std::vector<uint16_t> RenderDRR(vtkXPDRRFilter* filter, const XRayView& view, const Pose& misalignment)
{
  filter->SetView(view);
  filter->SetMisalignment(misalignment);
  filter->Update();
  return RowsTopFirst<uint16_t>(filter->GetOutput(0));
}

} // namespace

ReportContent ReportContentOf(const RegistrationRecord& record, const std::string& title)
{
  ReportContent content;
  content.title = title;
  content.ok = record.ok;
  content.reasons = record.Reasons();
  content.misalignment = record.misalignment;
  content.correction = record.correction;
  content.couch = record.couch;
  content.convention = CorrectionConvention;
  content.objective = record.objective;
  content.drrCount = record.drrCount;
  content.evaluations = record.evaluations;
  content.seconds = { { "read", record.readSeconds }, { "prealign", record.prealignSeconds }, { "mask", record.maskSeconds },
    { "fine", record.fineSeconds }, { "total", record.totalSeconds } };
  content.trace = record.objectiveTrace;
  for (const RegistrationStage& stage : record.stages)
    content.stages.emplace_back(stage.name, stage.firstEvaluation);
  return content;
}

ReportView ReportViewOf(const RegistrationRecord& record, size_t index, const RegistrationView& item,
  std::vector<uint8_t> mask, bool entropyMask, vtkXPDRRFilter* drr)
{
  const XRayView& view = item.view;
  ReportView v;
  v.name = view.name;
  v.columns = view.Columns();
  v.rows = view.Rows();
  v.xray = item.xray;
  v.roi = item.mask;
  v.mask = std::move(mask);
  if (entropyMask) // the same computation as the registration's, from the same X-ray and ROI
    v.entropy = ComputeEntropyMask(v.xray.data(), v.columns, v.rows, v.roi.empty() ? nullptr : v.roi.data()).entropy;
  v.drrStart = RenderDRR(drr, view, record.initialPose);
  v.drrFinal = RenderDRR(drr, view, record.misalignment);
  v.similarity = record.similarity.at(index);
  v.explained = record.explained.at(index);
  v.validFraction = record.validFraction.at(index);
  if (index < record.edgeDistanceMM.size())
  {
    v.edgeDistanceMM = record.edgeDistanceMM[index];
    v.edgeDistanceMovedMM = record.edgeDistanceShiftedMM.at(index);
  }
  return v;
}

} // namespace xp
