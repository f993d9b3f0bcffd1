// The GPU ray caster: its per-ray arithmetic (xpJosephRay.h) against the CPU ray caster on any
// machine, its line integrals against the CPU's where a GPU is present (skipped with a message
// where none is, as in CI), and --device's choice and refusals.
#include "xpAttenuationVolume.h"
#include "xpCudaRayCaster.h"
#include "xpError.h"
#include "xpJosephRay.h"
#include "xpRayCaster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace
{

constexpr double Pi = 3.14159265358979323846;

/** A turned, anisotropic CT of a water cylinder holding a bone ring and a dense rod. */
xp::AttenuationVolume Phantom()
{
  const Eigen::Vector3i dims(90, 80, 60);
  const Eigen::Affine3d indexToCT = Eigen::Translation3d(-40.0, -36.0, -45.0) *
    Eigen::AngleAxisd(12.0 * Pi / 180.0, Eigen::Vector3d::UnitZ()) * Eigen::Scaling(Eigen::Vector3d(0.9, 0.9, 1.5));
  std::vector<float> hu(static_cast<size_t>(dims.prod()));
  const Eigen::Vector3d center = indexToCT * (0.5 * (dims.cast<double>() - Eigen::Vector3d::Ones()));
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i)
      {
        const Eigen::Vector3d p = indexToCT * Eigen::Vector3d(i, j, k) - center;
        float value = -1000.0f;
        if (std::hypot(p.x() / 38.0, p.y() / 32.0) < 1.0)
        {
          value = static_cast<float>(30.0 * std::sin(p.x() / 7.0));
          const double ring = std::hypot(p.x() + 12.0, p.y() - 5.0);
          if (ring > 8.0 && ring < 12.0)
            value = 1300.0f;
          if (std::hypot(p.x() - 15.0, p.y() + 10.0) < 5.0)
            value = 700.0f;
        }
        hu[(static_cast<size_t>(k) * dims[1] + j) * dims[0] + i] = value;
      }
  return xp::AttenuationVolume(hu.data(), dims, indexToCT, 0.02);
}

/** A 96 x 72 panel 400 mm beyond the isocentre, the source 800 mm before it, turned `degrees`
 *  about the room's vertical axis. */
