/**
 * @file xpRayCaster.h
 * @brief Line integrals of attenuation from an X-ray source to detector pixels (the DRR kernel).
 *
 * Works on raw buffers so that a registration can call it once per pose with reused memory.
 * Rays are clipped to the volume and to the source-detector segment, empty 32^3 blocks are skipped,
 * and only pixels that the mask marks valid are traced: the cost scales with the valid count.
 * Every loop is bounded by the number of cells a ray can cross, so grazing rays, rays parallel to
 * the slices and rays that miss the volume end in bounded time with a defined result (0).
 */
#ifndef xpRayCaster_h
#define xpRayCaster_h

#include "vtkXPDRRModule.h"

#include "xpJosephRay.h"

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace xp
{
class AttenuationVolume;
struct XRayView;

/** How a buffer's pixels sit on the panel, in Room mm: pixel (c, r) = origin + c*columnStep + r*rowStep. */
struct VTKXPDRR_EXPORT DetectorGrid
{
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d columnStep = Eigen::Vector3d::UnitX();
  Eigen::Vector3d rowStep = Eigen::Vector3d::UnitY();
  int columns = 0;
  int rows = 0;

  /** Buffer row r = detector row r (top row first, as in PNG and DICOM). */
  static DetectorGrid TopRowFirst(const XRayView& view);
  /** Buffer row r = detector row rows-1-r (VTK image data, whose j runs up). */
  static DetectorGrid BottomRowFirst(const XRayView& view);
};

enum class RayCastMethod
{
  Trilinear, ///< trilinear interpolation at a fixed step along the ray (default)
  Siddon     ///< exact integral through piecewise-constant voxels (reference, slower)
};

/** Where the rays are cast. */
enum class ComputeDevice
{
  CPU, ///< all cores of this machine (vtkSMPTools)
  CUDA ///< the first NVIDIA GPU (xpCudaRayCaster.h): Joseph's scheme, the same samples in float
};

/** The device that `--device auto|cpu|cuda` names, and what to tell the user. */
struct ComputeDeviceChoice
{
  ComputeDevice device = ComputeDevice::CPU;
  /** "cpu", or "cuda (" the GPU's name ")": result.json's `device`. */
  std::string description = "cpu";
  /** With auto on a machine without a usable GPU: why it runs on the CPU; else empty. */
  std::string note;
};

/**
 * Resolves `--device`: "cpu"; "cuda", refused (InputError naming --device, with the reason) where
 * this build has no CUDA or no GPU can run it; "auto", the GPU where one is usable, else the CPU
 * with a note saying why. Any other word is refused.
 */
VTKXPDRR_EXPORT ComputeDeviceChoice ChooseComputeDevice(const std::string& option);

/** "cpu", or "cuda (" the GPU's name ")" (starts the GPU's context when first asked). */
VTKXPDRR_EXPORT std::string ComputeDeviceDescription(ComputeDevice device);

/**
 * How the sixteen-lane (AVX-512) packets read the four voxels of each sample. Every choice reads
 * the same voxels, so the integrals are the same to the bit, in times that depend on the CPU
 * (`xpose bench drr` compares them; Performance.md, "Loads or gathers, per CPU").
 */
enum class VoxelReads
{
  /** Loads on AMD's CPUs, gathers on the others (Performance.md, "Loads or gathers, per CPU"). */
  Auto,
  /** Where the lanes' voxels on a plane lie in one or two neighbouring rows within 31 voxels of
   *  each other: two 64-byte loads and a word permutation per row; sixteen-element gathers
   *  elsewhere. */
  Loads,
  /** Sixteen-element gathers always. */
  Gathers,
};

struct VTKXPDRR_EXPORT RayCastSettings
{
  RayCastMethod method = RayCastMethod::Trilinear;
  /**
   * Sampling step along the ray in mm for Trilinear. 0 (default): one sample on every voxel plane
   * of the ray's dominant axis (Joseph's scheme; the step is that axis' spacing / |cos|, and
   * trilinear interpolation on a plane is bilinear), the fastest and the reference for accuracy.
   */
  double stepSize = 0.0;
  /**
   * Joseph's scheme (stepSize 0) on every planeSteps[a]-th voxel plane along the ray's dominant
   * index axis a of the CT, each sample weighing that many planes' length: the planes whose index
   * (in the stored volume, padding included) is a multiple of the step, whatever the pose, so the
   * DRR is that of the volume's kept planes, at full resolution across the ray. 1 (the default):
   * every plane. A step of 2 where the CT's voxels are 1 mm halves the samples of a ray at the cost
   * of its integral's finest detail along the ray (Algorithms.md, "Every second voxel plane in the
   * refinement"). CPU only: the GPU samples every plane.
   */
  std::array<int, 3> planeSteps{ { 1, 1, 1 } };
  /**
   * Joseph's scheme on neighbouring rays together with AVX2, where the CPU has it (see
   * HasVectorRayCaster). false: one ray at a time in portable code, the reference that the vector
   * path is tested against. Both give the same samples; sums differ by float rounding only.
   */
  bool vectorized = true;
  /**
   * With `vectorized`: sixteen rays at a time with AVX-512 where the CPU has it (see
   * HasWideVectorRayCaster), else eight with AVX2. false: eight with AVX2 always. Both give the
   * same integrals to the bit; the setting is there to compare them.
   */
  bool wideVectors = true;
  /** With sixteen lanes: how a packet reads its voxels (VoxelReads; the same integrals to the bit). */
  VoxelReads voxelReads = VoxelReads::Auto;
  /**
   * A packet's rays clipped to the volume and their occupied blocks found several at a time, the
   * same operations per ray as one at a time: with sixteen lanes eight at a time with AVX-512
   * (where the CPU has its F, VL and BW parts), with eight lanes four at a time with AVX2; false:
   * one at a time. The same integrals to the bit.
   */
  bool wideSetUp = true;
  /** CUDA: Joseph's scheme only (method Trilinear, stepSize 0); volumes and pixel lists stay on
   *  the GPU between calls while the caller keeps them. */
  ComputeDevice device = ComputeDevice::CPU;
  /** CUDA: sample through the texture unit's trilinear filter (8-bit weights) instead of reading
   *  four voxels and weighting them in float. */
  bool textureFilter = false;
};

/** Whether this CPU runs the vectorised ray caster (AVX2 and FMA). */
VTKXPDRR_EXPORT bool HasVectorRayCaster();

/** Whether this CPU runs the vectorised ray caster on sixteen rays at a time (AVX-512 F and BW). */
VTKXPDRR_EXPORT bool HasWideVectorRayCaster();

/** What `requested` reads with on this CPU: Loads or Gathers (Auto resolved). */
VTKXPDRR_EXPORT VoxelReads WideVoxelReadsOf(VoxelReads requested);

/** "loads" or "gathers"; Auto: "auto". */
VTKXPDRR_EXPORT const char* ToString(VoxelReads reads);

/** The CPU's vectorised ray caster as it runs by default: "AVX-512, 16 lanes, voxels read by
 *  gathers" (or "by loads"), "AVX2, 8 lanes", or "scalar, one ray at a time". */
VTKXPDRR_EXPORT std::string RayCasterPathDescription();

/**
 * The pixels a DRR traces, in the order the ray caster visits them: tiles of 16 x 8, so that
 * neighbouring rays, which read the same voxels, run together; the list also spreads masked work
 * evenly over threads. The vectorised caster takes them in packets of up to sixteen consecutive
 * entries, each within one tile and at most two of its rows (a tile's row where none is masked):
 * a packet's rays then read one or two neighbouring voxel rows of each plane, which loads serve,
 * where a packet spanning a tile's last row and the next tile's first needs gathers
 * (Performance.md, "Packets within a tile"). It depends only on the panel size and the mask: a
 * registration builds it once per mask and renders every pose with it.
 */
class VTKXPDRR_EXPORT TracedPixels
{
public:
  static constexpr int TileColumns = 16, TileRows = 8;

  /** All pixels of a columns x rows panel, or those whose `mask` value is non-zero. */
  TracedPixels(int columns, int rows, const uint8_t* mask);

  int Columns() const { return this->PanelColumns; }
  int Rows() const { return this->PanelRows; }
  /** Pixel indices (row * Columns() + column), each below Columns() * Rows(). */
  const std::vector<int>& Order() const { return *this->Pixels; }
  /** Where each packet begins in Order(), and a last entry Order().size(): packet p holds the
   *  entries PacketStarts()[p] to PacketStarts()[p + 1] - 1, at most PacketSize of them. */
  const std::vector<int>& PacketStarts() const { return this->Packets; }
  static constexpr int PacketSize = 16;
  /** The list's owner, shared by copies: a GPU keeps its copy of the list while this lives. */
  std::shared_ptr<const void> Storage() const { return this->Pixels; }

private:
  int PanelColumns = 0;
  int PanelRows = 0;
  std::shared_ptr<const std::vector<int>> Pixels;
  std::vector<int> Packets;
};

/**
 * Line integral of mu (dimensionless) for every pixel of `grid` whose `mask` value is non-zero
 * (all pixels when mask is null); other pixels get 0. `ctToRoom` places the CT in the room
 * (planned set-up composed with the patient's misalignment). Uses all vtkSMPTools threads.
 * @return the number of rays traced.
 */
VTKXPDRR_EXPORT long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const uint8_t* mask, float* lineIntegrals,
  const RayCastSettings& settings = {});

