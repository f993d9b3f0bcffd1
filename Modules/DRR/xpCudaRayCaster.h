/**
 * @file xpCudaRayCaster.h
 * @brief The DRR ray caster and the mutual information of its DRRs on an NVIDIA GPU (CUDA).
 *
 * A plain C++ face (no CUDA, VTK or Eigen header) over the kernels of xpCudaRayCaster.cu; where
 * xpose is built without a CUDA compiler, xpCudaRayCasterStub.cxx implements it and every call
 * says so. The registration reaches it through RenderLineIntegrals (xpRayCaster.h) with
 * RayCastSettings::device; the harness of Utilities/GPU drives it directly.
 *
 * A GPUContext keeps volumes and pixel lists on the GPU between calls, as the CPU ray caster keeps
 * its AttenuationVolume and TracedPixels: a registration uploads them once and then sends each
 * evaluation's geometry only (a few hundred bytes a DRR). The rays are those of xpJosephRay.h,
 * one thread a ray; several DRRs (two views, a simplex's poses, a landscape) go in one launch.
 */
#ifndef xpCudaRayCaster_h
#define xpCudaRayCaster_h

#include "vtkXPDRRModule.h"

#include "xpJosephRay.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace xp
{
namespace cuda
{

/** Whether this build has the CUDA ray caster and a GPU can run it; if not, why, in `reason`. */
VTKXPDRR_EXPORT bool Available(std::string* reason = nullptr);

/** How a sample is interpolated on the GPU. */
enum class Interpolation
{
  /** Four voxels read and weighted in float, as the CPU ray caster does (the default). */
  Float,
  /** One fetch through the texture unit's trilinear filter, whose weights are 8-bit fractions. */
  Texture
};

/** A GPU's resident data and its work. Not thread-safe: one caller at a time. */
class VTKXPDRR_EXPORT GPUContext
{
public:
  /** Takes the first CUDA device; throws xp::Error when none is usable. */
  GPUContext();
  ~GPUContext();
  GPUContext(const GPUContext&) = delete;
  GPUContext& operator=(const GPUContext&) = delete;

  /** "NVIDIA H100 80GB HBM3" and the like. */
  std::string DeviceName() const;

  /** Copies a padded volume (AttenuationVolume::Voxels()) to the GPU; returns its handle. */
  int AddVolume(const uint16_t* paddedVoxels, const joseph::Grid& grid);
  /** Copies a list of pixel indices (the rays a DRR casts); returns its handle. */
  int AddPixels(const int* pixels, int count);
  /** Frees a volume, pixel list or metric view. */
  void Remove(int handle);

  /**
   * Line integrals of `count` DRRs of one volume in one launch: DRR d casts the rays of pixel list
   * `pixels[d]` with geometry `jobs[d]` and receives them, in the list's order, in `out[d]`
   * (one float per listed pixel). Returns the rays cast.
   */
  long long Render(int volume, const joseph::Job* jobs, const int* pixels, int count, float* const* out,
    Interpolation interpolation = Interpolation::Float);

  /**
   * A view for MutualInformation: its valid pixels (a pixel list), the X-ray's bin of each of
   * them (in the list's order, each below `bins`), and the map of a DRR's line integral to its
   * bin: cell = clamp(floor((integral - low) * toCell), 0, cellBins.size() - 1), bin = cellBins[cell]
   * (LevelTable's ranks as bins). Returns its handle.
   */
  int AddMetricView(int pixels, const uint8_t* xrayBins, int bins, double low, double toCell,
    const std::vector<uint8_t>& cellBins);

  /**
   * MI (nats) of `count` DRRs of one volume against their views' X-rays, all on the GPU: DRR d
   * renders metric view `views[d]`'s pixels with `jobs[d]`, its joint histogram is counted and
   * its MI computed there, and only the MIs come back, in `mi[d]`. Returns the rays cast.
   */
  long long MutualInformation(int volume, const joseph::Job* jobs, const int* views, int count, double* mi,
    Interpolation interpolation = Interpolation::Float);

private:
  struct Resident;
  std::unique_ptr<Resident> Data;
};

} // namespace cuda
} // namespace xp

#endif
