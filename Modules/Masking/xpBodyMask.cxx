#include "xpBodyMask.h"

#include "xpError.h"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkPointData.h>
#include <vtkSMPTools.h>
#include <vtkType.h>

#include <algorithm>
#include <atomic>

namespace xp
{

namespace
{

using Index = long long;

/** f(i) for every voxel index below `count`, on all threads. */
template <typename Function>
void ForVoxels(size_t count, Function&& f)
{
  vtkSMPTools::For(size_t{ 0 }, count,
    [&](size_t i0, size_t i1)
    {
      for (size_t i = i0; i < i1; ++i)
        f(i);
    });
}

/** How many voxel indices below `count` f(i) is true for, on all threads (f may also write
 *  voxel i). */
template <typename Function>
long long CountVoxels(size_t count, Function&& f)
{
  std::atomic<long long> total{ 0 };
  vtkSMPTools::For(size_t{ 0 }, count,
    [&](size_t i0, size_t i1)
    {
      long long here = 0;
      for (size_t i = i0; i < i1; ++i)
        here += f(i) ? 1 : 0;
      total += here;
    });
  return total;
}

/** emit(begin, end) for each run of pixels equal to `value` (as a truth value) along a row of
 *  `columns` pixels, in column order. */
template <typename Emit>
void ForRunsOf(const uint8_t* row, int columns, bool value, Emit&& emit)
{
  for (int x = 0; x < columns;)
  {
    if ((row[x] != 0) != value)
    {
      ++x;
      continue;
    }
    const int begin = x;
    while (x < columns && (row[x] != 0) == value)
      ++x;
    emit(begin, x);
  }
}

/** A run of voxels along a row, columns [begin, end): set ones (the components) or clear ones (the cavities). */
struct Run
{
  int begin, end;
};

/** Disjoint sets of runs (union-find, path halving; a set's root is its lowest run). */
class RunSets
{
public:
  explicit RunSets(size_t count = 0) { this->Reset(count); }
  void Reset(size_t count)
  {
    this->Parent.resize(count);
    for (size_t i = 0; i < count; ++i)
      this->Parent[i] = i;
  }
  size_t Root(size_t i)
  {
    while (this->Parent[i] != i)
      i = this->Parent[i] = this->Parent[this->Parent[i]];
    return i;
  }
  /** Joins the runs [a0, a1) of one row with the runs [b0, b1) of another wherever they share a
   *  column (each row's runs in column order). */
  template <typename RowRun>
  void JoinOverlapping(const std::vector<RowRun>& runs, size_t a0, size_t a1, size_t b0, size_t b1)
  {
    size_t i = a0, j = b0;
    while (i < a1 && j < b1)
    {
      if (runs[i].begin < runs[j].end && runs[j].begin < runs[i].end)
      {
        const size_t a = this->Root(i), b = this->Root(j);
        if (a != b)
          this->Parent[std::max(a, b)] = std::min(a, b);
      }
      if (runs[i].end < runs[j].end)
        ++i;
      else
        ++j;
    }
  }

private:
  std::vector<size_t> Parent;
};

/**
 * Keeps, in `inside`, the voxels whose 6-connected component holds at least `fraction` of the
 * largest one's voxels; clears the rest (all of it when nothing is inside). Components are
 * joined from runs along x (a run meets the runs of the row before it in its slice and of its
 * row in the slice before wherever they share a column), by union-find over the runs: a few
 * hundred thousand runs where a voxel walk visits tens of millions of voxels. The runs are found
 * slice by slice on all threads.
 */
void KeepLargeComponents(std::vector<uint8_t>& inside, const Eigen::Vector3i& d, double fraction)
{
  const Index nx = d[0], ny = d[1], nz = d[2], rows = ny * nz;
  // Each slice's runs found on its own thread, then laid end to end in slice order.
  std::vector<std::vector<Run>> sliceRuns(static_cast<size_t>(nz));
  std::vector<size_t> rowStart(static_cast<size_t>(rows) + 1, 0);
  vtkSMPTools::For(Index{ 0 }, nz, Index{ 1 },
    [&](Index z0, Index z1)
    {
      for (Index z = z0; z < z1; ++z)
      {
        std::vector<Run>& found = sliceRuns[z];
        for (Index y = 0; y < ny; ++y)
        {
          rowStart[z * ny + y] = found.size(); // within the slice, until the slices are joined
          ForRunsOf(inside.data() + (z * ny + y) * nx, static_cast<int>(nx), true,
            [&](int begin, int end) { found.push_back({ begin, end }); });
        }
      }
    });
  std::vector<Run> runs;
  for (Index z = 0; z < nz; ++z)
  {
    const size_t offset = runs.size();
    for (Index y = 0; y < ny; ++y)
      rowStart[z * ny + y] += offset;
    runs.insert(runs.end(), sliceRuns[z].begin(), sliceRuns[z].end());
    std::vector<Run>().swap(sliceRuns[z]);
  }
  rowStart[rows] = runs.size();
  // The runs hold the voxels now: `inside` is rewritten with the kept ones (no second copy of
  // the volume's size to allocate).
  std::vector<uint8_t>& kept = inside;
  std::fill(kept.begin(), kept.end(), uint8_t{ 0 });
  if (runs.empty())
    return;

  RunSets sets(runs.size());
  // Each row's runs joined with the row's before it in its slice and the same row's in the
  // slice before.
  const auto joinRows = [&](Index r, Index q)
  { sets.JoinOverlapping(runs, rowStart[r], rowStart[r + 1], rowStart[q], rowStart[q + 1]); };
  for (Index r = 0; r < rows; ++r)
  {
    if (r % ny > 0)
      joinRows(r, r - 1);
    if (r >= ny)
      joinRows(r, r - ny);
  }
  std::vector<Index> size(runs.size(), 0);
  for (size_t i = 0; i < runs.size(); ++i)
    size[sets.Root(i)] += runs[i].end - runs[i].begin;
  const Index largest = *std::max_element(size.begin(), size.end());
  std::vector<uint8_t> keep(runs.size());
  for (size_t i = 0; i < runs.size(); ++i)
    keep[i] = size[sets.Root(i)] >= fraction * largest;
  vtkSMPTools::For(Index{ 0 }, rows,
    [&](Index r0, Index r1)
    {
      for (Index r = r0; r < r1; ++r)
        for (size_t i = rowStart[r]; i < rowStart[r + 1]; ++i)
          if (keep[i])
            std::fill(kept.begin() + r * nx + runs[i].begin, kept.begin() + r * nx + runs[i].end, uint8_t{ 1 });
    });
}

/** Fills each slice's cavities: what the outside cannot reach from the slice border is body.
 *  The outside is found run by run: each row's runs of non-body pixels, joined with the runs of
 *  the row before that share a column (4-connected), by union-find; the runs joined to one on the
 *  border are outside. Slices are independent: they run on all threads. */
void FillSliceCavities(std::vector<uint8_t>& body, const Eigen::Vector3i& d)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny;
  vtkSMPTools::For(Index{ 0 }, Index{ d[2] }, Index{ 1 },
    [&](Index firstSlice, Index endSlice)
    {
      struct RowRun : Run
      {
        Index row;
      };
      std::vector<RowRun> runs;
      std::vector<size_t> rowStart(static_cast<size_t>(ny) + 1);
      std::vector<uint8_t> border;
      RunSets sets;
      for (Index z = firstSlice; z < endSlice; ++z)
      {
        uint8_t* b = body.data() + z * slice;
        runs.clear();
        for (Index y = 0; y < ny; ++y)
        {
          rowStart[y] = runs.size();
          ForRunsOf(b + y * nx, static_cast<int>(nx), false,
            [&](int begin, int end)
            {
              RowRun run;
              run.begin = begin;
              run.end = end;
              run.row = y;
              runs.push_back(run);
            });
        }
        rowStart[ny] = runs.size();
        sets.Reset(runs.size());
        for (Index y = 1; y < ny; ++y)
          sets.JoinOverlapping(runs, rowStart[y], rowStart[y + 1], rowStart[y - 1], rowStart[y]);
        border.assign(runs.size(), 0);
        for (size_t i = 0; i < runs.size(); ++i)
          if (runs[i].row == 0 || runs[i].row == ny - 1 || runs[i].begin == 0 || runs[i].end == nx)
            border[sets.Root(i)] = 1;
        std::fill(b, b + slice, uint8_t{ 1 });
        for (size_t i = 0; i < runs.size(); ++i)
          if (border[sets.Root(i)])
            std::fill(b + runs[i].row * nx + runs[i].begin, b + runs[i].row * nx + runs[i].end, uint8_t{ 0 });
      }
    });
}

/**
 * OR over windows of `width` consecutive elements, each element `stride` bytes of 0/1 (a voxel, or
 * a row of them): out[i] = in[i] | ... | in[i + width - 1] for i < count; `in` holds
 * count + width - 1 elements. By doubling: after each pass an element holds the OR of twice as
 * many as before, so a window of w costs about log2(w) + 1 vectorised passes instead of w - 1.
 * `a` and `b` are scratch buffers the function sizes.
 */
void OrWindows(const uint8_t* in, Index count, Index width, Index stride, uint8_t* out, std::vector<uint8_t>& a,
  std::vector<uint8_t>& b)
{
  Index length = count + width - 1; // elements that hold a valid OR of `covered` inputs
  a.assign(in, in + length * stride);
  Index covered = 1;
  while (2 * covered <= width)
  {
    length -= covered;
    b.resize(static_cast<size_t>(length * stride));
    const uint8_t* __restrict from = a.data();
    uint8_t* __restrict to = b.data();
    const Index shift = covered * stride, bytes = length * stride;
    for (Index i = 0; i < bytes; ++i)
      to[i] = from[i] | from[i + shift];
    std::swap(a, b);
    covered *= 2;
  }
  // The last pass overlaps two windows of `covered` to make one of `width`.
  const uint8_t* __restrict from = a.data();
  uint8_t* __restrict to = out;
  const Index shift = (width - covered) * stride, bytes = count * stride;
  for (Index i = 0; i < bytes; ++i)
    to[i] = from[i] | from[i + shift];
}

/**
 * Square in-slice dilation by `radius` voxels, separable: along each row, then down the columns
 * (whole rows at a time), each an OR over the window (OrWindows), into `out`. Slices run on all
 * threads. Row y of slice z comes as 0/1 from rowIn(z, y, row) (its nx voxels into `row`), and
 * each dilated slice, while it is still in the cache, goes through sliceOut(z, slice), whose counts
 * are summed and returned: a pass over the volume each that the segmentation saves.
 */
template <typename RowIn, typename SliceOut>
long long DilateSlices(std::vector<uint8_t>& out, const Eigen::Vector3i& d, int radius, RowIn rowIn, SliceOut sliceOut)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny, r = radius, width = 2 * r + 1;
  std::atomic<long long> total{ 0 };
  vtkSMPTools::For(Index{ 0 }, Index{ d[2] }, Index{ 1 },
    [&](Index firstSlice, Index endSlice)
    {
      // The slice as 0/1 with r zeros either side of each row, then with r zero rows above and
      // below; scratch for the passes.
      std::vector<uint8_t> row(static_cast<size_t>(nx + 2 * r), 0);
      std::vector<uint8_t> rows(static_cast<size_t>((ny + 2 * r) * nx), 0);
      std::vector<uint8_t> a, b;
      long long here = 0;
      for (Index z = firstSlice; z < endSlice; ++z)
      {
        uint8_t* s = out.data() + z * slice;
        for (Index y = 0; y < ny; ++y)
        {
          rowIn(z, y, row.data() + r);
          OrWindows(row.data(), nx, width, 1, rows.data() + (y + r) * nx, a, b);
        }
        OrWindows(rows.data(), ny, width, nx, s, a, b);
        here += sliceOut(z, s);
      }
      total += here;
    });
  return total;
}