/** The same for the pixels of `pixels` (built for this grid's size); other pixels are left as they are. */
VTKXPDRR_EXPORT long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid, const TracedPixels& pixels, float* lineIntegrals,
  const RayCastSettings& settings = {});

/** A DRR's rays as the GPU casts them (xpJosephRay.h): the grid and the source in the padded
 *  voxel-index space of `volume` placed at `ctToRoom`, and the rays' lengths in Room mm. */
VTKXPDRR_EXPORT joseph::Job JosephJob(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const Eigen::Vector3d& sourceInRoom, const DetectorGrid& grid);

/** One DRR of several rendered at one placement of the volume (RenderLineIntegrals below). */
struct RenderTarget
{
  Eigen::Vector3d source;                ///< Room mm
  DetectorGrid grid;
  const TracedPixels* pixels = nullptr;  ///< built for the grid's size
  float* lineIntegrals = nullptr;        ///< the traced pixels' integrals; others left as they are
};

/** The DRRs of several views at one placement: on the GPU in one launch, on the CPU one after
 *  the other on all threads. Returns the rays cast. */
VTKXPDRR_EXPORT long long RenderLineIntegrals(const AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom,
  const std::vector<RenderTarget>& targets, const RayCastSettings& settings = {});

/**
 * Mutual information of DRRs against X-rays, computed on the GPU where the rays are cast, so that
 * an evaluation sends a pose and gets one number per view back. Each view's DRR is binned by a
 * fixed map of line integral to bin (a LevelTable's ranks as bins: cell = (integral - low) *
 * toCell, truncated and clamped to cellBins, bin = cellBins[cell]) and counted against its
 * X-ray's bin (xrayBins, one per traced pixel in the list's order) over the traced pixels; MI is
 * JointHistogram's (xpMutualInformation.h). The volume and the pixel lists must outlive this.
 */
