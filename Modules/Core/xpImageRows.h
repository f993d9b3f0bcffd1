/**
 * @file xpImageRows.h
 * @brief The one place where VTK's row order (j runs up) meets xpose's kernels (row 0 first,
 *        as in DICOM and PNG), and the whole-extent request shared by xpose's filters.
 */
#ifndef xpImageRows_h
#define xpImageRows_h

#include "vtkXPCoreModule.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>
#include <vtkTypeTraits.h>

#include <algorithm>
#include <vector>

class vtkInformationVector;

namespace xp
{

/** The pixels of a 2D vtkImageData of scalar type T, detector row 0 first. */
template <typename T>
std::vector<T> RowsTopFirst(vtkImageData* image)
{
  int dims[3];
  image->GetDimensions(dims);
  const T* in = static_cast<const T*>(image->GetScalarPointer());
  std::vector<T> out(static_cast<size_t>(dims[0]) * dims[1]);
  for (int row = 0; row < dims[1]; ++row)
  {
    std::copy(in + static_cast<size_t>(dims[1] - 1 - row) * dims[0], in + static_cast<size_t>(dims[1] - row) * dims[0],
      out.begin() + static_cast<size_t>(row) * dims[0]);
  }
  return out;
}

/** Writes row-0-first pixels into an allocated 2D vtkImageData of the same size, times `scale`. */
template <typename T>
void CopyRowsTopFirst(const std::vector<T>& pixels, vtkImageData* image, T scale = 1)
{
  int dims[3];
  image->GetDimensions(dims);
  T* out = static_cast<T*>(image->GetScalarPointer());
  for (int row = 0; row < dims[1]; ++row)
  {
    for (int column = 0; column < dims[0]; ++column)
    {
      out[static_cast<size_t>(dims[1] - 1 - row) * dims[0] + column] =
        static_cast<T>(pixels[static_cast<size_t>(row) * dims[0] + column] * scale);
    }
  }
}

/** A new 2D vtkImageData (scalar type of T) holding row-0-first pixels of the given size. */
template <typename T>
vtkSmartPointer<vtkImageData> ImageFromRowsTopFirst(const std::vector<T>& pixels, int columns, int rows)
{
  auto image = vtkSmartPointer<vtkImageData>::New();
  image->SetDimensions(columns, rows, 1);
  image->AllocateScalars(vtkTypeTraits<T>::VTKTypeID(), 1);
  CopyRowsTopFirst(pixels, image.GetPointer());
  return image;
}

/** Asks every connected input of ports [0, ports) for its whole extent (kernels need all of it). */
VTKXPCORE_EXPORT void RequestWholeExtents(vtkInformationVector** inputVector, int ports);

} // namespace xp

#endif