/** DilateSlices' rowIn for a 0/1 volume's own rows (each slice is read before it is written). */
auto RowsOf(const std::vector<uint8_t>& volume, const Eigen::Vector3i& d)
{
  return [&volume, nx = Index{ d[0] }, slice = Index{ d[0] } * d[1]](Index z, Index y, uint8_t* row)
  {
    const uint8_t* in = volume.data() + z * slice + y * nx;
    for (Index x = 0; x < nx; ++x)
      row[x] = in[x] != 0;
  };
}

/** DilateSlices of `body` in place. */
void DilateSlices(std::vector<uint8_t>& body, const Eigen::Vector3i& d, int radius)
{
  DilateSlices(body, d, radius, RowsOf(body, d), [](Index, uint8_t*) { return 0LL; });
}

} // namespace

template <typename HU>
std::vector<uint8_t> SegmentBody(const HU* hu, const Eigen::Vector3i& dims, const BodyMaskSettings& settings)
{
  if ((dims.array() < 1).any() || !hu)
  {
    throw InputError("body mask", "the CT is empty");
  }
  const size_t count = static_cast<size_t>(dims[0]) * dims[1] * dims[2];
  const double threshold = settings.thresholdHU;
  // Opening: an erosion removes thin shells (a table's carbon skin, a mask's mesh) before the
  // components are counted, so that they cannot join the body or count as a limb. The erosion
  // is the dilation of what is not tissue.
  // Each slice's non-tissue read from the HU and dilated, then inverted and counted while it is in
  // the cache.
  const Index nx = dims[0], slice = nx * dims[1];
  std::vector<uint8_t> core(count);
  const long long cores = DilateSlices(core, dims, settings.openingRadius,
    [&](Index z, Index y, uint8_t* row)
    {
      const HU* in = hu + z * slice + y * nx;
      for (Index x = 0; x < nx; ++x)
        row[x] = !(in[x] > threshold);
    },
    [&](Index, uint8_t* s)
    {
      long long kept = 0;
      for (Index i = 0; i < slice; ++i)
      {
        s[i] = !s[i];
        kept += s[i] != 0;
      }
      return kept;
    });
  if (cores == 0)
  {
    throw InputError("body mask", "no part of the CT above " + std::to_string(settings.thresholdHU) +
        " HU is thicker than " + std::to_string(2 * settings.openingRadius + 1) + " voxels");
  }
  KeepLargeComponents(core, dims, settings.minComponentFraction);
  std::vector<uint8_t> body = std::move(core);
  // Back to the tissue's own outline: what the opening took from the kept parts (each slice
  // dilated, then ANDed with the tissue).
  DilateSlices(body, dims, settings.openingRadius + 1, RowsOf(body, dims),
    [&](Index z, uint8_t* s)
    {
      const HU* tissue = hu + z * slice;
      for (Index i = 0; i < slice; ++i)
        s[i] = s[i] && tissue[i] > threshold;
      return 0LL;
    });
  FillSliceCavities(body, dims);
  if (settings.dilation > 0)
    DilateSlices(body, dims, settings.dilation);
  return body;
}

