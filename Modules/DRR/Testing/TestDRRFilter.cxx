// vtkXPDRRFilter in the conventions of Coordinates.md: a dense marker in a CT lands on the pixel
// that the geometry predicts, and a patient misalignment moves it the way the convention says.
#include "vtkXPDRRFilter.h"

#include "xpImageGeometry.h"
#include "xpPose.h"
#include "xpReferenceGeometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkShortArray.h>
#include <vtkSmartPointer.h>

namespace
{

xp::XRayView ViewA()
{
  return xp::testing::ReferenceViews(256, 192)[0];
}

/**
 * A 60x50x40 CT of air with 2 mm voxels, an axial HFS orientation and a 4 mm bone cube centred
 * at CT voxel (40, 12, 30). Origin and a non-zero extent start exercise the index mapping.
 */
vtkSmartPointer<vtkImageData> MarkerCT(Eigen::Vector3d& markerLPS)
{
  auto ct = vtkSmartPointer<vtkImageData>::New();
  ct->SetExtent(0, 59, 0, 49, 0, 39);
  ct->SetSpacing(2.0, 2.0, 2.0);
  ct->SetOrigin(-50.0, 20.0, 100.0);
  vtkNew<vtkShortArray> hu;
  hu->SetNumberOfValues(60 * 50 * 40);
  hu->FillValue(-1000);
  for (int k = 29; k <= 30; ++k)
    for (int j = 11; j <= 12; ++j)
      for (int i = 39; i <= 40; ++i)
        hu->SetValue((k * 50 + j) * 60 + i, 3000);
  ct->GetPointData()->SetScalars(hu);
  markerLPS = Eigen::Vector3d(-50.0 + 2 * 39.5, 20.0 + 2 * 11.5, 100.0 + 2 * 29.5);
  return ct;
}

/** A DRR filter rendering view A of `ct`, updated. */
vtkSmartPointer<vtkXPDRRFilter> RenderViewA(vtkImageData* ct)
{
  auto drr = vtkSmartPointer<vtkXPDRRFilter>::New();
  drr->SetInputData(ct);
  drr->SetView(ViewA());
  drr->Update();
  return drr;
}

/** Room position of the marker with the planned HFS set-up (CT centre at the isocentre). */
Eigen::Vector3d MarkerInRoom(vtkImageData* ct, const Eigen::Vector3d& markerLPS)
{
  double center[3];
  const double mid[3] = { 29.5, 24.5, 19.5 };
  ct->TransformContinuousIndexToPhysicalPoint(mid, center);
  return xp::PlannedCTToRoom(xp::PatientPosition::HFS, Eigen::Vector3d(center), Eigen::Vector3d::Zero()) * markerLPS;
}

/** Centroid (detector col, row) of the attenuation in a DRR line-integral output. */
Eigen::Vector2d Centroid(vtkImageData* lineIntegral)
{
  int dims[3];
  lineIntegral->GetDimensions(dims);
  const float* v = static_cast<const float*>(lineIntegral->GetScalarPointer());
  double sum = 0, sc = 0, sr = 0;
  for (int j = 0; j < dims[1]; ++j)
    for (int i = 0; i < dims[0]; ++i)
    {
      const double w = v[j * dims[0] + i];
      sum += w;
      sc += w * i;
      sr += w * (dims[1] - 1 - j); // VTK rows run up: detector row = rows-1-j
    }
  EXPECT_GT(sum, 0.0);
  return { sc / sum, sr / sum };
}

} // namespace

