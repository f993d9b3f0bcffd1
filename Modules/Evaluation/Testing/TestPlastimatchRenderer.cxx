// plastimatch as an X-ray source: its views must be the geometry's views. A bead off the
// isocentre, with the patient turned and moved, projects to the same pixel in plastimatch's
// image as through XRayView::Project; a swapped axis, a mirrored panel or an inverted pose moves
// it by many pixels.
#include "xpDetector.h"
#include "xpError.h"
#include "xpImageGeometry.h"
#include "xpPlastimatchRenderer.h"
#include "xpReferenceGeometry.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <gtest/gtest.h>

namespace
{

/** A 60 mm cube (2 mm voxels) of `hu` with a 2 mm bone bead at voxel (bead). */
vtkSmartPointer<vtkImageData> BeadVolume(const Eigen::Vector3i& bead, short hu0 = -1000)
{
  auto ct = vtkSmartPointer<vtkImageData>::New();
  ct->SetDimensions(30, 31, 32);
  ct->SetSpacing(2.0, 2.0, 2.0);
  ct->SetOrigin(-29.0, -30.0, -31.0);
  ct->AllocateScalars(VTK_SHORT, 1);
  short* hu = static_cast<short*>(ct->GetScalarPointer());
  std::fill(hu, hu + 30 * 31 * 32, hu0);
  hu[(bead[2] * 31 + bead[1]) * 30 + bead[0]] = 3000;
  return ct;
}

Eigen::Vector2d Brightest(const std::vector<float>& integrals, int columns)
{
  const size_t i = std::max_element(integrals.begin(), integrals.end()) - integrals.begin();
  return { static_cast<double>(i % columns), static_cast<double>(i / columns) };
}

} // namespace

TEST(PlastimatchRenderer, ABeadProjectsWhereTheGeometrySays)
{
  if (!xp::PlastimatchRenderer::Available())
    GTEST_SKIP() << "plastimatch is not installed (apt-get install plastimatch)";
  const Eigen::Vector3i bead(22, 9, 20);
  vtkSmartPointer<vtkImageData> ct = BeadVolume(bead);
  const Eigen::Vector3d beadInCT = xp::IndexToPhysical(ct) * bead.cast<double>();
  const xp::PatientSetup patient{ xp::PatientPosition::HFS, std::nullopt, Eigen::Vector3d::Zero() };
  const Eigen::Isometry3d planned = patient.PlannedCTToRoom(xp::ImageCenter(ct));
  xp::PlastimatchRenderer renderer(ct, planned, patient.roomIsocenter);
  xp::Pose pose;
  pose.translation = Eigen::Vector3d(6.0, -4.0, 9.0);
  pose.pitch = 4.0;
  pose.roll = -7.0;
  pose.yaw = 10.0;
  const Eigen::Vector3d beadInRoom = xp::MisalignedCTToRoom(planned, pose, patient.roomIsocenter) * beadInCT;
  for (const xp::XRayView& view : xp::testing::ReferenceViews(128, 96))
  {
    const std::vector<float> integrals = renderer.LineIntegrals(view, pose);
    ASSERT_EQ(integrals.size(), 128u * 96u);
    const Eigen::Vector2d expected = view.Project(beadInRoom);
    const Eigen::Vector2d found = Brightest(integrals, 128);
    EXPECT_LE((found - expected).cwiseAbs().maxCoeff(), 1.0) << "view " << view.name << ": bead at " << found.transpose()
                                                              << ", the geometry projects it to " << expected.transpose();
  }
}

TEST(PlastimatchRenderer, LineIntegralsAreMuTimesMillimetres)
{
  if (!xp::PlastimatchRenderer::Available())
    GTEST_SKIP() << "plastimatch is not installed (apt-get install plastimatch)";
  // Water, 60 mm along the central ray of a view at gantry 0 (source above): mu 0.0218 / mm.
  vtkSmartPointer<vtkImageData> ct = BeadVolume(Eigen::Vector3i(0, 0, 0), 0);
  const xp::PatientSetup patient{ xp::PatientPosition::HFS, std::nullopt, Eigen::Vector3d::Zero() };
  xp::PlastimatchRenderer renderer(ct, patient.PlannedCTToRoom(xp::ImageCenter(ct)), patient.roomIsocenter);
  xp::XRayView view;
  view.source = { 0, 0, 1000 };
  view.detectorCenter = { 0, 0, -500 };
  view.size = { 9, 7 };
  const std::vector<float> integrals = renderer.LineIntegrals(view, xp::Pose{});
  // 31 voxels of 2 mm along Room z (CT y): 60 to 62 mm, as the end voxels count.
  EXPECT_NEAR(integrals[3 * 9 + 4] / 61.0, 0.0218, 0.0006);
  // Without the factor of 10 it would be 0.0022.
}

TEST(Detector, FormatsKeepTheirRangeAndPolarity)
{
  // A ramp of transmission from the open field (1) down to 0.1 %.
  std::vector<float> signal(64 * 16);
  for (size_t i = 0; i < signal.size(); ++i)
    signal[i] = static_cast<float>(std::pow(10.0, -3.0 * (i % 64) / 63.0));
  std::mt19937 random(1);
  for (xp::DetectorFormat format :
    { xp::DetectorFormat::Linear12, xp::DetectorFormat::Linear16, xp::DetectorFormat::Log, xp::DetectorFormat::Processed })
  {
    xp::DetectorSettings settings{ format, 0.0, 0.0 };
    const std::vector<uint16_t> image = xp::DetectImage(signal, 64, 16, 1.0, settings, random);
    const int top = xp::DetectorMaxValue(format);
    EXPECT_LE(*std::max_element(image.begin(), image.end()), top) << xp::DetectorFormatName(format);
    const bool linear = format == xp::DetectorFormat::Linear12 || format == xp::DetectorFormat::Linear16;
    // Linear: the open field bright; log and processed: bone (little transmission) bright.
    const int row = 8 * 64;
    EXPECT_EQ(image[row] > image[row + 63], linear) << xp::DetectorFormatName(format);
  }
  EXPECT_EQ(xp::ParseDetectorFormat("linear16", "--detector"), xp::DetectorFormat::Linear16);
  EXPECT_THROW(xp::ParseDetectorFormat("linear14", "--detector"), xp::InputError);
  // Quantum noise: at 100 quanta per pixel at full transmission, half of it counts 50: sd 14 % of the mean.
  std::vector<float> open(200 * 200, 0.5f);
  const std::vector<uint16_t> noisy = xp::DetectImage(open, 200, 200, 1.0, { xp::DetectorFormat::Linear16, 100.0, 0.0 }, random);
  double sum = 0.0, squares = 0.0;
  for (uint16_t v : noisy)
    sum += v, squares += double(v) * v;
  const double mean = sum / noisy.size(), sd = std::sqrt(squares / noisy.size() - mean * mean);
  EXPECT_NEAR(sd / mean, std::sqrt(1.0 / 50.0), 0.005);
}