template VTKXPMASKING_EXPORT std::vector<uint8_t> SegmentBody(const float*, const Eigen::Vector3i&, const BodyMaskSettings&);
template VTKXPMASKING_EXPORT std::vector<uint8_t> SegmentBody(const int16_t*, const Eigen::Vector3i&, const BodyMaskSettings&);

long long ClearOutsideBody(float* hu, const std::vector<uint8_t>& body)
{
  return CountVoxels(body.size(),
    [&](size_t i)
    {
      if (body[i] || hu[i] == -1000.0f)
        return false;
      hu[i] = -1000.0f;
      return true;
    });
}

namespace
{
/** SegmentBody of `hu` and the count of voxels outside the body denser than settings.tableHU. */
template <typename HU>
BodyVoxels SegmentedWithTable(const HU* hu, const Eigen::Vector3i& dims, const BodyMaskSettings& settings)
{
  const float denseHU = static_cast<float>(settings.tableHU);
  BodyVoxels body;
  body.inBody = SegmentBody(hu, dims, settings);
  body.tableVoxels = CountVoxels(body.inBody.size(), [&](size_t i) { return !body.inBody[i] && static_cast<float>(hu[i]) > denseHU; });
  return body;
}

vtkDataArray* HounsfieldScalars(vtkImageData* ct)
{
  vtkDataArray* scalars = ct ? ct->GetPointData()->GetScalars() : nullptr;
  if (!scalars || scalars->GetNumberOfComponents() != 1)
  {
    throw InputError("CT", "needs one scalar component in HU");
  }
  return scalars;
}

Eigen::Vector3i DimensionsOf(vtkImageData* ct)
{
  int d[3];
  ct->GetDimensions(d);
  return { d[0], d[1], d[2] };
}

/** The values of `scalars` as floats, without a virtual call per voxel for VTK's own types. */
void CopyAsFloats(vtkDataArray* scalars, float* to)
{
  const vtkIdType count = scalars->GetNumberOfTuples();
  switch (scalars->GetDataType())
  {
    vtkTemplateMacro(const VTK_TT* from = static_cast<const VTK_TT*>(scalars->GetVoidPointer(0));
      ForVoxels(static_cast<size_t>(count), [&](size_t i) { to[i] = static_cast<float>(static_cast<double>(from[i])); }));
    default:
      for (vtkIdType i = 0; i < count; ++i)
        to[i] = static_cast<float>(scalars->GetTuple1(i));
  }
}
} // namespace