xp::DetectorGrid Panel(double degrees, Eigen::Vector3d& source)
{
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(degrees * Pi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  source = turn * Eigen::Vector3d(0.0, -800.0, 0.0);
  xp::DetectorGrid grid;
  grid.columns = 96;
  grid.rows = 72;
  grid.columnStep = turn * Eigen::Vector3d(1.6, 0.0, 0.0);
  grid.rowStep = Eigen::Vector3d(0.0, 0.0, -1.6);
  grid.origin = turn * Eigen::Vector3d(0.0, 400.0, 0.0) - 47.5 * grid.columnStep - 35.5 * grid.rowStep;
  return grid;
}

Eigen::Isometry3d Misaligned(int pose)
{
  const double t = 0.9 * pose;
  return Eigen::Isometry3d(Eigen::Translation3d(1.5 * std::sin(t), -2.0 * std::cos(t), 2.5 * std::sin(2.0 * t)) *
    Eigen::AngleAxisd(0.04 * std::cos(t), Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.03 * std::sin(t), Eigen::Vector3d::UnitY()) *
    Eigen::AngleAxisd(0.06 * std::sin(1.3 * t), Eigen::Vector3d::UnitZ()));
}

std::vector<float> Render(const xp::AttenuationVolume& volume, const Eigen::Isometry3d& ctToRoom, const Eigen::Vector3d& source,
  const xp::DetectorGrid& grid, const xp::RayCastSettings& settings)
{
  std::vector<float> out(static_cast<size_t>(grid.columns) * grid.rows, -1.0f);
  xp::RenderLineIntegrals(volume, ctToRoom, source, grid, nullptr, out.data(), settings);
  return out;
}

TEST(CudaRayCaster, JosephRayIsTheCPURayCastersArithmetic)
{
  // The GPU kernel's per-ray code, run on the CPU, gives the CPU ray caster's integrals: a
  // flipped axis, a swapped plane axis or a wrong scale shows as a difference far above rounding.
  const xp::AttenuationVolume volume = Phantom();
  xp::RayCastSettings scalar;
  scalar.vectorized = false;
  const Eigen::Vector3i dims = volume.PaddedDimensions();
  const xp::joseph::Grid grid{ { dims[0], dims[1], dims[2] }, volume.Quantum() };
  const uint16_t* voxels = volume.Voxels();
  const auto voxel = [&](int x, int y, int z)
  { return static_cast<float>(voxels[x + static_cast<long>(y) * dims[0] + static_cast<long>(z) * dims[0] * dims[1]]); };
  for (double degrees : { -45.0, 0.0, 45.0, 90.0 }) // every dominant axis and both signs
    for (int pose = 0; pose < 3; ++pose)
    {
      Eigen::Vector3d source;
      const xp::DetectorGrid panel = Panel(degrees, source);
      const std::vector<float> cpu = Render(volume, Misaligned(pose), source, panel, scalar);
      const xp::joseph::Job job = xp::JosephJob(volume, Misaligned(pose), source, panel);
      float largest = 0.0f;
      for (int p = 0; p < panel.columns * panel.rows; ++p)
      {
        const float joseph = xp::joseph::LineIntegral(job, grid, p, voxel);
        ASSERT_NEAR(joseph, cpu[p], 1e-5f * std::max(1.0f, cpu[p])) << degrees << " degrees, pose " << pose << ", pixel " << p;
        largest = std::max(largest, joseph);
      }
      EXPECT_GT(largest, 1.0f) << "the rays cross the phantom";
    }
}

TEST(CudaRayCaster, DeviceChoice)
{
  EXPECT_EQ(xp::ChooseComputeDevice("cpu").device, xp::ComputeDevice::CPU);
  EXPECT_EQ(xp::ChooseComputeDevice("cpu").description, "cpu");
  try
  {
    xp::ChooseComputeDevice("gpu");
    FAIL() << "an unknown device is refused";
  }
  catch (const xp::InputError& error)
  {
    EXPECT_NE(std::string(error.what()).find("--device"), std::string::npos) << error.what();
  }
  std::string reason;
  if (xp::cuda::Available(&reason))
  {
    const xp::ComputeDeviceChoice cuda = xp::ChooseComputeDevice("cuda");
    EXPECT_EQ(cuda.device, xp::ComputeDevice::CUDA);
    EXPECT_EQ(cuda.description.rfind("cuda (", 0), 0u) << cuda.description;
    EXPECT_EQ(xp::ChooseComputeDevice("auto").device, xp::ComputeDevice::CUDA);
    return;
  }
  EXPECT_FALSE(reason.empty());
  try
  {
    xp::ChooseComputeDevice("cuda");
    FAIL() << "cuda without a usable GPU is refused";
  }
  catch (const xp::InputError& error)
  {
    const std::string message = error.what();
    EXPECT_NE(message.find("--device"), std::string::npos) << message;
    EXPECT_NE(message.find(reason), std::string::npos) << message;
  }
  const xp::ComputeDeviceChoice fallback = xp::ChooseComputeDevice("auto");
  EXPECT_EQ(fallback.device, xp::ComputeDevice::CPU);
  EXPECT_NE(fallback.note.find("CPU"), std::string::npos) << fallback.note;
}

TEST(CudaRayCaster, LineIntegralsMatchTheCPU)
{
  std::string reason;
  if (!xp::cuda::Available(&reason))
    GTEST_SKIP() << "no GPU here: " << reason;
  const xp::AttenuationVolume volume = Phantom();
  xp::RayCastSettings cpu, gpu;
  gpu.device = xp::ComputeDevice::CUDA;
  std::vector<double> relative;
  for (double degrees : { -45.0, 45.0, 90.0 })
    for (int pose = 0; pose < 3; ++pose)
    {
      Eigen::Vector3d source;
      const xp::DetectorGrid panel = Panel(degrees, source);
      const std::vector<float> reference = Render(volume, Misaligned(pose), source, panel, cpu);
      const std::vector<float> test = Render(volume, Misaligned(pose), source, panel, gpu);
      const float largest = *std::max_element(reference.begin(), reference.end());
      for (size_t i = 0; i < reference.size(); ++i)
      {
        if (reference[i] > 0.01f * largest)
        {
          relative.push_back(std::abs(double(test[i]) - reference[i]) / reference[i]);
          EXPECT_LE(relative.back(), 0.005) << "pixel " << i;
        }
        else
          EXPECT_NEAR(test[i], reference[i], 1e-3f) << "pixel " << i;
      }
    }
  std::nth_element(relative.begin(), relative.begin() + relative.size() / 2, relative.end());
  EXPECT_LE(relative[relative.size() / 2], 0.0005);
  // Masked pixels are left as they are, on the GPU as on the CPU.
  Eigen::Vector3d source;
  const xp::DetectorGrid panel = Panel(30.0, source);
  std::vector<uint8_t> mask(static_cast<size_t>(panel.columns) * panel.rows, 0);
  for (size_t i = 0; i < mask.size(); i += 3)
    mask[i] = 1;
  std::vector<float> out(mask.size(), -7.0f);
  const xp::TracedPixels traced(panel.columns, panel.rows, mask.data());
  const long long rays = xp::RenderLineIntegrals(volume, Misaligned(1), source, panel, traced, out.data(), gpu);
  EXPECT_EQ(rays, static_cast<long long>(traced.Order().size()));
  for (size_t i = 0; i < mask.size(); ++i)
    if (!mask[i])
      EXPECT_EQ(out[i], -7.0f);
}

} // namespace
