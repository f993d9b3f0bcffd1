# xp_enable_cuda(<result>): enables CUDA where a plain configure finds its compiler (on the PATH,
# in CUDACXX, or at /usr/local/cuda/bin), for sm_90 (H100, H200) with its PTX for later GPUs
# unless CMAKE_CUDA_ARCHITECTURES says otherwise, and sets <result> ON; else OFF. xpose's
# top-level CMakeLists.txt and the GPU harness (Utilities/GPU) share it.
macro(xp_enable_cuda result)
  set(${result} OFF)
  if(NOT DEFINED ENV{CUDACXX} AND NOT CMAKE_CUDA_COMPILER AND EXISTS /usr/local/cuda/bin/nvcc)
    set(ENV{CUDACXX} /usr/local/cuda/bin/nvcc)
  endif()
  include(CheckLanguage)
  check_language(CUDA)
  if(CMAKE_CUDA_COMPILER)
    if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
      set(CMAKE_CUDA_ARCHITECTURES 90)
    endif()
    enable_language(CUDA)
    set(CMAKE_CUDA_STANDARD 17)
    set(CMAKE_CUDA_STANDARD_REQUIRED ON)
    find_package(CUDAToolkit REQUIRED)
    set(${result} ON)
  endif()
endmacro()