class VTKXPDRR_EXPORT GPUMutualInformation
{
public:
  struct View
  {
    Eigen::Vector3d source;            ///< Room mm
    DetectorGrid grid;                 ///< the rays' grid (the panel)
    const TracedPixels* pixels = nullptr; ///< the pixels that count, each cast
    std::vector<uint8_t> xrayBins;
    double low = 0.0, toCell = 1.0;
    std::vector<uint8_t> cellBins;
  };

  /** Uploads the views' bins (the volume and pixels, where not yet there); throws xp::Error
   *  where no GPU is usable. */
  GPUMutualInformation(const AttenuationVolume& volume, const std::vector<View>& views, int bins);
  ~GPUMutualInformation();
  GPUMutualInformation(const GPUMutualInformation&) = delete;
  GPUMutualInformation& operator=(const GPUMutualInformation&) = delete;

  /** MI (nats) of every view at every placement (CT -> Room), in one launch: mi[p * views + v].
   *  Returns the rays cast. */
  long long Evaluate(const std::vector<Eigen::Isometry3d>& ctToRoom, std::vector<double>& mi);

private:
  const AttenuationVolume& Volume;
  std::shared_ptr<const void> VolumeOwner;
  std::vector<std::shared_ptr<const void>> PixelOwners;
  std::vector<int> Handles;              ///< per view, its bins on the GPU
  std::vector<Eigen::Vector3d> Sources;  ///< per view
  std::vector<DetectorGrid> Grids;       ///< per view
};

/** 12-bit transmission round(4095 * exp(-integral)); 0 where the mask is zero. */
VTKXPDRR_EXPORT void LineIntegralsTo12Bit(
  const float* lineIntegrals, const uint8_t* mask, long long count, uint16_t* transmission);

} // namespace xp

#endif
