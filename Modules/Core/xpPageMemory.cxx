#include "xpPageMemory.h"

#include "xpError.h"

#ifndef XP_WITHOUT_VTK
#include <vtkFloatArray.h>
#include <vtkShortArray.h>
#endif

#include <cstdint>
#include <cstdlib>
#include <string>
#include <sys/mman.h>

namespace xp
{

namespace
{

constexpr size_t HugePage = size_t(2) << 20;

/** XPOSE_HUGE_PAGES=1: buffers marked for transparent huge pages (xpPageMemory.h). */
bool HugePagesAsked()
{
  static const bool asked = []
  {
    const char* value = std::getenv("XPOSE_HUGE_PAGES");
    return value && std::string(value) == "1";
  }();
  return asked;
}

/** Kept just below the aligned start, so that FreePages needs nothing but the pointer. */
struct Mapping
{
  void* start;
  size_t length;
};

Mapping* MappingOf(void* aligned)
{
  return reinterpret_cast<Mapping*>(static_cast<char*>(aligned) - sizeof(Mapping));
}

} // namespace

void* AllocatePages(size_t bytes)
{
  const size_t rounded = (bytes + HugePage - 1) / HugePage * HugePage;
  if (rounded < bytes || rounded > SIZE_MAX - 2 * HugePage)
  {
    throw Error("memory: " + std::to_string(bytes) + " bytes cannot be allocated");
  }
  // One huge page of slack: room to align the start and to keep the Mapping record before it.
  const size_t length = rounded + HugePage;
  void* start = mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (start == MAP_FAILED)
  {
    throw Error("memory: out of memory (" + std::to_string(bytes >> 20) + " MiB)");
  }
  const uintptr_t address = reinterpret_cast<uintptr_t>(start) + sizeof(Mapping);
  void* aligned = reinterpret_cast<void*>((address + HugePage - 1) / HugePage * HugePage);
  *MappingOf(aligned) = Mapping{ start, length };
  if (HugePagesAsked())
    madvise(aligned, rounded, MADV_HUGEPAGE);
  return aligned;
}

void FreePages(void* memory)
{
  if (memory)
  {
    const Mapping mapping = *MappingOf(memory);
    munmap(mapping.start, mapping.length);
  }
}

#ifndef XP_WITHOUT_VTK
namespace
{

template <class ArrayT>
vtkSmartPointer<ArrayT> NewPageArray(vtkIdType count)
{
  using Value = typename ArrayT::ValueType;
  auto array = vtkSmartPointer<ArrayT>::New();
  auto* values = static_cast<Value*>(AllocatePages(static_cast<size_t>(count) * sizeof(Value)));
  array->SetArray(values, count, 0, ArrayT::VTK_DATA_ARRAY_USER_DEFINED);
  array->SetArrayFreeFunction(&FreePages);
  return array;
}

} // namespace

vtkSmartPointer<vtkFloatArray> NewPageFloatArray(vtkIdType count)
{
  return NewPageArray<vtkFloatArray>(count);
}

vtkSmartPointer<vtkShortArray> NewPageShortArray(vtkIdType count)
{
  return NewPageArray<vtkShortArray>(count);
}

#endif

} // namespace xp
