/**
 * @file xpHugePages.h
 * @brief Large buffers on 2 MiB transparent huge pages.
 *
 * A CT and the volumes made from it are hundreds of MiB that are filled once and then read out
 * of order. On 4 KiB pages, filling them costs a page fault per 4 KiB (a third of the time of
 * reading a CT file on a virtual machine) and ray casting a TLB miss on most samples.
 */
#ifndef xpHugePages_h
#define xpHugePages_h

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
 * Zero-filled memory of at least `bytes`, aligned to 2 MiB and marked for transparent huge
 * pages where the kernel allows them. Pages are mapped when first touched, so threads that fill
 * their own part place it themselves. Release with FreeHugePages. Throws xp::Error when the
 * memory cannot be had.
 */
VTKXPCORE_EXPORT void* AllocateHugePages(size_t bytes);

/** Releases memory from AllocateHugePages; null is ignored. A plain function, so that a VTK
 *  array can own such memory (vtkAbstractArray::SetArrayFreeFunction). */
VTKXPCORE_EXPORT void FreeHugePages(void* memory);

/** Owner of an array of T from AllocateHugePages. */
template <typename T>
using HugePageArray = std::unique_ptr<T[], void (*)(void*)>;

template <typename T>
HugePageArray<T> MakeHugePageArray(size_t count)
{
  return HugePageArray<T>(static_cast<T*>(AllocateHugePages(count * sizeof(T))), &FreeHugePages);
}

#ifndef XP_WITHOUT_VTK // (the VTK-free build of Utilities/GPU needs the memory only)
/** A one-component array of `count` zeros that owns huge-page memory. */
VTKXPCORE_EXPORT vtkSmartPointer<vtkFloatArray> NewHugePageFloatArray(vtkIdType count);
VTKXPCORE_EXPORT vtkSmartPointer<vtkShortArray> NewHugePageShortArray(vtkIdType count);
#endif

} // namespace xp

#endif
