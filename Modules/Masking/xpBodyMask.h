/**
 * @file xpBodyMask.h
 * @brief The patient's body in a CT, apart from the scanner table and the air around it.
 *
 * A planning CT shows its own table under the patient; a treatment couch is another object, in
 * another place. Rendering DRRs, or simulating X-rays, from the body alone keeps the CT's table
 * out of both.
 */
#ifndef xpBodyMask_h
#define xpBodyMask_h

#include "vtkXPMaskingModule.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace xp
{

struct BodyMaskSettings
{
  /** Tissue is above this (HU): fat (-100) and skin are in; the table's foam and carbon shell,
   *  mostly -900 to -400 HU in a CT, and the air between them and the patient are out. */
  double thresholdHU = -400.0;
  /** A separate component is kept when it has at least this fraction of the largest one's
   *  voxels: arms beside the body stay, thin table fragments (rails, shell edges) go. */
  double minComponentFraction = 0.02;
  /** In-slice radius (voxels) of the opening that separates thin shells from the body: parts
   *  thinner than 2 r + 1 voxels cannot hold a component together. */
  int openingRadius = 3;
  /** Voxels added around the kept tissue in each slice: the skin's partial-volume rim. */
  int dilation = 1;
  /** Outside the body and denser than this (HU): the CT's table, its foam and shell, not air or
   *  its noise (BodyOnly's `table`). */
  double tableHU = -850.0;
};

/**
 * 1 for voxels of the body: the tissue above the threshold that belongs to a large 6-connected
 * component once thin parts are opened away, with the cavities of each slice (bowel gas, lungs)
 * filled, dilated by `dilation` voxels in-slice.
 * @param hu voxels, x fastest, dims[0] * dims[1] * dims[2] values
 */
template <typename HU> // float, or int16_t as the CT readers keep whole-number HU
VTKXPMASKING_EXPORT std::vector<uint8_t> SegmentBody(
  const HU* hu, const Eigen::Vector3i& dims, const BodyMaskSettings& settings = {});

/** A CT's body (SegmentBody) and how many voxels outside it are denser than settings.tableHU:
 *  the CT's table. */
struct BodyVoxels
{
  std::vector<uint8_t> inBody; ///< 1 in the body, one per voxel of the CT, x fastest
  long long tableVoxels = 0;
};

/** SegmentBody of a HU image, on its own values (16-bit or float; others read as floats). */
VTKXPMASKING_EXPORT BodyVoxels BodyOf(vtkImageData* ct, const BodyMaskSettings& settings = {});

/** Sets every voxel outside `body` to -1000 HU (air); returns how many changed. */
VTKXPMASKING_EXPORT long long ClearOutsideBody(float* hu, const std::vector<uint8_t>& body);

/** A float copy of a HU image with everything outside the body set to air: the CT without its
 *  table. `removed` (optional) receives the number of voxels cleared, `table` (optional) those of
 *  them denser than settings.tableHU. */
VTKXPMASKING_EXPORT vtkSmartPointer<vtkImageData> BodyOnly(
  vtkImageData* ct, const BodyMaskSettings& settings = {}, long long* removed = nullptr, long long* table = nullptr);

} // namespace xp

#endif
