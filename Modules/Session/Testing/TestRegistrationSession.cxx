// The session reads and checks its sources before any registration work, naming the file or the
// option of each refusal; what it records of them lets `xpose report` find them again.
#include "xpRegistrationSession.h"

#include "xpDICOMSeriesWriter.h"
#include "xpError.h"
#include "xpHeadPhantom.h"
#include "xpImageRows.h"
#include "xpTestFolders.h"

#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkNew.h>

#include <filesystem>
#include <fstream>

namespace
{

std::string Refusal(const xp::RegistrationSources& sources)
{
  try
  {
    xp::RegistrationSession session(sources);
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "accepted";
}

/** A coarse phantom CT series, and the sources that name it with the reference geometry. */
xp::RegistrationSources PhantomSources(const std::string& name)
{
  const std::string dir = xp::testing::FreshFolder(name);
  std::filesystem::create_directories(dir + "/ct");
  xp::WriteCTSeries(xp::MakeHeadPhantom(8.0), dir + "/ct");
  xp::RegistrationSources sources;
  sources.ct = dir + "/ct";
  sources.geometry = XP_SOURCE_DIR "/Data/geometry/stereo-oblique-90.json";
  sources.xrays = { dir + "/xray_A.png", dir + "/xray_B.png" }; // checked after the CT and the geometry
  return sources;
}

} // namespace

TEST(RegistrationSession, RefusesEachSourceByItsFileOrOption)
{
  xp::RegistrationSources sources = PhantomSources("session-refusals");
  xp::RegistrationSources missing = sources;
  missing.ct += "-missing";
  EXPECT_NE(Refusal(missing).find("ct-missing"), std::string::npos) << Refusal(missing);
  xp::RegistrationSources one = sources;
  one.xrays.pop_back();
  EXPECT_NE(Refusal(one).find("--xray"), std::string::npos) << Refusal(one);
  EXPECT_NE(Refusal(one).find("2 imagers"), std::string::npos) << Refusal(one);
  xp::RegistrationSources rois = sources;
  rois.rois = { "roi_A.png" };
  EXPECT_NE(Refusal(rois).find("--roi"), std::string::npos) << Refusal(rois);
  xp::RegistrationSources size = sources;
  size.size = Eigen::Vector2i(300, 200); // the reference panels are 1024x768
  EXPECT_NE(Refusal(size).find("--size"), std::string::npos) << Refusal(size);
  // All of the above were refused before the X-rays, which do not exist, were opened.
  EXPECT_NE(Refusal(sources).find("xray_A.png"), std::string::npos) << Refusal(sources);
}

TEST(RegistrationSession, RecordsItsSourcesAsAbsolutePathsWithTheXRaysDigests)
{
  const std::string dir = xp::testing::FreshFolder("session-record");
  std::ofstream(dir + "/a.png") << "first";
  std::ofstream(dir + "/b.png") << "second";
  xp::RegistrationSources sources;
  sources.ct = dir + "/ct";
  sources.geometry = dir + "/../" + dir + "/geometry.json";
  sources.xrays = { dir + "/a.png", dir + "/b.png" };
  sources.size = Eigen::Vector2i(256, 192);
  sources.removeTable = true;
  const xp::RegistrationRecordInputs recorded = xp::RecordedInputs(sources, false);
  const std::string here = std::filesystem::current_path().string();
  EXPECT_EQ(recorded.ct, here + "/" + dir + "/ct");
  EXPECT_EQ(recorded.geometry, here + "/" + dir + "/geometry.json") << "not normalised";
  ASSERT_EQ(recorded.xrayMD5.size(), 2u);
  EXPECT_NE(recorded.xrayMD5[0], recorded.xrayMD5[1]) << "each X-ray's own digest";
  EXPECT_EQ(recorded.size, Eigen::Vector2i(256, 192));
  EXPECT_TRUE(recorded.removeTable);
  EXPECT_FALSE(recorded.entropyMask);
}

TEST(RegistrationSession, InMemoryTakesItsXRaysAndChecksEachAgainstItsImager)
{
  auto ct = vtkSmartPointer<vtkImageData>::New();
  ct->SetDimensions(8, 8, 8);
  ct->SetSpacing(4, 4, 4);
  ct->AllocateScalars(VTK_FLOAT, 1);
  xp::StereoGeometry geometry = xp::ReadStereoGeometry(XP_SOURCE_DIR "/Data/geometry/stereo-oblique-90.json");
  for (xp::XRayView& view : geometry.views)
    view = view.Resampled(64, 48);
  xp::RegistrationSession session(ct, xp::PatientSetup{}, geometry);
  EXPECT_FALSE(session.FromFiles());
  EXPECT_TRUE(session.Inputs().views.empty()) << "no X-rays yet";
  const auto xray = [](int columns, int rows, uint16_t seed)
  {
    auto image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(columns, rows, 1);
    image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    auto* p = static_cast<uint16_t*>(image->GetScalarPointer());
    for (int i = 0; i < columns * rows; ++i)
      p[i] = static_cast<uint16_t>((i * 7 + seed) % 4096);
    return image;
  };
  const auto second = xray(64, 48, 2);
  session.SetXRays({ xray(64, 48, 1), second });
  ASSERT_EQ(session.Inputs().views.size(), 2u);
  EXPECT_EQ(session.Inputs().views[1].view.Columns(), 64);
  EXPECT_EQ(session.Inputs().views[1].xray, xp::RowsTopFirst<uint16_t>(second)) << "the second X-ray is the second view's";
  try
  {
    session.SetXRays({ xray(64, 48, 1), xray(32, 24, 2) });
    ADD_FAILURE() << "an X-ray of another size was taken";
  }
  catch (const xp::InputError& e)
  {
    EXPECT_NE(std::string(e.what()).find("imager B"), std::string::npos) << e.what();
  }
  EXPECT_EQ(session.Inputs().views[1].xray, xp::RowsTopFirst<uint16_t>(second)) << "a refused pair changes nothing";
}

// The target is a CT point: inside the grid (half a voxel beyond the outer centres included),
// refused by --target outside it; none given is the planned isocentre.
TEST(RegistrationSession, TheTargetMustLieInTheCT)
{
  vtkNew<vtkImageData> ct;
  ct->SetDimensions(10, 20, 5);
  ct->SetSpacing(1.0, 2.0, 3.0);
  ct->SetOrigin(-5.0, 100.0, 0.0);
  ct->AllocateScalars(VTK_SHORT, 1);
  const Eigen::Vector3d iso(0.0, 120.0, 6.0);
  EXPECT_EQ(xp::ResolveTarget(std::nullopt, ct, iso), iso);
  EXPECT_EQ(xp::ResolveTarget(Eigen::Vector3d(4.4, 138, 13), ct, iso), Eigen::Vector3d(4.4, 138, 13));
  for (const Eigen::Vector3d outside : { Eigen::Vector3d(5.6, 120, 6), Eigen::Vector3d(0, 98.9, 6), Eigen::Vector3d(0, 120, 13.6),
         Eigen::Vector3d(0, 120, -1.6) })
  {
    try
    {
      xp::ResolveTarget(outside, ct, iso);
      ADD_FAILURE() << outside.transpose() << " passed";
    }
    catch (const xp::InputError& e)
    {
      EXPECT_NE(std::string(e.what()).find("--target"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("outside the CT"), std::string::npos) << e.what();
    }
  }
}

// A geometry file's couch, and the options that override it.
TEST(RegistrationSession, TheOptionsOverrideTheGeometrysCouch)
{
  xp::StereoGeometry room;
  EXPECT_TRUE(xp::ResolveCouch(room, {}) == xp::CouchDescription{}) << "none in the file: 6dof, unlimited";
  room.couch = xp::CouchDescription{};
  room.couch->motions = xp::CouchMotions::FourDOF;
  room.couch->rotationCenter = Eigen::Vector3d(1, 2, 3);
  xp::CouchOptions options;
  EXPECT_EQ(xp::ResolveCouch(room, options).motions, xp::CouchMotions::FourDOF);
  options.motions = "6dof";
  options.rotationLimit = "2.5";
  const xp::CouchDescription couch = xp::ResolveCouch(room, options);
  EXPECT_EQ(couch.motions, xp::CouchMotions::SixDOF);
  EXPECT_EQ(couch.pitchRollLimitDegrees, 2.5);
  EXPECT_EQ(couch.rotationCenter.value(), Eigen::Vector3d(1, 2, 3));
  options.rotationLimit = "nan";
  EXPECT_THROW(xp::ResolveCouch(room, options), xp::InputError);
}

// A binned X-ray keeps its panel's extent with the spacing scaled per axis; its imager's own size
// is the panel itself; other sizes are refused naming the file and both sizes.
TEST(RegistrationSession, AnXRayIsItsPanelOrThePanelBinned)
{
  xp::XRayView panel;
  panel.name = "A";
  panel.size = { 1024, 768 };
  panel.pixelSpacing = { 0.4, 0.4 };
  const auto xray = [](int columns, int rows)
  {
    vtkSmartPointer<vtkImageData> image = vtkSmartPointer<vtkImageData>::New();
    image->SetDimensions(columns, rows, 1);
    return image;
  };
  const Eigen::Vector3d iso = Eigen::Vector3d::Zero();
  const xp::XRayView same = xp::PanelOfXRay(panel, xray(1024, 768), "a.png", iso, xp::PatientPosition::HFS);
  EXPECT_EQ(same.Columns(), 1024);
  EXPECT_EQ(same.pixelSpacing[0], 0.4);
  const xp::XRayView binned = xp::PanelOfXRay(panel, xray(512, 384), "a.png", iso, xp::PatientPosition::HFS);
  EXPECT_EQ(binned.Columns(), 512);
  EXPECT_EQ(binned.Rows(), 384);
  EXPECT_DOUBLE_EQ(binned.pixelSpacing[0], 0.8);
  EXPECT_DOUBLE_EQ(binned.pixelSpacing[1], 0.8);
  const xp::XRayView uneven = xp::PanelOfXRay(panel, xray(1024, 384), "a.png", iso, xp::PatientPosition::HFS);
  EXPECT_DOUBLE_EQ(uneven.pixelSpacing[0], 0.4) << "columns kept";
  EXPECT_DOUBLE_EQ(uneven.pixelSpacing[1], 0.8) << "rows binned";
  for (const auto& [columns, rows] : std::vector<std::pair<int, int>>{ { 600, 450 }, { 2048, 1536 }, { 512, 300 } })
  {
    try
    {
      xp::PanelOfXRay(panel, xray(columns, rows), "a.png", iso, xp::PatientPosition::HFS);
      ADD_FAILURE() << columns << "x" << rows << " passed";
    }
    catch (const xp::InputError& e)
    {
      const std::string message = e.what();
      EXPECT_NE(message.find("a.png"), std::string::npos) << message;
      EXPECT_NE(message.find(std::to_string(columns) + "x" + std::to_string(rows)), std::string::npos) << message;
      EXPECT_NE(message.find("1024x768"), std::string::npos) << message;
    }
  }
}
