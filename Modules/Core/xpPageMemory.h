/**
 * @file xpPageMemory.h
 * @brief Large buffers mapped straight from the kernel, 2 MiB-aligned.
 *
 * A CT and the volumes made from it are hundreds of MiB that are filled once and then read out
 * of order. They are mapped from the kernel rather than taken from the heap, so that threads that
 * fill their own part place it themselves and a freed volume goes straight back.
 *
 * Transparent huge pages are asked for only with XPOSE_HUGE_PAGES=1 in the environment. On the
 * 2-core virtual machines xpose is measured on (CI's kind), a huge page's first touch costs
 * several times a small page's (the host backs it afresh), and a pelvis registration took more
 * time with them and no less CPU in its ray casting (Performance.md, "Memory pages and the
 * body's volume").
 */
#ifndef xpPageMemory_h
#define xpPageMemory_h

#include "vtkXPCoreModule.h"

#ifndef XP_WITHOUT_VTK
#include <vtkSmartPointer.h>
#include <vtkType.h>
#endif

#include <cstddef>
#include <memory>

#ifndef XP_WITHOUT_VTK
class vtkFloatArray;
class vtkShortArray;
#endif

namespace xp
{

/**
 * Zero-filled memory of at least `bytes`, aligned to 2 MiB (marked for transparent huge pages
 * with XPOSE_HUGE_PAGES=1). Pages are mapped when first touched, so threads that fill
 * their own part place it themselves. Release with FreePages. Throws xp::Error when the
 * memory cannot be had.
 */
VTKXPCORE_EXPORT void* AllocatePages(size_t bytes);

/** Releases memory from AllocatePages; null is ignored. A plain function, so that a VTK
 *  array can own such memory (vtkAbstractArray::SetArrayFreeFunction). */
VTKXPCORE_EXPORT void FreePages(void* memory);

/** Owner of an array of T from AllocatePages. */
template <typename T>
using PageArray = std::unique_ptr<T[], void (*)(void*)>;

template <typename T>
PageArray<T> MakePageArray(size_t count)
{
  return PageArray<T>(static_cast<T*>(AllocatePages(count * sizeof(T))), &FreePages);
}

#ifndef XP_WITHOUT_VTK // (the VTK-free build of Utilities/GPU needs the memory only)
/** A one-component array of `count` zeros that owns memory from AllocatePages. */
VTKXPCORE_EXPORT vtkSmartPointer<vtkFloatArray> NewPageFloatArray(vtkIdType count);
VTKXPCORE_EXPORT vtkSmartPointer<vtkShortArray> NewPageShortArray(vtkIdType count);
#endif

} // namespace xp

#endif