BodyVoxels BodyOf(vtkImageData* ct, const BodyMaskSettings& settings)
{
  vtkDataArray* scalars = HounsfieldScalars(ct);
  const Eigen::Vector3i dims = DimensionsOf(ct);
  // The readers keep HU as 16-bit integers or floats: segmented as they are. Any other type is
  // read as floats first.
  if (scalars->GetDataType() == VTK_SHORT)
    return SegmentedWithTable(static_cast<const int16_t*>(scalars->GetVoidPointer(0)), dims, settings);
  if (scalars->GetDataType() == VTK_FLOAT)
    return SegmentedWithTable(static_cast<const float*>(scalars->GetVoidPointer(0)), dims, settings);
  std::vector<float> hu(static_cast<size_t>(scalars->GetNumberOfTuples()));
  CopyAsFloats(scalars, hu.data());
  return SegmentedWithTable(hu.data(), dims, settings);
}

vtkSmartPointer<vtkImageData> BodyOnly(vtkImageData* ct, const BodyMaskSettings& settings, long long* removed, long long* table)
{
  vtkDataArray* scalars = HounsfieldScalars(ct);
  auto body = vtkSmartPointer<vtkImageData>::New();
  body->CopyStructure(ct);
  body->SetDirectionMatrix(ct->GetDirectionMatrix());
  auto values = vtkSmartPointer<vtkFloatArray>::New();
  values->SetNumberOfTuples(scalars->GetNumberOfTuples());
  CopyAsFloats(scalars, values->GetPointer(0));
  body->GetPointData()->SetScalars(values);
  // The float copy segmented: the 16-bit CT's own segmentation, voxel for voxel
  // (BodyMask.A16BitCTIsSegmentedAsItsFloatCopy), with one conversion for any other type.
  const BodyVoxels segmented = SegmentedWithTable(values->GetPointer(0), DimensionsOf(ct), settings);
  if (table)
    *table = segmented.tableVoxels;
  const long long cleared = ClearOutsideBody(values->GetPointer(0), segmented.inBody);
  if (removed)
    *removed = cleared;
  return body;
}

} // namespace xp
