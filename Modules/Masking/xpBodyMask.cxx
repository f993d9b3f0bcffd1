#include "xpBodyMask.h"

#include "xpError.h"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>
#include <vtkType.h>

#include <algorithm>

namespace xp
{

namespace
{

using Index = long long;

/**
 * The voxels of `inside` whose 6-connected component holds at least `fraction` of the largest
 * one's voxels; empty when nothing is inside. Components are joined from runs along x (a run
 * meets the runs of the row before it in its slice and of its row in the slice before wherever
 * they share a column), by union-find over the runs: a few hundred thousand runs where a voxel
 * walk visits tens of millions of voxels.
 */
std::vector<uint8_t> KeepLargeComponents(const std::vector<uint8_t>& inside, const Eigen::Vector3i& d, double fraction)
{
  const Index nx = d[0], rows = static_cast<Index>(d[1]) * d[2];
  struct Run
  {
    int begin, end; // columns [begin, end)
  };
  std::vector<Run> runs;
  std::vector<size_t> rowStart(static_cast<size_t>(rows) + 1, 0);
  for (Index r = 0; r < rows; ++r)
  {
    rowStart[r] = runs.size();
    const uint8_t* row = inside.data() + r * nx;
    for (int x = 0; x < nx;)
    {
      if (!row[x])
      {
        ++x;
        continue;
      }
      const int begin = x;
      while (x < nx && row[x])
        ++x;
      runs.push_back({ begin, x });
    }
  }
  rowStart[rows] = runs.size();
  std::vector<uint8_t> kept(inside.size(), 0);
  if (runs.empty())
    return kept;

  std::vector<size_t> parent(runs.size());
  for (size_t i = 0; i < parent.size(); ++i)
    parent[i] = i;
  const auto root = [&](size_t i)
  {
    while (parent[i] != i)
      i = parent[i] = parent[parent[i]];
    return i;
  };
  // Joins the runs of row r with those of row q that share a column.
  const auto joinRows = [&](Index r, Index q)
  {
    size_t i = rowStart[r], j = rowStart[q];
    while (i < rowStart[r + 1] && j < rowStart[q + 1])
    {
      if (runs[i].begin < runs[j].end && runs[j].begin < runs[i].end)
      {
        const size_t a = root(i), b = root(j);
        if (a != b)
          parent[std::max(a, b)] = std::min(a, b);
      }
      if (runs[i].end < runs[j].end)
        ++i;
      else
        ++j;
    }
  };
  const Index ny = d[1];
  for (Index r = 0; r < rows; ++r)
  {
    if (r % ny > 0)
      joinRows(r, r - 1); // the row before, in the same slice
    if (r >= ny)
      joinRows(r, r - ny); // the same row, in the slice before
  }
  std::vector<Index> size(runs.size(), 0);
  for (size_t i = 0; i < runs.size(); ++i)
    size[root(i)] += runs[i].end - runs[i].begin;
  const Index largest = *std::max_element(size.begin(), size.end());
  for (Index r = 0; r < rows; ++r)
    for (size_t i = rowStart[r]; i < rowStart[r + 1]; ++i)
      if (size[root(i)] >= fraction * largest)
        std::fill(kept.begin() + r * nx + runs[i].begin, kept.begin() + r * nx + runs[i].end, uint8_t{ 1 });
  return kept;
}

/** Fills each slice's cavities: what the outside cannot reach from the slice border is body.
 *  Slices are independent: they run on all threads. */
void FillSliceCavities(std::vector<uint8_t>& body, const Eigen::Vector3i& d)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny;
  vtkSMPTools::For(Index{ 0 }, Index{ d[2] }, Index{ 1 },
    [&](Index firstSlice, Index endSlice)
    {
      std::vector<uint8_t> outside(static_cast<size_t>(slice));
      std::vector<Index> stack;
      for (Index z = firstSlice; z < endSlice; ++z)
      {
        uint8_t* b = body.data() + z * slice;
        std::fill(outside.begin(), outside.end(), 0);
        stack.clear();
        for (Index x = 0; x < nx; ++x)
          for (Index y : { Index(0), ny - 1 })
            stack.push_back(y * nx + x);
        for (Index y = 0; y < ny; ++y)
          for (Index x : { Index(0), nx - 1 })
            stack.push_back(y * nx + x);
        while (!stack.empty())
        {
          const Index p = stack.back();
          stack.pop_back();
          if (b[p] || outside[p])
            continue;
          outside[p] = 1;
          const Index x = p % nx;
          if (x > 0) stack.push_back(p - 1);
          if (x + 1 < nx) stack.push_back(p + 1);
          if (p >= nx) stack.push_back(p - nx);
          if (p + nx < slice) stack.push_back(p + nx);
        }
        for (Index p = 0; p < slice; ++p)
          b[p] = !outside[p];
      }
    });
}

/**
 * Square in-slice dilation by `radius` voxels, separable (along the rows, then down the columns),
 * each pass a sliding count of the set voxels within the window (linear in the slice, whatever
 * the radius; the columns a row of counts at a time, in memory order). Slices run on all threads.
 */
void DilateSlices(std::vector<uint8_t>& body, const Eigen::Vector3i& d, int radius)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny, r = radius;
  vtkSMPTools::For(Index{ 0 }, Index{ d[2] }, Index{ 1 },
    [&](Index firstSlice, Index endSlice)
    {
      std::vector<uint8_t> copy(static_cast<size_t>(slice));
      std::vector<int> counts(static_cast<size_t>(nx));
      for (Index z = firstSlice; z < endSlice; ++z)
      {
        uint8_t* b = body.data() + z * slice;
        // Along each row: count of set voxels in [x - r, x + r].
        for (Index y = 0; y < ny; ++y)
        {
          const uint8_t* in = b + y * nx;
          uint8_t* out = copy.data() + y * nx;
          int count = 0;
          for (Index x = 0; x < std::min(r, nx); ++x)
            count += in[x] != 0;
          for (Index x = 0; x < nx; ++x)
          {
            if (x + r < nx)
              count += in[x + r] != 0;
            if (x - r - 1 >= 0)
              count -= in[x - r - 1] != 0;
            out[x] = count > 0;
          }
        }
        // Down each column: counts over rows [y - r, y + r], one row of counts at a time.
        std::fill(counts.begin(), counts.end(), 0);
        for (Index y = 0; y < std::min(r, ny); ++y)
          for (Index x = 0; x < nx; ++x)
            counts[x] += copy[y * nx + x];
        for (Index y = 0; y < ny; ++y)
        {
          if (y + r < ny)
            for (Index x = 0; x < nx; ++x)
              counts[x] += copy[(y + r) * nx + x];
          if (y - r - 1 >= 0)
            for (Index x = 0; x < nx; ++x)
              counts[x] -= copy[(y - r - 1) * nx + x];
          uint8_t* out = b + y * nx;
          for (Index x = 0; x < nx; ++x)
            out[x] = counts[x] > 0;
        }
      }
    });
}

} // namespace

