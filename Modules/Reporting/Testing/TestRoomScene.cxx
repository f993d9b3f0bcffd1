#include "xpRoomScene.h"
#include "xpVirtualDisplay.h"

#include "xpHeadPhantom.h"
#include "xpReferenceGeometry.h"

#include <gtest/gtest.h>

#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>

#include <cstdlib>

namespace
{

vtkSmartPointer<vtkImageData> PhantomImage()
{
  const xp::CTVolumeData phantom = xp::MakeHeadPhantom(3.0);
  vtkNew<vtkImageData> ct;
  ct->SetDimensions(phantom.dimensions.data());
  ct->SetSpacing(phantom.spacing.data());
  ct->SetOrigin(phantom.origin.data());
  vtkNew<vtkFloatArray> hu;
  hu->SetNumberOfValues(static_cast<vtkIdType>(phantom.hounsfield.size()));
  std::copy(phantom.hounsfield.begin(), phantom.hounsfield.end(), hu->GetPointer(0));
  ct->GetPointData()->SetScalars(hu);
  return vtkSmartPointer<vtkImageData>(ct);
}

/** Pixels whose colour differs by more than 30 in any channel. */
long long Differing(vtkImageData* a, vtkImageData* b)
{
  const auto* p = static_cast<const uint8_t*>(a->GetScalarPointer());
  const auto* q = static_cast<const uint8_t*>(b->GetScalarPointer());
  long long count = 0;
  for (vtkIdType i = 0; i < a->GetNumberOfPoints(); ++i)
    count += std::abs(p[3 * i] - q[3 * i]) > 30 || std::abs(p[3 * i + 1] - q[3 * i + 1]) > 30 ||
      std::abs(p[3 * i + 2] - q[3 * i + 2]) > 30;
  return count;
}

} // namespace

TEST(RoomScene, BoneSurfaceSitsAtTheIsocentreAndTheSceneMovesWithThePose)
{
  const xp::StereoGeometry geometry = xp::testing::ReferenceStereoGeometry();
  vtkSmartPointer<vtkImageData> ct = PhantomImage();
  xp::RoomScene scene(geometry);
  const Eigen::Vector3d isoInCT(0, 10, -23); // the phantom volume's centre
  scene.SetCT(ct, xp::PlannedCTToRoom(xp::PatientPosition::HFS, isoInCT, geometry.isocenter));
  vtkPolyData* bone = scene.GetBoneSurface();
  ASSERT_GT(bone->GetNumberOfPoints(), 1000);
  double bounds[6];
  bone->GetBounds(bounds);
  for (int axis = 0; axis < 3; ++axis) // the skull surrounds the isocentre
  {
    EXPECT_LT(bounds[2 * axis], geometry.isocenter[axis] - 40.0);
    EXPECT_GT(bounds[2 * axis + 1], geometry.isocenter[axis] + 40.0);
  }

  std::string reason;
  const std::unique_ptr<xp::VirtualDisplay> display = xp::VirtualDisplay::Ensure(reason);
  if (!display)
  {
    if (std::getenv("CI"))
      FAIL() << "CI must render the 3D scene: " << reason;
    GTEST_SKIP() << reason;
  }
  vtkSmartPointer<vtkImageData> planned = scene.Render(480, 360);
  vtkSmartPointer<vtkImageData> again = scene.Render(480, 360);
  xp::Pose moved;
  moved.translation = Eigen::Vector3d(15, 0, 10);
  moved.yaw = 5;
  scene.SetMisalignment(moved);
  vtkSmartPointer<vtkImageData> misaligned = scene.Render(480, 360);
  int dims[3];
  planned->GetDimensions(dims);
  ASSERT_EQ(dims[0], 480);
  ASSERT_EQ(dims[1], 360);
  const long long total = 480 * 360;
  EXPECT_LT(Differing(planned, again), total / 200) << "the same scene renders the same";
  EXPECT_GT(Differing(planned, misaligned), total / 100) << "a misalignment shows in 3D";
  // Not blank: the bone colour covers part of the picture.
  long long bright = 0;
  const auto* p = static_cast<const uint8_t*>(planned->GetScalarPointer());
  for (long long i = 0; i < total; ++i)
    bright += p[3 * i] > 120 && p[3 * i + 1] > 110;
  EXPECT_GT(bright, total / 100);
}