TEST(vtkXPDRRFilter, MarkerLandsOnThePredictedPixel)
{
  Eigen::Vector3d marker;
  vtkSmartPointer<vtkImageData> ct = MarkerCT(marker);
  vtkSmartPointer<vtkXPDRRFilter> drr = RenderViewA(ct);
  ASSERT_EQ(drr->GetNumberOfTracedRays(), 256 * 192);

  const Eigen::Vector3d room = MarkerInRoom(ct, marker);
  // HFS: the marker is left (+X), anterior (+Z) and superior (+Y) of the CT centre.
  EXPECT_GT(room[0], 0);
  EXPECT_GT(room[1], 0);
  EXPECT_GT(room[2], 0);
  const Eigen::Vector2d expected = ViewA().Project(room);
  const Eigen::Vector2d found = Centroid(drr->GetOutput(1));
  EXPECT_NEAR(found[0], expected[0], 0.1);
  EXPECT_NEAR(found[1], expected[1], 0.1);

  // The same pixel holds the darkest 12-bit value (bone is dark in transmission).
  vtkImageData* twelve = drr->GetOutput(0);
  const uint16_t* t = static_cast<const uint16_t*>(twelve->GetScalarPointer());
  const int vtkRow = 191 - static_cast<int>(std::lround(expected[1]));
  const int col = static_cast<int>(std::lround(expected[0]));
  EXPECT_LT(t[vtkRow * 256 + col], 4095);
  EXPECT_EQ(t[0], 4095) << "air everywhere else";
  // Output placement: VTK pixel (col, vtkRow) sits at the room position of detector pixel (col, row).
  double p[3];
  const double index[3] = { double(col), double(vtkRow), 0.0 };
  twelve->TransformContinuousIndexToPhysicalPoint(index, p);
  EXPECT_NEAR((Eigen::Vector3d(p) - ViewA().PixelCenter(col, 191 - vtkRow)).norm(), 0.0, 1e-6);
}

TEST(vtkXPDRRFilter, MisalignmentMovesTheMarkerAsTheConventionSays)
{
  Eigen::Vector3d marker;
  vtkSmartPointer<vtkImageData> ct = MarkerCT(marker);
  vtkSmartPointer<vtkXPDRRFilter> drr = RenderViewA(ct);
  const Eigen::Vector2d before = Centroid(drr->GetOutput(1));

  const Eigen::Vector3d room = MarkerInRoom(ct, marker);
  for (const char* text : { "5,0,0,0,0,0", "0,-7,3,0,0,0", "0,0,0,0,0,8", "2,1,-1,4,-3,2" })
  {
    const xp::Pose pose = xp::Pose::Parse(text, "pose");
    drr->SetMisalignment(pose);
    drr->Update();
    const Eigen::Vector2d moved = Centroid(drr->GetOutput(1));
    const Eigen::Vector2d expected = ViewA().Project(pose.ToTransform(Eigen::Vector3d::Zero()) * room);
    EXPECT_NEAR(moved[0], expected[0], 0.1) << text;
    EXPECT_NEAR(moved[1], expected[1], 0.1) << text;
    EXPECT_GT((moved - before).norm(), 0.5) << text;
  }
}

TEST(vtkXPDRRFilter, MaskPortSkipsRaysAndFlagsThem)
{
  Eigen::Vector3d marker;
  vtkSmartPointer<vtkImageData> ct = MarkerCT(marker);
  vtkNew<vtkImageData> mask;
  mask->SetDimensions(256, 192, 1);
  mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  uint8_t* m = static_cast<uint8_t*>(mask->GetScalarPointer());
  for (int i = 0; i < 256 * 192; ++i)
    m[i] = (i % 256) < 64 ? 1 : 0; // a quarter of the columns
  vtkNew<vtkXPDRRFilter> drr;
  drr->SetInputData(0, ct);
  drr->SetInputData(1, mask);
  drr->SetView(ViewA());
  drr->Update();
  EXPECT_EQ(drr->GetNumberOfTracedRays(), 64 * 192);
  const uint8_t* valid = static_cast<const uint8_t*>(drr->GetOutput(2)->GetScalarPointer());
  const uint16_t* t = static_cast<const uint16_t*>(drr->GetOutput(0)->GetScalarPointer());
  EXPECT_EQ(valid[10], 255);
  EXPECT_EQ(valid[100], 0);
  EXPECT_EQ(t[100], 0);
  EXPECT_EQ(t[10], 4095);

  vtkNew<vtkImageData> wrongSize;
  wrongSize->SetDimensions(100, 100, 1);
  wrongSize->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  drr->SetInputData(1, wrongSize);
  drr->GlobalWarningDisplayOff();
  drr->Update();
  drr->GlobalWarningDisplayOn();
  EXPECT_EQ(drr->GetOutput(0)->GetNumberOfPoints(), 0) << "a mask of the wrong size is refused";
}

