#include "xpPageMemory.h"

#include <vtkFloatArray.h>

#include <cstdint>
#include <gtest/gtest.h>

TEST(PageMemory, MemoryIsAlignedZeroedAndWritable)
{
  for (const size_t bytes : { size_t(1), size_t(3) << 20, (size_t(2) << 20) + 1 })
  {
    auto* memory = static_cast<unsigned char*>(xp::AllocatePages(bytes));
    ASSERT_NE(memory, nullptr);
    EXPECT_EQ(reinterpret_cast<uintptr_t>(memory) % (size_t(2) << 20), 0u);
    EXPECT_EQ(memory[0], 0);
    EXPECT_EQ(memory[bytes - 1], 0);
    memory[0] = memory[bytes - 1] = 255;
    xp::FreePages(memory);
  }
  xp::FreePages(nullptr);
}

TEST(PageMemory, AFloatArrayOwnsItsMemory)
{
  vtkSmartPointer<vtkFloatArray> array = xp::NewPageFloatArray(1000);
  ASSERT_EQ(array->GetNumberOfValues(), 1000);
  EXPECT_EQ(array->GetValue(999), 0.0f);
  array->SetValue(999, 2.5f);
  EXPECT_EQ(array->GetValue(999), 2.5f);
  vtkSmartPointer<vtkFloatArray> copy = vtkSmartPointer<vtkFloatArray>::New();
  copy->DeepCopy(array);
  array = nullptr; // freed through FreePages; the copy is independent
  EXPECT_EQ(copy->GetValue(999), 2.5f);
}
