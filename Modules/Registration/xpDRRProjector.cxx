#include "xpDRRProjector.h"

#include "xpError.h"
#include "xpParallel.h"

#include <algorithm>
#include <string>

namespace xp
{

namespace
{

/** The panel's pixel spacings shrunk by the magnification where the central ray passes the isocentre. */
Eigen::Vector2d PixelSpacingsAtIsocenter(const XRayView& view, const Eigen::Vector3d& roomIsocenter)
{
  const double toIsocenter = (view.source - roomIsocenter).dot(view.NormalTowardsSource());
  return view.pixelSpacing * toIsocenter / view.SourceToPanelDistance();
}

} // namespace

double PixelSpacingAtIsocenter(const XRayView& view, const Eigen::Vector3d& roomIsocenter)
{
  return PixelSpacingsAtIsocenter(view, roomIsocenter).maxCoeff();
}

double CTSpacingAlong(const AttenuationVolume& volume, const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomDirection)
{
  const Eigen::Vector3d inCT = plannedCTToRoom.linear().transpose() * roomDirection.normalized();
  return 1.0 / (volume.IndexToCT().linear().inverse() * inCT).norm();
}

RenderStride RenderStrideFor(const AttenuationVolume& volume, const std::vector<RegistrationView>& views,
  const Eigen::Isometry3d& plannedCTToRoom, const Eigen::Vector3d& roomIsocenter)
{
  const auto strideAlong = [&](const XRayView& view, int axis)
  {
    const Eigen::Vector3d& direction = axis == 0 ? view.rowDirection : view.columnDirection;
    const double pixelAtIsocenter = PixelSpacingsAtIsocenter(view, roomIsocenter)[axis];
    return 2.0 * pixelAtIsocenter <= 1.1 * CTSpacingAlong(volume, plannedCTToRoom, direction) ? 2 : 1;
  };
  RenderStride stride{ 2, 2 };
  for (const RegistrationView& item : views)
  {
    stride.columns = std::min(stride.columns, strideAlong(item.view, 0));
    stride.rows = std::min(stride.rows, strideAlong(item.view, 1));
  }
  return stride;
}

DRRProjector::DRRProjector(const AttenuationVolume& volume, const std::vector<RegistrationView>& views)
  : Volume(volume)
  , Views(views)
{
  for (const RegistrationView& item : views)
  {
    const size_t pixels = static_cast<size_t>(item.view.Columns()) * item.view.Rows();
    if (!item.mask.empty() && item.mask.size() != pixels)
      throw InputError("view " + item.view.name, "X-ray or mask size does not match the panel");
    this->Buffers.emplace_back(pixels);
  }
  this->SetStride(RenderStride{});
}

void DRRProjector::SetStride(const RenderStride& stride)
{
  for (int step : { stride.columns, stride.rows })
    if (step < 1 || step > 8)
      throw InputError("render stride", "must be 1 to 8, not " + std::to_string(step));
  this->Settings = stride;
  this->Grids.clear();
  this->TracedPixelsOf.clear();
  this->NodeIntegrals.clear();
  const int sc = stride.columns, sr = stride.rows;
  for (const RegistrationView& item : this->Views)
  {
    const DetectorGrid full = DetectorGrid::TopRowFirst(item.view);
    if (sc == 1 && sr == 1)
    {
      this->Grids.push_back(full);
      this->TracedPixelsOf.emplace_back(full.columns, full.rows, item.mask.empty() ? nullptr : item.mask.data());
      continue;
    }
    // Node (c', r') sits on pixel (sc c', sr r'); the last nodes reach past the last pixel.
    DetectorGrid grid = full;
    grid.columnStep = sc * full.columnStep;
    grid.rowStep = sr * full.rowStep;
    grid.columns = (full.columns - 1 + sc - 1) / sc + 1;
    grid.rows = (full.rows - 1 + sr - 1) / sr + 1;
    std::vector<uint8_t> nodes(static_cast<size_t>(grid.columns) * grid.rows, 0);
    for (int r = 0; r < full.rows; ++r)
      for (int c = 0; c < full.columns; ++c)
      {
        if (!item.mask.empty() && !item.mask[static_cast<size_t>(r) * full.columns + c])
          continue;
        const int c0 = c / sc, r0 = r / sr;
        const int c1 = c0 + (c % sc != 0), r1 = r0 + (r % sr != 0);
        for (int rr : { r0, r1 })
          for (int cc : { c0, c1 })
            nodes[static_cast<size_t>(rr) * grid.columns + cc] = 1;
      }
    this->Grids.push_back(grid);
    this->TracedPixelsOf.emplace_back(grid.columns, grid.rows, nodes.data());
    this->NodeIntegrals.emplace_back(nodes.size(), 0.0f);
  }
}

long long DRRProjector::Render(const Eigen::Isometry3d& ctToRoom) const
{
  const bool strided = !(this->Settings == RenderStride{});
  std::vector<RenderTarget> targets;
  for (size_t v = 0; v < this->Views.size(); ++v)
    targets.push_back(RenderTarget{ this->Views[v].view.source, this->Grids[v], &this->TracedPixelsOf[v],
      strided ? this->NodeIntegrals[v].data() : this->Buffers[v].data() });
  const long long rays = RenderLineIntegrals(this->Volume, ctToRoom, targets, this->RayCast);
  if (!strided)
    return rays;
  // The pixels between the nodes, bilinear; rows on all threads.
  const int sc = this->Settings.columns, sr = this->Settings.rows;
  const float columnStep = 1.0f / static_cast<float>(sc), rowStep = 1.0f / static_cast<float>(sr);
  for (size_t v = 0; v < this->Views.size(); ++v)
  {
    const RegistrationView& item = this->Views[v];
    const DetectorGrid& grid = this->Grids[v];
    const float* nodes = this->NodeIntegrals[v].data();
    float* out = this->Buffers[v].data();
    const int columns = item.view.Columns();
    ParallelFor(0, item.view.Rows(), 16,
      [&](int firstRow, int lastRow)
      {
        for (int r = firstRow; r < lastRow; ++r)
        {
          const int r0 = r / sr, dr = r % sr;
          const float fr = dr * rowStep;
          const float* row0 = nodes + static_cast<size_t>(r0) * grid.columns;
          const float* row1 = dr ? row0 + grid.columns : row0;
          for (int c = 0; c < columns; ++c)
          {
            const size_t i = static_cast<size_t>(r) * columns + c;
            if (!item.mask.empty() && !item.mask[i])
              continue;
            const int c0 = c / sc, dc = c % sc;
            const int c1 = dc ? c0 + 1 : c0;
            const float fc = dc * columnStep;
            const float top = row0[c0] + fc * (row0[c1] - row0[c0]);
            const float bottom = row1[c0] + fc * (row1[c1] - row1[c0]);
            out[i] = top + fr * (bottom - top);
          }
        }
      });
  }
  return rays;
}

} // namespace xp