// 16-bit and float HU of the same values give the same attenuation volume, hence the same DRR.
TEST(vtkXPDRRFilter, SixteenBitAndFloatHUGiveTheSameDRR)
{
  Eigen::Vector3d marker;
  vtkSmartPointer<vtkImageData> shortCT = MarkerCT(marker);
  auto floatCT = vtkSmartPointer<vtkImageData>::New();
  floatCT->CopyStructure(shortCT);
  vtkNew<vtkFloatArray> hu;
  hu->SetNumberOfValues(shortCT->GetNumberOfPoints());
  for (vtkIdType i = 0; i < shortCT->GetNumberOfPoints(); ++i)
    hu->SetValue(i, static_cast<float>(shortCT->GetPointData()->GetScalars()->GetTuple1(i)));
  floatCT->GetPointData()->SetScalars(hu);
  vtkSmartPointer<vtkXPDRRFilter> a = RenderViewA(shortCT), b = RenderViewA(floatCT);
  const float* la = static_cast<const float*>(a->GetOutput(1)->GetScalarPointer());
  const float* lb = static_cast<const float*>(b->GetOutput(1)->GetScalarPointer());
  double largest = 0.0;
  for (vtkIdType i = 0; i < a->GetOutput(1)->GetNumberOfPoints(); ++i)
  {
    ASSERT_EQ(la[i], lb[i]) << "pixel " << i;
    largest = std::max(largest, static_cast<double>(la[i]));
  }
  EXPECT_GT(largest, 0.1); // the marker is in the picture
}

// The body's volume from the CT's own HU with voxels left out (`keep`) is, bit for bit, the volume
// of a copy of the CT with those voxels set to air: the same stored box, quantum, both voxel
// layouts and occupancy, and it differs from the whole CT's.
TEST(vtkXPDRRFilter, VoxelsLeftOutAreTheVolumeOfACopyWithThemSetToAir)
{
  const Eigen::Vector3i dims(70, 50, 40);
  const size_t count = static_cast<size_t>(dims.prod());
  auto ct = vtkSmartPointer<vtkImageData>::New();
  ct->SetDimensions(dims[0], dims[1], dims[2]);
  ct->SetSpacing(0.9, 0.9, 2.0);
  vtkNew<vtkShortArray> hu;
  hu->SetNumberOfValues(static_cast<vtkIdType>(count));
  std::vector<uint8_t> keep(count);
  std::vector<float> cleared(count);
  uint32_t state = 12345;
  for (size_t n = 0; n < count; ++n)
  {
    const int i = static_cast<int>(n % dims[0]), j = static_cast<int>(n / dims[0] % dims[1]);
    state = state * 1664525u + 1013904223u;
    // A body in the middle, a dense "table" along the low rows, air and its noise elsewhere.
    const bool body = std::hypot(i - 35.0, j - 22.0) < 16.0, table = j >= 44 && j < 47;
    const short value = static_cast<short>(body ? 40 + (state >> 22) % 900 : table ? 1500 : -1000 + (state >> 24) % 80);
    hu->SetValue(static_cast<vtkIdType>(n), value);
    keep[n] = body;
    cleared[n] = body ? static_cast<float>(value) : -1000.0f;
  }
  ct->GetPointData()->SetScalars(hu);
  const std::unique_ptr<xp::AttenuationVolume> kept = xp::MakeAttenuationVolume(ct, 0.02, &keep);
  const xp::AttenuationVolume copied(cleared.data(), dims, xp::IndexToPhysical(ct), 0.02);
  const std::unique_ptr<xp::AttenuationVolume> whole = xp::MakeAttenuationVolume(ct, 0.02);
  EXPECT_EQ(kept->StoredOrigin(), copied.StoredOrigin());
  ASSERT_EQ(kept->PaddedDimensions(), copied.PaddedDimensions());
  EXPECT_EQ(kept->Quantum(), copied.Quantum());
  const size_t voxels = static_cast<size_t>(copied.PaddedDimensions().prod());
  EXPECT_TRUE(std::equal(kept->Voxels(), kept->Voxels() + voxels, copied.Voxels()));
  EXPECT_TRUE(std::equal(kept->VoxelsYFastest(), kept->VoxelsYFastest() + voxels, copied.VoxelsYFastest()));
  ASSERT_EQ(kept->BlockDimensions(), copied.BlockDimensions());
  EXPECT_TRUE(std::equal(kept->OccupancyGrid(), kept->OccupancyGrid() + copied.BlockDimensions().prod(), copied.OccupancyGrid()));
  // The table and the air's noise were left out: the whole CT's box is larger, its quantum coarser.
  EXPECT_NE(whole->PaddedDimensions(), kept->PaddedDimensions());
  EXPECT_GT(whole->Quantum(), kept->Quantum());
  // A flag list of another size is refused, not read past its end.
  keep.pop_back();
  EXPECT_THROW(xp::MakeAttenuationVolume(ct, 0.02, &keep), std::invalid_argument);
}