std::vector<uint8_t> SegmentBody(const float* hu, const Eigen::Vector3i& dims, const BodyMaskSettings& settings)
{
  if ((dims.array() < 1).any() || !hu)
  {
    throw InputError("body mask", "the CT is empty");
  }
  const size_t count = static_cast<size_t>(dims[0]) * dims[1] * dims[2];
  std::vector<uint8_t> tissue(count);
  for (size_t i = 0; i < count; ++i)
    tissue[i] = hu[i] > settings.thresholdHU;
  // Opening: an erosion removes thin shells (a table's carbon skin, a mask's mesh) before the
  // components are counted, so that they cannot join the body or count as a limb.
  std::vector<uint8_t> core(count);
  for (size_t i = 0; i < count; ++i)
    core[i] = !tissue[i];
  DilateSlices(core, dims, settings.openingRadius);
  for (uint8_t& v : core)
    v = !v;
  if (std::find(core.begin(), core.end(), uint8_t{ 1 }) == core.end())
  {
    throw InputError("body mask", "no part of the CT above " + std::to_string(settings.thresholdHU) +
        " HU is thicker than " + std::to_string(2 * settings.openingRadius + 1) + " voxels");
  }
  std::vector<uint8_t> body = KeepLargeComponents(core, dims, settings.minComponentFraction);
  // Back to the tissue's own outline: what the opening took from the kept parts.
  DilateSlices(body, dims, settings.openingRadius + 1);
  for (size_t i = 0; i < count; ++i)
    body[i] = body[i] && tissue[i];
  FillSliceCavities(body, dims);
  if (settings.dilation > 0)
    DilateSlices(body, dims, settings.dilation);
  return body;
}

long long ClearOutsideBody(float* hu, const std::vector<uint8_t>& body)
{
  long long changed = 0;
  for (size_t i = 0; i < body.size(); ++i)
    if (!body[i] && hu[i] != -1000.0f)
    {
      hu[i] = -1000.0f;
      ++changed;
    }
  return changed;
}

vtkSmartPointer<vtkImageData> BodyOnly(vtkImageData* ct, const BodyMaskSettings& settings, long long* removed, long long* table)
{
  vtkDataArray* scalars = ct ? ct->GetPointData()->GetScalars() : nullptr;
  if (!scalars || scalars->GetNumberOfComponents() != 1)
  {
    throw InputError("CT", "needs one scalar component in HU");
  }
  auto body = vtkSmartPointer<vtkImageData>::New();
  body->CopyStructure(ct);
  body->SetDirectionMatrix(ct->GetDirectionMatrix());
  auto values = vtkSmartPointer<vtkFloatArray>::New();
  values->SetNumberOfTuples(scalars->GetNumberOfTuples());
  float* to = values->GetPointer(0);
  const vtkIdType count = scalars->GetNumberOfTuples();
  switch (scalars->GetDataType())
  {
    // The stored type's values as floats, without a virtual call per voxel.
    vtkTemplateMacro(std::transform(static_cast<const VTK_TT*>(scalars->GetVoidPointer(0)),
      static_cast<const VTK_TT*>(scalars->GetVoidPointer(0)) + count, to,
      [](VTK_TT value) { return static_cast<float>(static_cast<double>(value)); }));
    default:
      for (vtkIdType i = 0; i < count; ++i)
        to[i] = static_cast<float>(scalars->GetTuple1(i));
  }
  body->GetPointData()->SetScalars(values);
  int dims[3];
  ct->GetDimensions(dims);
  const std::vector<uint8_t> inBody = SegmentBody(values->GetPointer(0), Eigen::Vector3i(dims[0], dims[1], dims[2]), settings);
  if (table)
  {
    const float dense = static_cast<float>(settings.tableHU);
    *table = 0;
    for (size_t i = 0; i < inBody.size(); ++i)
      *table += !inBody[i] && to[i] > dense;
  }
  const long long cleared = ClearOutsideBody(values->GetPointer(0), inBody);
  if (removed)
    *removed = cleared;
  return body;
}

} // namespace xp
