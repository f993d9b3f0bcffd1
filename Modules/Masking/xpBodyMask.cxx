#include "xpBodyMask.h"

#include "xpError.h"

#include <vtkDataArray.h>
#include <vtkFloatArray.h>
#include <vtkPointData.h>

#include <algorithm>

namespace xp
{

namespace
{

using Index = long long;

/** Labels the 6-connected components of `inside`; returns each component's size (label - 1). */
std::vector<Index> LabelComponents(const std::vector<uint8_t>& inside, const Eigen::Vector3i& d, std::vector<int>& label)
{
  const Index nx = d[0], ny = d[1], nz = d[2], slice = nx * ny;
  label.assign(inside.size(), 0);
  std::vector<Index> sizes, stack;
  for (Index start = 0; start < static_cast<Index>(inside.size()); ++start)
  {
    if (!inside[start] || label[start])
      continue;
    const int id = static_cast<int>(sizes.size()) + 1;
    Index size = 0;
    stack.assign(1, start);
    label[start] = id;
    while (!stack.empty())
    {
      const Index v = stack.back();
      stack.pop_back();
      ++size;
      const Index x = v % nx, y = (v / nx) % ny, z = v / slice;
      const Index neighbours[6] = { x > 0 ? v - 1 : -1, x + 1 < nx ? v + 1 : -1, y > 0 ? v - nx : -1,
        y + 1 < ny ? v + nx : -1, z > 0 ? v - slice : -1, z + 1 < nz ? v + slice : -1 };
      for (Index n : neighbours)
        if (n >= 0 && inside[n] && !label[n])
        {
          label[n] = id;
          stack.push_back(n);
        }
    }
    sizes.push_back(size);
  }
  return sizes;
}

/** Fills each slice's cavities: what the outside cannot reach from the slice border is body. */
void FillSliceCavities(std::vector<uint8_t>& body, const Eigen::Vector3i& d)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny;
  std::vector<uint8_t> outside(static_cast<size_t>(slice));
  std::vector<Index> stack;
  for (Index z = 0; z < d[2]; ++z)
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
      const Index x = p % nx, y = p / nx;
      if (x > 0) stack.push_back(p - 1);
      if (x + 1 < nx) stack.push_back(p + 1);
      if (y > 0) stack.push_back(p - nx);
      if (y + 1 < ny) stack.push_back(p + nx);
    }
    for (Index p = 0; p < slice; ++p)
      b[p] = !outside[p];
  }
}

/** Square in-slice dilation by `radius` voxels, separable (rows, then columns). */
void DilateSlices(std::vector<uint8_t>& body, const Eigen::Vector3i& d, int radius)
{
  const Index nx = d[0], ny = d[1], slice = nx * ny;
  std::vector<uint8_t> line;
  for (Index z = 0; z < d[2]; ++z)
  {
    uint8_t* b = body.data() + z * slice;
    for (int pass = 0; pass < 2; ++pass)
    {
      const Index length = pass == 0 ? nx : ny, lines = pass == 0 ? ny : nx;
      const Index stride = pass == 0 ? 1 : nx, lineStride = pass == 0 ? nx : 1;
      line.resize(static_cast<size_t>(length));
      for (Index l = 0; l < lines; ++l)
      {
        uint8_t* p = b + l * lineStride;
        for (Index i = 0; i < length; ++i)
          line[i] = p[i * stride];
        for (Index i = 0; i < length; ++i)
        {
          uint8_t any = 0;
          for (Index j = std::max<Index>(0, i - radius); j <= std::min(length - 1, i + radius) && !any; ++j)
            any = line[j];
          p[i * stride] = any;
        }
      }
    }
  }
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
  std::vector<int> label;
  const std::vector<Index> sizes = LabelComponents(core, dims, label);
  if (sizes.empty())
  {
    throw InputError("body mask", "no part of the CT above " + std::to_string(settings.thresholdHU) +
        " HU is thicker than " + std::to_string(2 * settings.openingRadius + 1) + " voxels");
  }
  const Index largest = *std::max_element(sizes.begin(), sizes.end());
  std::vector<uint8_t> body(count);
  for (size_t i = 0; i < count; ++i)
    body[i] = label[i] > 0 && sizes[label[i] - 1] >= settings.minComponentFraction * largest;
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

vtkSmartPointer<vtkImageData> BodyOnly(vtkImageData* ct, const BodyMaskSettings& settings, long long* removed)
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
  for (vtkIdType i = 0; i < scalars->GetNumberOfTuples(); ++i)
    values->SetValue(i, static_cast<float>(scalars->GetTuple1(i)));
  body->GetPointData()->SetScalars(values);
  int dims[3];
  ct->GetDimensions(dims);
  const long long cleared =
    ClearOutsideBody(values->GetPointer(0), SegmentBody(values->GetPointer(0), Eigen::Vector3i(dims[0], dims[1], dims[2]), settings));
  if (removed)
    *removed = cleared;
  return body;
}

} // namespace xp
