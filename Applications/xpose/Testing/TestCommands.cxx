// The subcommands end to end: phantom -> DICOM -> DRR files, exit codes, nothing half-written.
#include "xpCommands.h"
#include "xpCudaRayCaster.h"
#include "xpProjectionMatrix.h"
#include "xpRegistrationRecord.h"
#include "xpDICOMSeries.h"
#include "xpImageGeometry.h"
#include "xpImageIO.h"
#include "xpPose.h"
#include "xpSpatialRegistration.h"
#include "xpVolumeIO.h"
#include "xpStereoGeometry.h"

#include <algorithm>
#include <dirent.h>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <vtkDataArray.h>
#include <Eigen/Core>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>

namespace
{

const std::string Geometry = std::string(XP_SOURCE_DIR) + "/Data/geometry/stereo-oblique-90.json";
const std::string SharedPelvis = std::string(XP_SHARED_DATA_DIR) + "/ct/vhm-pelvis";

int CountFiles(const std::string& dir)
{
  int n = 0;
  if (DIR* d = opendir(dir.c_str()))
  {
    while (dirent* e = readdir(d))
      n += e->d_name[0] != '.' || std::string(e->d_name).rfind(".xpose-partial", 0) == 0;
    closedir(d);
  }
  return n;
}

bool Exists(const std::string& path)
{
  struct stat s;
  return stat(path.c_str(), &s) == 0;
}

/**
 * A coarse phantom CT, one per test: ctest runs the tests of this file as parallel processes in
 * one folder, so each needs its own.
 */
const std::string& PhantomCT()
{
  static const std::string dir = []
  {
    const std::string folder = std::string("cmd-phantom-") + ::testing::UnitTest::GetInstance()->current_test_info()->name();
    EXPECT_EQ(std::system(("rm -rf " + folder).c_str()), 0);
    xp::PhantomOptions options;
    options.outputDirectory = folder;
    options.spacing = 3.0;
    EXPECT_EQ(xp::GuardedRun("phantom", [&] { return xp::RunPhantom(options); }), xp::ExitOk);
    return options.outputDirectory;
  }();
  return dir;
}

xp::DRROptions SmallDRR(const std::string& out)
{
  EXPECT_EQ(std::system(("rm -rf " + out).c_str()), 0);
  xp::DRROptions options;
  options.ct = PhantomCT();
  options.geometry = Geometry;
  options.size = "128x96";
  options.outputDirectory = out;
  return options;
}

void WriteMask(const std::string& path, int columns, int rows, int validColumns)
{
  vtkNew<vtkImageData> mask;
  mask->SetDimensions(columns, rows, 1);
  mask->AllocateScalars(VTK_UNSIGNED_CHAR, 1);
  auto* m = static_cast<unsigned char*>(mask->GetScalarPointer());
  for (int i = 0; i < columns * rows; ++i)
    m[i] = (i % columns) < validColumns ? 255 : 0;
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(mask);
  writer->SetFileName(path.c_str());
  writer->Write();
}

} // namespace

TEST(Commands, PhantomThenDRRWritesBothViews)
{
  xp::DRROptions options = SmallDRR("cmd-drr");
  options.pose = "5,0,0,0,0,2";
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitOk);
  for (const char* name : { "A", "B" })
  {
    const std::string png = "cmd-drr/drr_" + std::string(name) + ".png";
    ASSERT_TRUE(Exists(png)) << png;
    ASSERT_TRUE(Exists("cmd-drr/drr_" + std::string(name) + ".mha"));
    vtkNew<vtkPNGReader> reader;
    reader->SetFileName(png.c_str());
    reader->Update();
    vtkImageData* image = reader->GetOutput();
    EXPECT_EQ(image->GetScalarType(), VTK_UNSIGNED_SHORT);
    EXPECT_EQ(image->GetDimensions()[0], 128);
    double range[2];
    image->GetPointData()->GetScalars()->GetRange(range);
    EXPECT_LE(range[1], 4095.0) << "12-bit values";
    EXPECT_LT(range[0], 1500.0) << "bone and the head rest attenuate";
    EXPECT_GT(range[1], 4000.0) << "air around the head transmits";
  }
  EXPECT_EQ(CountFiles("cmd-drr"), 6) << "no staging folder left behind";
}

TEST(Commands, MaskedDRRMatchesUnmaskedWhereValid)
{
  xp::DRROptions full = SmallDRR("cmd-full");
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(full); }), xp::ExitOk);
  ASSERT_EQ(std::system("rm -rf cmd-masks && mkdir cmd-masks"), 0);
  WriteMask("cmd-masks/mask_A.png", 128, 96, 40);
  WriteMask("cmd-masks/mask_B.png", 128, 96, 128);
  xp::DRROptions masked = SmallDRR("cmd-masked");
  masked.maskDirectory = "cmd-masks";
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(masked); }), xp::ExitOk);
  vtkNew<vtkPNGReader> a, b;
  a->SetFileName("cmd-full/drr_A.png");
  b->SetFileName("cmd-masked/drr_A.png");
  a->Update();
  b->Update();
  const auto* pa = static_cast<const unsigned short*>(a->GetOutput()->GetScalarPointer());
  const auto* pb = static_cast<const unsigned short*>(b->GetOutput()->GetScalarPointer());
  for (int i = 0; i < 128 * 96; ++i)
  {
    ASSERT_EQ(pb[i], (i % 128) < 40 ? pa[i] : 0) << "pixel " << i;
  }
}

TEST(Commands, BadInputExitsWithTwoAndWritesNothing)
{
  // Inconsistent geometry file.
  std::ofstream("cmd-bad-geometry.json") << "{ \"imagers\": [ { \"name\": \"A\", \"source\": [0, 0, -1000], "
                                            "\"detector\": { \"center\": [0, 0, 500], \"row_direction\": [1, 0, 0], "
                                            "\"column_direction\": [1, 0, 0], \"pixel_spacing\": [1, 1], \"size\": [10, 10] } } ] }";
  xp::DRROptions options = SmallDRR("cmd-bad1");
  options.geometry = "cmd-bad-geometry.json";
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-bad1"));

  // A mask of the wrong size for view B: view A must not be written either.
  ASSERT_EQ(std::system("rm -rf cmd-bad-masks && mkdir cmd-bad-masks"), 0);
  WriteMask("cmd-bad-masks/mask_A.png", 128, 96, 50);
  WriteMask("cmd-bad-masks/mask_B.png", 64, 48, 50);
  options = SmallDRR("cmd-bad2");
  options.maskDirectory = "cmd-bad-masks";
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitBadInput);
  EXPECT_EQ(CountFiles("cmd-bad2"), 0);

  // An empty mask.
  WriteMask("cmd-bad-masks/mask_B.png", 128, 96, 0);
  options = SmallDRR("cmd-bad3");
  options.maskDirectory = "cmd-bad-masks";
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitBadInput);
  EXPECT_EQ(CountFiles("cmd-bad3"), 0);

  for (auto [field, value] : { std::pair<std::string, std::string>{ "pose", "1,2,3" }, { "size", "12x" },
         { "method", "joseph" }, { "ct", "cmd-no-such-ct" } })
  {
    options = SmallDRR("cmd-bad4");
    if (field == "pose")
      options.pose = value;
    if (field == "size")
      options.size = value;
    if (field == "method")
      options.method = value;
    if (field == "ct")
      options.ct = value;
    EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitBadInput) << field;
    EXPECT_EQ(CountFiles("cmd-bad4"), 0) << field;
  }

  // --dicom-out with a panel tilted against its beam axis (no RT Image for it): refused before
  // anything is rendered or written.
  std::ofstream("cmd-tilted-geometry.json") << "{ \"imagers\": [ { \"name\": \"A\", \"source\": [0, 0, -1000], "
                                              "\"detector\": { \"center\": [0, 0, 500], \"row_direction\": [0.984808, 0, 0.173648], "
                                              "\"column_direction\": [0, -1, 0], \"pixel_spacing\": [2, 2], \"size\": [64, 64] } } ] }";
  options = SmallDRR("cmd-bad5");
  options.geometry = "cmd-tilted-geometry.json";
  options.size = "";
  options.dicomOutputDirectory = "cmd-bad5-dicom";
  ASSERT_EQ(std::system("rm -rf cmd-bad5-dicom"), 0);
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-bad5")) << "refused before the output folders are made";
  EXPECT_FALSE(Exists("cmd-bad5-dicom"));

  xp::PhantomOptions phantom;
  phantom.outputDirectory = PhantomCT(); // not empty
  EXPECT_EQ(xp::GuardedRun("phantom", [&] { return xp::RunPhantom(phantom); }), xp::ExitBadInput);
}

TEST(Commands, RealPelvisCT)
{
  if (!Exists(SharedPelvis))
  {
    GTEST_SKIP() << "shared pelvis CT not found at " << SharedPelvis << " (../shared/data beside the project)";
  }
  xp::DRROptions options = SmallDRR("cmd-pelvis");
  options.ct = SharedPelvis;
  options.size = "256x192";
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(options); }), xp::ExitOk);
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName("cmd-pelvis/drr_A.png");
  reader->Update();
  double range[2];
  reader->GetOutput()->GetPointData()->GetScalars()->GetRange(range);
  EXPECT_LT(range[0], 300.0) << "the pelvis attenuates strongly along oblique rays";
  EXPECT_EQ(range[1], 4095.0) << "rows beyond the 140 mm of CT see no attenuation";
}

TEST(Commands, MaskOfADRRWritesMaskAndEntropy)
{
  xp::DRROptions drr = SmallDRR("cmd-mask-drr");
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  ASSERT_EQ(std::system("rm -rf cmd-mask"), 0);
  xp::MaskOptions options;
  options.xray = "cmd-mask-drr/drr_A.png";
  options.outputDirectory = "cmd-mask";
  ASSERT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(options); }), xp::ExitOk);
  EXPECT_TRUE(Exists("cmd-mask/mask.png"));
  EXPECT_TRUE(Exists("cmd-mask/entropy.png"));

  // An ROI that allows nothing leaves an empty mask: refused, nothing written.
  ASSERT_EQ(std::system("rm -rf cmd-mask-empty cmd-roi && mkdir cmd-roi"), 0);
  WriteMask("cmd-roi/roi.png", 128, 96, 1);
  options.roi = "cmd-roi/roi.png";
  options.outputDirectory = "cmd-mask-empty";
  EXPECT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(options); }), xp::ExitBadInput);
  EXPECT_EQ(CountFiles("cmd-mask-empty"), 0);
  // An 8-bit grey PNG is an X-ray (a processed image); a colour PNG is not.
  options.roi.clear();
  options.xray = "cmd-mask-drr/drr_A_display.png";
  options.outputDirectory = "cmd-mask-8bit";
  ASSERT_EQ(std::system("rm -rf cmd-mask-8bit"), 0);
  EXPECT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(options); }), xp::ExitOk);
  vtkNew<vtkImageData> colour;
  colour->SetDimensions(128, 96, 1);
  colour->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  std::fill_n(static_cast<unsigned char*>(colour->GetScalarPointer()), 128 * 96 * 3, 100);
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputData(colour);
  writer->SetFileName("cmd-roi/colour.png");
  writer->Write();
  options.xray = "cmd-roi/colour.png";
  options.outputDirectory = "cmd-mask-colour";
  EXPECT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(options); }), xp::ExitBadInput);
}

TEST(Commands, SimulateWritesXRaysAndTruth)
{
  ASSERT_EQ(std::system("rm -rf cmd-sim"), 0);
  xp::SimulateOptions options;
  options.ct = PhantomCT();
  options.geometry = Geometry;
  options.size = "128x96";
  options.pose = "5,0,0,0,0,0";
  options.noise = 20.0;
  options.kvContrast = true;
  options.addObjects = true;
  options.outputDirectory = "cmd-sim";
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(options); }), xp::ExitOk);
  std::ifstream truth("cmd-sim/truth.json");
  const std::string text((std::istreambuf_iterator<char>(truth)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"misalignment\": {\"translation_mm\": [5.000000, 0.000000, 0.000000]"), std::string::npos) << text;
  EXPECT_NE(text.find("\"correction\": {\"translation_mm\": [-5.000000, "), std::string::npos) << text;
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName("cmd-sim/xray_A.png");
  reader->Update();
  double range[2];
  reader->GetOutput()->GetPointData()->GetScalars()->GetRange(range);
  EXPECT_LE(range[1], 4095.0);
  // The couch rail (columns 4-10 % of the width) is darker in the X-ray than anywhere in air.
  const auto* p = static_cast<const unsigned short*>(reader->GetOutput()->GetScalarPointer());
  EXPECT_LT(p[48 * 128 + 9], 600) << "rail";

  options.noise = -1.0;
  options.outputDirectory = "cmd-sim-bad";
  EXPECT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-sim-bad"));
}

namespace
{

std::string ReadText(const std::string& path)
{
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

/** The number after `"key": ` in `text` (first occurrence after `after`). */
/** The gate's failure codes of a record, as result.json names them. */
std::string FailureCodes(const xp::RegistrationRecord& record)
{
  std::string codes;
  for (const xp::GateFailure& failure : record.failures)
    codes += std::string(codes.empty() ? "" : ", ") + xp::GateCodeName(failure.code);
  return codes;
}

/** Simulated X-rays with noise and kV contrast (and X-ray-only objects) into `out`. */
xp::SimulateOptions KVSimulation(const std::string& ct, const std::string& pose, double noise, bool objects, const std::string& out)
{
  xp::SimulateOptions simulate;
  simulate.ct = ct;
  simulate.geometry = Geometry;
  simulate.pose = pose;
  simulate.noise = noise;
  simulate.kvContrast = true;
  simulate.addObjects = objects;
  simulate.outputDirectory = out;
  return simulate;
}

/** Imported imagers as the issue asks: names, sizes, sources and panel centres within 0.1 mm,
 *  row and column directions within 0.01 degree. */
void ExpectSameImagers(const xp::StereoGeometry& read, const xp::StereoGeometry& reference)
{
  ASSERT_EQ(read.views.size(), reference.views.size());
  for (size_t v = 0; v < read.views.size(); ++v)
  {
    const xp::XRayView &a = read.views[v], &b = reference.views[v];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.size, b.size);
    EXPECT_LT((a.source - b.source).norm(), 0.1);
    EXPECT_LT((a.detectorCenter - b.detectorCenter).norm(), 0.1);
    EXPECT_LT(std::acos(std::min(1.0, a.rowDirection.dot(b.rowDirection))) * 180.0 / M_PI, 0.01);
    EXPECT_LT(std::acos(std::min(1.0, a.columnDirection.dot(b.columnDirection))) * 180.0 / M_PI, 0.01);
  }
}

xp::RegisterOptions RegisterSimulated(const std::string& simulated, const std::string& out)
{
  xp::RegisterOptions options;
  options.ct = PhantomCT();
  options.geometry = Geometry;
  options.xrays = { simulated + "/xray_A.png", simulated + "/xray_B.png" };
  options.size = Eigen::Vector2i(256, 192);
  options.outputDirectory = out;
  return options;
}

} // namespace

namespace
{

/** The couch motion of `result` applied to the misalignment it estimated puts the target back
 *  within 0.01 mm, applied to the true one within 0.5 mm; the target is where the plan puts
 *  `targetInCT`. */
void ExpectTheCouchPutsTheTargetBack(const xp::RegistrationRecord& result, const xp::Pose& truth,
  const Eigen::Isometry3d& planned, const Eigen::Vector3d& targetInCT)
{
  ASSERT_TRUE(result.couch.has_value()) << "an ok result carries a couch motion";
  const xp::CouchMotion& couch = *result.couch;
  const Eigen::Vector3d target = planned * targetInCT, iso = Eigen::Vector3d::Zero();
  EXPECT_LT((couch.target - target).norm(), 1e-6) << couch.target.transpose() << " vs " << target.transpose();
  EXPECT_LT((couch.Transform() * (result.misalignment.ToTransform(iso) * target) - target).norm(), 0.01);
  EXPECT_LT((couch.Transform() * (truth.ToTransform(iso) * target) - target).norm(), 0.5);
}

} // namespace

TEST(Commands, RegisterRecoversASimulatedMisalignment)
{
  ASSERT_EQ(std::system("rm -rf cmd-reg-sim cmd-reg"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "5,-3,2,1,-1,1.5", 20.0, false, "cmd-reg-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-reg-sim", "cmd-reg");
  options.dicomOutputDirectory = "cmd-reg-dicom";
  // A 4-DOF couch, and a target 45 mm from the isocentre: the couch cannot pitch or roll.
  const xp::CTVolume volume = xp::ReadCTVolume(PhantomCT());
  const Eigen::Vector3d centre = xp::ImageCenter(volume.image);
  const Eigen::Vector3d targetInCT = centre + Eigen::Vector3d(30, -20, 25);
  options.couch.motions = "4dof";
  options.couch.target = targetInCT;
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  const xp::RegistrationRecord result = xp::ReadRegistrationRecord("cmd-reg/result.json");
  EXPECT_TRUE(result.ok) << FailureCodes(result);
  // By default the X-rays choose the CT's table: these, DRRs of the CT with its head rest and
  // couch top, choose it.
  ASSERT_TRUE(result.table.has_value());
  EXPECT_GT(result.table->tableCM3, 0.0);
  EXPECT_TRUE(result.table->keptTable) << result.table->withTable << " against " << result.table->bodyOnly;
  // Misalignment as simulated; the correction of a +5 mm lateral shift is about -5 mm.
  const Eigen::Vector3d t = result.misalignment.translation;
  EXPECT_NEAR(t[0], 5.0, 0.5);
  EXPECT_NEAR(t[1], -3.0, 0.5);
  EXPECT_NEAR(t[2], 2.0, 0.5);
  EXPECT_NEAR(result.misalignment.pitch, 1.0, 0.3);
  EXPECT_NEAR(result.misalignment.roll, -1.0, 0.3);
  EXPECT_NEAR(result.misalignment.yaw, 1.5, 0.3);
  const Eigen::Vector3d c = result.correction.translation;
  EXPECT_LT(c[0], -4.0) << "correction moves the patient back";
  for (const char* file : { "drr_A.png", "drr_B.png", "mask_A.png", "mask_B.png", "entropy_A.png" })
    EXPECT_TRUE(Exists(std::string("cmd-reg/") + file)) << file;

  // The DICOM Spatial Registration moves CT points where result.json's misalignment moves the
  // patient in the room (Coordinates.md, written out here), within 0.01 mm.
  const xp::CTSeriesInfo ct = xp::ScanCTSeries(PhantomCT());
  const Eigen::Isometry3d inCT = xp::ReadSpatialRegistrationMatrix("cmd-reg-dicom/reg.dcm", ct.frameOfReferenceUID);
  const Eigen::Isometry3d planned = xp::PlannedCTToRoom(xp::PatientPosition::HFS, centre, Eigen::Vector3d::Zero());
  ExpectTheCouchPutsTheTargetBack(result, xp::Pose::Parse("5,-3,2,1,-1,1.5", "truth"), planned, targetInCT);
  EXPECT_EQ(result.couch->motion.pitch, 0.0);
  EXPECT_EQ(result.couch->motion.roll, 0.0);
  EXPECT_EQ(result.couch->limitedBy, (std::vector<std::string>{ "no_pitch", "no_roll" }));
  EXPECT_NEAR(result.couch->uncorrected.pitch, result.misalignment.pitch, 0.1);
  const xp::Pose& m = result.misalignment;
  const double deg = M_PI / 180.0;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(m.yaw * deg, Eigen::Vector3d::UnitZ()) *
    Eigen::AngleAxisd(m.roll * deg, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(m.pitch * deg, Eigen::Vector3d::UnitX()))
                              .toRotationMatrix();
  for (const Eigen::Vector3d& offset : { Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(60, -40, 30), Eigen::Vector3d(-70, 50, -45) })
  {
    const Eigen::Vector3d p = centre + offset;
    const Eigen::Vector3d expected = R * (planned * p) + m.translation; // room isocentre at 0
    EXPECT_LT((planned * (inCT * p) - expected).norm(), 0.01) << offset.transpose();
  }

  // The DRRs as RT Images: `xpose geometry --dicom` gives the geometry file back from their tags
  // alone (sources and panel centres within 0.1 mm, directions within 0.01 degree).
  xp::GeometryOptions geometry;
  geometry.dicom = { "cmd-reg-dicom/drr_A.dcm", "cmd-reg-dicom/drr_B.dcm" };
  geometry.output = "cmd-reg-dicom-geometry.json";
  std::remove(geometry.output.c_str());
  ASSERT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(geometry); }), xp::ExitOk);
  const xp::StereoGeometry reference = xp::ReadStereoGeometry(Geometry), read = xp::ReadStereoGeometry(geometry.output);
  ExpectSameImagers(read, reference);
  // --check: the RT Images agree with the geometry file they were made for, not with their
  // imagers swapped.
  xp::GeometryOptions check;
  check.check = Geometry;
  check.dicom = geometry.dicom;
  EXPECT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(check); }), xp::ExitOk);
  std::swap(check.dicom[0], check.dicom[1]);
  EXPECT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(check); }), xp::ExitBadInput);
}

// Two frames of a moving patient: each registered from the previous result, one row each in
// poses.csv with the columns, both ok and near their truth; a frame with one X-ray is
// refused before any work.
TEST(Commands, TrackRegistersFrameAfterFrame)
{
  ASSERT_EQ(std::system("rm -rf cmd-track-1 cmd-track-2 cmd-track cmd-track-bad"), 0);
  const char* truths[2] = { "5,-3,2,1,-1,1.5", "6,-2,2.5,1.5,-1,1" };
  for (int f = 0; f < 2; ++f)
  {
    const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), truths[f], 20.0, false, "cmd-track-" + std::to_string(f + 1));
    ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  }
  xp::TrackOptions options;
  options.registration = RegisterSimulated("cmd-track-1", "unused");
  options.registration.xrays.clear();
  options.frames = { "cmd-track-1/xray_A.png,cmd-track-1/xray_B.png", "cmd-track-2/xray_A.png,cmd-track-2/xray_B.png" };
  options.outputDirectory = "cmd-track";
  options.registration.couch.motions = "4dof";
  ASSERT_EQ(xp::GuardedRun("track", [&] { return xp::RunTrack(options); }), xp::ExitOk);
  std::istringstream csv(ReadText("cmd-track/poses.csv"));
  std::string header, row;
  std::getline(csv, header);
  EXPECT_EQ(header, "frame,xray_a,xray_b,status,tx_mm,ty_mm,tz_mm,pitch_deg,roll_deg,yaw_deg,uncertainty_tx_mm,"
                    "uncertainty_ty_mm,uncertainty_tz_mm,uncertainty_pitch_deg,uncertainty_roll_deg,uncertainty_yaw_deg,time_s,"
                    "edge_distance_a_mm,edge_distance_moved_a_mm,edge_distance_b_mm,edge_distance_moved_b_mm,"
                    "couch_action,couch_tx_mm,couch_ty_mm,couch_tz_mm,couch_pitch_deg,couch_roll_deg,couch_yaw_deg,"
                    "uncorrected_pitch_deg,uncorrected_roll_deg,uncorrected_yaw_deg,couch_limited_by");
  int rows = 0;
  while (std::getline(csv, row))
  {
    std::vector<std::string> cells;
    std::stringstream in(row);
    for (std::string cell; std::getline(in, cell, ',');)
      cells.push_back(cell);
    ASSERT_EQ(cells.size(), 32u) << row;
    EXPECT_EQ(cells[3], "ok") << row;
    EXPECT_EQ(cells[21], "move") << row;
    EXPECT_EQ(cells[25], "0") << row << ": a 4-DOF couch does not pitch";
    EXPECT_NEAR(std::stod(cells[28]), std::stod(cells[7]), 0.2) << row << ": the pitch stays uncorrected";
    EXPECT_EQ(cells[31], "no_pitch no_roll") << row;
    // Each view's DRR edges lie on the X-ray's, no farther than when moved 3 mm, and closer over
    // both views (the medians come in whole pixels of 1.04 mm here: a view whose X-ray edges lie
    // within a pixel of any moved edge ties).
    EXPECT_LE(std::stod(cells[17]), std::stod(cells[18])) << row;
    EXPECT_LE(std::stod(cells[19]), std::stod(cells[20])) << row;
    EXPECT_LT(std::stod(cells[17]) + std::stod(cells[19]), std::stod(cells[18]) + std::stod(cells[20])) << row;
    EXPECT_GE(std::stod(cells[17]), 0.0) << row;
    const xp::Pose truth = xp::Pose::Parse(truths[rows], "truth");
    EXPECT_NEAR(std::stod(cells[4]), truth.translation[0], 0.5) << row;
    EXPECT_NEAR(std::stod(cells[6]), truth.translation[2], 0.5) << row;
    EXPECT_NEAR(std::stod(cells[9]), truth.yaw, 0.3) << row;
    ++rows;
  }
  EXPECT_EQ(rows, 2);
  EXPECT_TRUE(Exists("cmd-track/poses.json"));
  // The second frame started where the first ended.
  const xp::RegistrationRecord first = xp::ReadRegistrationRecord("cmd-track/frame-0001/result.json");
  const xp::RegistrationRecord second = xp::ReadRegistrationRecord("cmd-track/frame-0002/result.json");
  EXPECT_LT((second.initialPose.translation - first.misalignment.translation).norm(), 1e-6);
  const std::string json = ReadText("cmd-track/poses.json");
  EXPECT_NE(json.find("\"start\" : \"planned set-up\""), std::string::npos) << json;
  EXPECT_NE(json.find("\"start\" : \"previous frame\""), std::string::npos) << json;
  // Each frame's record places the CT in the room: the head moved between the two truths by
  // what the two results say (1 mm along x, 1 along y, 0.5 along z, at the isocentre).
  ASSERT_TRUE(first.volumeToRoom && second.volumeToRoom);
  const Eigen::Vector3d firstCenter = *first.volumeToRoom * first.volumeCenter;
  const Eigen::Vector3d secondCenter = *second.volumeToRoom * second.volumeCenter;
  EXPECT_NEAR((secondCenter - firstCenter).x(), 1.0, 0.3);
  EXPECT_NEAR((secondCenter - firstCenter).y(), 1.0, 0.3);
  xp::RelativeOptions relative;
  relative.reference = { "cmd-track/frame-0001/result.json", "cmd-track/frame-0002/result.json" };
  relative.moving = relative.reference;
  EXPECT_EQ(xp::GuardedRun("relative", [&] { return xp::RunRelative(relative); }), xp::ExitOk);
  relative.moving.pop_back();
  EXPECT_EQ(xp::GuardedRun("relative", [&] { return xp::RunRelative(relative); }), xp::ExitBadInput);

  options.frames = { "cmd-track-1/xray_A.png", "cmd-track-2/xray_A.png,cmd-track-2/xray_B.png" };
  options.outputDirectory = "cmd-track-bad";
  EXPECT_EQ(xp::GuardedRun("track", [&] { return xp::RunTrack(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-track-bad/poses.csv"));
}

TEST(Commands, RegisterRefusesImagesOfSomethingElse)
{
  // X-rays that show no patient like the CT (smooth random texture): status failed, exit 3.
  ASSERT_EQ(std::system("rm -rf cmd-reg-other cmd-reg-failed && mkdir cmd-reg-other"), 0);
  std::mt19937 random(5);
  std::uniform_real_distribution<double> phase(0.0, 6.28);
  for (const char* name : { "A", "B" })
  {
    vtkNew<vtkImageData> image;
    image->SetDimensions(1024, 768, 1);
    image->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
    auto* p = static_cast<unsigned short*>(image->GetScalarPointer());
    const double a = phase(random), b = phase(random);
    for (int y = 0; y < 768; ++y)
      for (int x = 0; x < 1024; ++x)
        p[y * 1024 + x] = static_cast<unsigned short>(2000 + 900 * std::sin(x * 0.021 + a) * std::cos(y * 0.034 + b) +
          400 * std::sin((x + y) * 0.05));
    vtkNew<vtkPNGWriter> writer;
    writer->SetInputData(image);
    writer->SetFileName((std::string("cmd-reg-other/xray_") + name + ".png").c_str());
    writer->Write();
  }
  xp::RegisterOptions options = RegisterSimulated("cmd-reg-other", "cmd-reg-failed");
  options.dicomOutputDirectory = "cmd-reg-failed-dicom";
  ASSERT_EQ(std::system("rm -rf cmd-reg-failed-dicom"), 0);
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitRegistrationFailed);
  EXPECT_FALSE(Exists("cmd-reg-failed-dicom/reg.dcm")) << "a failed result is never written as a REG";
  EXPECT_TRUE(Exists("cmd-reg-failed-dicom/drr_A.dcm")) << "the reference DRRs are written all the same";
  const xp::RegistrationRecord result = xp::ReadRegistrationRecord("cmd-reg-failed/result.json");
  EXPECT_FALSE(result.ok);
  EXPECT_FALSE(result.failures.empty()) << "a failure says why";
}

// X-rays read out binned: xpose's own RT Images at 512x384 register with the 1024x768 geometry
// that made them (the panel's extent kept, its spacing doubled); a size that is no whole
// fraction of the panel is refused, naming both sizes.
TEST(Commands, BinnedXRaysRegisterWithTheirPanelsGeometry)
{
  ASSERT_EQ(std::system("rm -rf cmd-binned-drr cmd-binned-dicom cmd-binned-reg cmd-binned-odd cmd-binned-odd-reg"), 0);
  xp::DRROptions drr = SmallDRR("cmd-binned-drr");
  drr.size = "512x384";
  drr.pose = "3,-2,1,1,0.5,-1";
  drr.dicomOutputDirectory = "cmd-binned-dicom";
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-binned-dicom", "cmd-binned-reg");
  options.xrays = { "cmd-binned-dicom/drr_A.dcm", "cmd-binned-dicom/drr_B.dcm" };
  testing::internal::CaptureStdout();
  const int code = xp::GuardedRun("register", [&] { return xp::RunRegister(options); });
  const std::string output = testing::internal::GetCapturedStdout();
  ASSERT_EQ(code, xp::ExitOk) << output;
  EXPECT_NE(output.find("binned 2x2"), std::string::npos) << output;
  const xp::RegistrationRecord result = xp::ReadRegistrationRecord("cmd-binned-reg/result.json");
  EXPECT_LT((result.misalignment.translation - Eigen::Vector3d(3, -2, 1)).norm(), 0.5) << result.misalignment.ToString();
  EXPECT_NEAR(result.misalignment.pitch, 1.0, 0.3);

  // 600x450 of a 1024x768 panel: no binning gives it.
  vtkNew<vtkImageData> odd;
  odd->SetDimensions(600, 450, 1);
  odd->AllocateScalars(VTK_UNSIGNED_SHORT, 1);
  std::fill_n(static_cast<uint16_t*>(odd->GetScalarPointer()), 600 * 450, uint16_t(2000));
  std::filesystem::create_directories("cmd-binned-odd");
  xp::WritePNG(odd, "cmd-binned-odd/a.png");
  xp::WritePNG(odd, "cmd-binned-odd/b.png");
  options = RegisterSimulated("cmd-binned-odd", "cmd-binned-odd-reg");
  options.xrays = { "cmd-binned-odd/a.png", "cmd-binned-odd/b.png" };
  testing::internal::CaptureStderr();
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  const std::string error = testing::internal::GetCapturedStderr();
  EXPECT_NE(error.find("cmd-binned-odd/a.png"), std::string::npos) << error;
  EXPECT_NE(error.find("600x450"), std::string::npos) << error;
  EXPECT_NE(error.find("1024x768"), std::string::npos) << error;
  EXPECT_FALSE(Exists("cmd-binned-odd-reg"));
}

TEST(Commands, RegisterBadInputExitsWithTwo)
{
  xp::RegisterOptions options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
  options.xrays.pop_back();
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << "one X-ray";
  options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << "missing files";
  options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
  options.size = Eigen::Vector2i(300, 200);
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << "size";
  options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
  options.optimizer = "nelder-mead/simplex";
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << "optimiser";
  options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
  options.device = "gpu";
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << "device";
  // The couch's options, each refused by name before any work.
  for (const auto& [option, set] : std::vector<std::pair<std::string, std::function<void(xp::RegisterOptions&)>>>{
         { "--couch", [](xp::RegisterOptions& o) { o.couch.motions = "5dof"; } },
         { "--couch-rotation-limit", [](xp::RegisterOptions& o) { o.couch.rotationLimit = "-1"; } },
         { "--couch-rotation-limit", [](xp::RegisterOptions& o) { o.couch.rotationLimit = "3deg"; } },
         { "--action-level-mm", [](xp::RegisterOptions& o) { o.couch.levels.actionMM = -1; } },
         { "--max-uncorrected-deg", [](xp::RegisterOptions& o) { o.couch.levels.maxUncorrectedDegrees = std::nan(""); } } })
  {
    options = RegisterSimulated("cmd-no-such", "cmd-reg-bad");
    set(options);
    testing::internal::CaptureStderr();
    EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput) << option;
    const std::string error = testing::internal::GetCapturedStderr();
    EXPECT_NE(error.find(option), std::string::npos) << error;
  }
  EXPECT_FALSE(Exists("cmd-reg-bad"));
}

// The GPU casts trilinear rays on the voxel planes only: Siddon with --device cuda is refused on
// any machine, with auto it runs on the CPU, and a device that is no device is refused with it too.
TEST(Commands, DRRDeviceRefusesWhatTheGPUCannotCast)
{
  ASSERT_EQ(std::system("rm -rf cmd-dev-siddon"), 0);
  xp::DRROptions drr = SmallDRR("cmd-dev-siddon");
  drr.method = "siddon";
  for (const char* device : { "cuda", "gpu" })
  {
    drr.device = device;
    testing::internal::CaptureStderr();
    EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitBadInput) << device;
    const std::string error = testing::internal::GetCapturedStderr();
    EXPECT_NE(error.find("--device"), std::string::npos) << error;
    EXPECT_FALSE(Exists("cmd-dev-siddon")) << device;
  }
  drr.device = "auto";
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  EXPECT_TRUE(Exists("cmd-dev-siddon/drr_A.png"));
}

// --device cuda where no GPU can run it is refused before any work, naming the option and why;
// auto says that it runs on the CPU and does; result.json says where the rays were cast.
TEST(Commands, DeviceOptionRefusesAMissingGPUAndRecordsWhereItRan)
{
  std::string reason;
  if (xp::cuda::Available(&reason))
    GTEST_SKIP() << "a GPU is present: cuda is not refused here";
  ASSERT_EQ(std::system("rm -rf cmd-dev-sim cmd-dev cmd-dev-drr"), 0);
  xp::DRROptions drr = SmallDRR("cmd-dev-drr");
  drr.device = "cuda";
  testing::internal::CaptureStderr();
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitBadInput);
  const std::string error = testing::internal::GetCapturedStderr();
  EXPECT_NE(error.find("--device"), std::string::npos) << error;
  EXPECT_NE(error.find(reason), std::string::npos) << error;
  EXPECT_FALSE(Exists("cmd-dev-drr"));
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "2,-1,1,0.5,0,0.5", 20.0, false, "cmd-dev-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-dev-sim", "cmd-dev");
  options.device = "cuda";
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-dev"));
  options.device = "auto";
  testing::internal::CaptureStdout();
  const int code = xp::GuardedRun("register", [&] { return xp::RunRegister(options); });
  const std::string console = testing::internal::GetCapturedStdout();
  EXPECT_EQ(code, xp::ExitOk) << console;
  EXPECT_NE(console.find("device: no GPU used: " + reason), std::string::npos) << console;
  EXPECT_EQ(xp::ReadRegistrationRecord("cmd-dev/result.json").device, "cpu");
}

TEST(Commands, WithXRayOnlyObjectsTheMaskedRunIsAtLeastAsAccurate)
{
  ASSERT_EQ(std::system("rm -rf cmd-obj-sim cmd-obj-masked cmd-obj-unmasked"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "6,4,-5,-2,1.5,2.5", 20.0, true, "cmd-obj-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  double error[2];
  for (int masked = 0; masked < 2; ++masked)
  {
    xp::RegisterOptions options = RegisterSimulated("cmd-obj-sim", masked ? "cmd-obj-masked" : "cmd-obj-unmasked");
    options.settings.entropyMask = masked;
    xp::GuardedRun("register", [&] { return xp::RunRegister(options); });
    const xp::RegistrationRecord result = xp::ReadRegistrationRecord(options.outputDirectory + "/result.json");
    error[masked] = (result.misalignment.translation - Eigen::Vector3d(6, 4, -5)).cwiseAbs().maxCoeff();
    if (masked)
    {
      EXPECT_TRUE(result.ok) << FailureCodes(result);
    }
  }
  std::printf("largest axis error with X-ray-only objects: masked %.3f mm, unmasked %.3f mm\n", error[1], error[0]);
  // Since MI bins ranked levels (xpImageLevels.h), the objects no longer pull the whole-image run
  // either: both are accurate, and the masks (with less of the image) may cost at most 0.1 mm.
  EXPECT_LE(error[1], error[0] + 0.1) << "the masked run must be about as accurate (to 0.1 mm)";
  EXPECT_LT(error[1], 0.3);
  EXPECT_LT(error[0], 0.3);
}

TEST(Commands, RealPelvisRegistrationAndADifferentPatient)
{
  if (!Exists(SharedPelvis))
  {
    GTEST_SKIP() << "shared pelvis CT not found at " << SharedPelvis << " (../shared/data beside the project)";
  }
  ASSERT_EQ(std::system("rm -rf cmd-pel-sim cmd-pel-reg cmd-pel-other"), 0);
  const xp::SimulateOptions simulate = KVSimulation(SharedPelvis, "7,-5,4,2,-1.5,2.5", 30.0, true, "cmd-pel-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-pel-sim", "cmd-pel-reg");
  options.ct = SharedPelvis;
  // The pelvis resolution: at 256x192 (1.6 mm pixels at the panel) this case ends 0.53 mm
  // along the roll/lateral valley, at 512x384 0.27 mm.
  options.size = Eigen::Vector2i(512, 384);
  // A 6-DOF top that pitches and rolls at most 1 degree, about its own point below the patient.
  options.couch.rotationLimit = "1";
  options.geometry = "cmd-pel-room.json";
  {
    xp::StereoGeometry room = xp::ReadStereoGeometry(Geometry);
    room.couch = xp::CouchDescription{};
    room.couch->rotationCenter = Eigen::Vector3d(0, -300, -250);
    xp::WriteStereoGeometry(room, options.geometry);
  }
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  const xp::RegistrationRecord result = xp::ReadRegistrationRecord("cmd-pel-reg/result.json");
  EXPECT_LT((result.misalignment.translation - Eigen::Vector3d(7, -5, 4)).cwiseAbs().maxCoeff(), 0.5)
    << result.misalignment.ToString();
  EXPECT_NEAR(result.misalignment.yaw, 2.5, 0.2);
  const xp::CTVolume pelvis = xp::ReadCTVolume(SharedPelvis);
  const Eigen::Vector3d centre = xp::ImageCenter(pelvis.image);
  ExpectTheCouchPutsTheTargetBack(result, xp::Pose::Parse("7,-5,4,2,-1.5,2.5", "truth"),
    xp::PlannedCTToRoom(xp::PatientPosition::HFS, centre, Eigen::Vector3d::Zero()), centre);
  EXPECT_NEAR(result.couch->motion.pitch, -1.0, 1e-6) << "the correction's -2 degrees clipped";
  EXPECT_NEAR(result.couch->motion.roll, 1.0, 1e-6) << "the correction's +1.5 degrees clipped";
  EXPECT_EQ(result.couch->limitedBy, (std::vector<std::string>{ "pitch_limit", "roll_limit" }));
  EXPECT_EQ(result.couch->rotationCenter, Eigen::Vector3d(0, -300, -250));

  // The pelvis X-rays against the head phantom's CT: another patient, so the result must fail.
  options = RegisterSimulated("cmd-pel-sim", "cmd-pel-other");
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitRegistrationFailed);
  EXPECT_FALSE(xp::ReadRegistrationRecord("cmd-pel-other/result.json").ok);
  EXPECT_FALSE(xp::ReadRegistrationRecord("cmd-pel-other/result.json").couch.has_value()) << "no couch motion for a failed result";
}

namespace
{

/** Reads a PNG; returns the standard deviation of its first channel (0 for an unreadable file). */
double PNGContrast(const std::string& path, int* width = nullptr)
{
  vtkNew<vtkPNGReader> reader;
  if (!reader->CanReadFile(path.c_str()))
    return 0.0;
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkImageData* image = reader->GetOutput();
  if (width)
    *width = image->GetDimensions()[0];
  vtkDataArray* values = image->GetPointData()->GetScalars();
  double sum = 0.0, squares = 0.0;
  const vtkIdType n = values->GetNumberOfTuples();
  for (vtkIdType i = 0; i < n; ++i)
  {
    const double v = values->GetComponent(i, 0);
    sum += v;
    squares += v * v;
  }
  return n > 0 ? std::sqrt(std::max(0.0, squares / n - (sum / n) * (sum / n))) : 0.0;
}

std::vector<std::string> ReportPictures()
{
  std::vector<std::string> files{ "convergence.png", "summary.png" };
  for (const char* view : { "A", "B" })
    for (const char* kind : { "xray", "drr_start", "drr_final", "checkerboard", "blend", "edges", "entropy", "mask", "roi",
           "masked_xray" })
      files.push_back(std::string("view_") + view + "_" + kind + ".png");
  return files;
}

} // namespace

TEST(Commands, RegisterWritesAReportThatReportRebuilds)
{
  ASSERT_EQ(std::system("rm -rf cmd-report-sim cmd-report cmd-report-again"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "4,-2,3,1,0.5,-1", 20.0, true, "cmd-report-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-report-sim", "cmd-report");
  options.reportDirectory = "cmd-report/report";
  options.dicomOutputDirectory = "cmd-report/dicom";
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  // With --dicom-out the summary goes beside the REG as a Secondary Capture of the same picture.
  const std::string secondaryCapture = ReadText("cmd-report/dicom/report.dcm");
  EXPECT_NE(secondaryCapture.find("1.2.840.10008.5.1.4.1.1.7"), std::string::npos) << "a Secondary Capture";
  EXPECT_GT(secondaryCapture.size(), 1000u * 600u * 3u) << "the summary's RGB pixels";

  for (const std::string& file : ReportPictures())
  {
    const std::string path = "cmd-report/report/" + file;
    EXPECT_GT(PNGContrast(path), 5.0) << path << " is missing, unreadable or blank";
  }
  int summaryWidth = 0;
  PNGContrast("cmd-report/report/summary.png", &summaryWidth);
  EXPECT_GE(summaryWidth, 1000);
  EXPECT_GT(PNGContrast("cmd-report/report/scene3d.png"), 5.0) << "the 3D scene (Xvfb started by xpose when no display)";
  const std::string html = ReadText("cmd-report/report/index.html");
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("</html>"), std::string::npos);
  EXPECT_NE(html.find("6-DOF correction"), std::string::npos);
  EXPECT_NE(html.find("<h2>Couch</h2>"), std::string::npos) << "an ok result's couch panel";
  EXPECT_NE(html.find("couch motion"), std::string::npos);
  for (const std::string& file : ReportPictures())
    if (file != "summary.png")
      EXPECT_NE(html.find("src=\"" + file + "\""), std::string::npos) << file << " is not on the page";

  // `xpose report` rebuilds it from result.json; with no display and no Xvfb it warns, skips the
  // 3D scene and still writes the rest.
  const char* display = std::getenv("DISPLAY");
  const std::string savedDisplay = display ? display : "", savedPath = std::getenv("PATH");
  unsetenv("DISPLAY");
  setenv("PATH", "/nonexistent", 1);
  xp::ReportOptions report;
  report.result = "cmd-report/result.json";
  report.outputDirectory = "cmd-report-again";
  const int code = xp::GuardedRun("report", [&] { return xp::RunReport(report); });
  setenv("PATH", savedPath.c_str(), 1);
  if (display)
    setenv("DISPLAY", savedDisplay.c_str(), 1);
  ASSERT_EQ(code, xp::ExitOk);
  for (const std::string& file : ReportPictures())
    EXPECT_GT(PNGContrast("cmd-report-again/" + file), 5.0) << file;
  EXPECT_FALSE(Exists("cmd-report-again/scene3d.png"));
  EXPECT_NE(ReadText("cmd-report-again/index.html").find("3D scene was not rendered"), std::string::npos);

  // A result.json without what the report needs: exit 2, naming the field, nothing written.
  std::ofstream("cmd-report/broken.json") << "{\"status\": \"ok\"}";
  report.result = "cmd-report/broken.json";
  report.outputDirectory = "cmd-report-broken";
  EXPECT_EQ(xp::GuardedRun("report", [&] { return xp::RunReport(report); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-report-broken"));
}

TEST(Commands, SmallSeededEvaluationWritesConsistentFilesAndResumes)
{
  ASSERT_EQ(std::system("rm -rf cmd-evaluate"), 0);
  xp::EvaluateOptions options;
  options.ct = PhantomCT();
  options.geometry = Geometry;
  options.trials = 2;
  options.maxTranslation = 8.0;
  options.maxRotation = 2.0;
  options.size = "128x96";
  options.scenario = "objects";
  options.seed = 7;
  options.outputDirectory = "cmd-evaluate";
  ASSERT_EQ(xp::GuardedRun("evaluate", [&] { return xp::RunEvaluate(options); }), xp::ExitOk);
  for (const char* file : { "trials.csv", "summary.json", "evaluation.json" })
    EXPECT_TRUE(Exists(std::string("cmd-evaluate/") + file)) << file;
  for (const char* plot : { "final_error.png", "time.png", "capture_range.png" })
    EXPECT_GT(PNGContrast(std::string("cmd-evaluate/") + plot), 5.0) << plot;

  // trials.csv: the header, one row per trial and approach, success only below 1 mm with status ok.
  std::ifstream csv("cmd-evaluate/trials.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("trial,approach,scenario,initial_tx", 0), 0u);
  const int columns = static_cast<int>(std::count(header.begin(), header.end(), ',')) + 1;
  const auto columnOf = [&](const std::string& name)
  { return static_cast<int>(std::count(header.begin(), header.begin() + header.find("," + name + ","), ',')) + 1; };
  ASSERT_NE(header.find(",valid_pixels,end_face_excess_min,end_face_excess_max,end_faces_left_out,"), std::string::npos);
  const int validColumn = columnOf("valid_pixels"), leftOutColumn = columnOf("end_faces_left_out");
  // Each trial's evaluations, and the same by what they served: they add up.
  const int evaluationsColumn = columnOf("evaluations"), searchColumn = columnOf("search_evaluations");
  ASSERT_NE(header.find(",evaluations,search_evaluations,refinement_evaluations,second_end_evaluations,polish_evaluations,"
                        "gate_evaluations,"), std::string::npos) << header;
  int rows = 0;
  while (std::getline(csv, line))
  {
    ++rows;
    std::vector<std::string> f;
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');)
      f.push_back(field);
    if (!line.empty() && line.back() == ',')
      f.emplace_back();
    ASSERT_EQ(static_cast<int>(f.size()), columns) << line;
    EXPECT_TRUE(f[1] == "A" || f[1] == "B");
    EXPECT_EQ(f[2], "objects");
    EXPECT_GT(std::stoll(f[validColumn]), 2048) << "the phantom's views keep thousands of pixels";
    int served = 0;
    for (int c = searchColumn; c < searchColumn + 5; ++c)
      served += std::stoi(f[c]);
    EXPECT_EQ(served, std::stoi(f[evaluationsColumn])) << line;
    EXPECT_GT(std::stoi(f[searchColumn]), 0) << "every registration searches";
    EXPECT_GT(std::stoi(f[searchColumn + 1]), 0) << "and refines";
    const int leftOut = std::stoi(f[leftOutColumn]);
    EXPECT_TRUE(leftOut >= 0 && leftOut <= 4) << "two faces of two views";
    const double initial = std::stod(f[9]), mtre = std::stod(f[18]);
    EXPECT_GE(initial, 1.0);
    EXPECT_LE(initial, 8.0);
    if (f[19] == "1")
    {
      EXPECT_EQ(f[11], "ok");
      EXPECT_LT(mtre, 1.0);
    }
    else
    {
      EXPECT_TRUE(f[11] != "ok" || mtre >= 1.0) << "a trial below 1 mm with status ok is a success: " << line;
    }
  }
  EXPECT_EQ(rows, 4);
  const std::string summary = ReadText("cmd-evaluate/summary.json");
  for (const char* key : { "\"A\"", "\"B\"", "\"success_rate\"", "\"bands_mm\"", "\"goals_B\"", "\"time_s\"", "\"mtre_mm\"" })
    EXPECT_NE(summary.find(key), std::string::npos) << key;

  // Resuming with the same options registers nothing again; other options are refused.
  ASSERT_EQ(xp::GuardedRun("evaluate", [&] { return xp::RunEvaluate(options); }), xp::ExitOk);
  std::ifstream again("cmd-evaluate/trials.csv");
  EXPECT_EQ(std::count(std::istreambuf_iterator<char>(again), std::istreambuf_iterator<char>(), '\n'), 5);
  // The same CT named another way (absolute, through "/.") is the same run.
  options.ct = std::filesystem::absolute(options.ct).string() + "/.";
  EXPECT_EQ(xp::GuardedRun("evaluate", [&] { return xp::RunEvaluate(options); }), xp::ExitOk);
  options.seed = 8;
  EXPECT_EQ(xp::GuardedRun("evaluate", [&] { return xp::RunEvaluate(options); }), xp::ExitBadInput);
}

// --- Reliability (issue 17): bad input ends with exit 2 before any work, never with `ok`. ---

TEST(Commands, NonFiniteOrNegativeGateLimitsAreRefused)
{
  // Real X-rays: without the checks these would register (exit 0 or 3), not exit 2.
  ASSERT_EQ(std::system("rm -rf cmd-limits-sim cmd-reg-limits"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "2,1,0,0,0,0", 10.0, false, "cmd-limits-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  const xp::RegisterOptions good = RegisterSimulated("cmd-limits-sim", "cmd-reg-limits");
  for (const auto& [translation, rotation] : { std::make_pair(std::nan(""), 10.0), std::make_pair(50.0, std::nan("")),
         std::make_pair(-1.0, 10.0), std::make_pair(50.0, -2.0), std::make_pair(HUGE_VAL, 10.0) })
  {
    xp::RegisterOptions options = good;
    options.settings.maxTranslation = translation;
    options.settings.maxRotation = rotation;
    EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput)
      << translation << " mm, " << rotation << " degrees";
  }
  EXPECT_FALSE(Exists("cmd-reg-limits"));
}

TEST(Commands, TheTranslationLimitIsOnTheVectorLength)
{
  // Simulated (5, -3, 2) mm: 6.2 mm long, 5 mm on its largest axis. A 5.5 mm limit passed it per axis.
  ASSERT_EQ(std::system("rm -rf cmd-len-sim cmd-len"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "5,-3,2,1,-1,1.5", 20.0, false, "cmd-len-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-len-sim", "cmd-len");
  options.settings.maxTranslation = 5.5;
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitRegistrationFailed);
  const xp::RegistrationRecord result = xp::ReadRegistrationRecord("cmd-len/result.json");
  EXPECT_FALSE(result.ok);
  EXPECT_EQ(FailureCodes(result), "translation_too_large");
  EXPECT_NE(result.failures.front().message.find("exceeds 5.5 mm"), std::string::npos) << result.failures.front().message;
}

TEST(Commands, UnwritableOutputsAndTheSameXRayTwiceAreRefusedBeforeTheWork)
{
  ASSERT_EQ(std::system("rm -rf cmd-early-sim cmd-early cmd-early-file && touch cmd-early-file"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "2,1,0,0,0,0", 10.0, false, "cmd-early-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  xp::RegisterOptions options = RegisterSimulated("cmd-early-sim", "cmd-early");
  options.reportDirectory = "cmd-early-file"; // a file, not a folder
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-early/result.json")) << "no result may be written when the report cannot be";
  options = RegisterSimulated("cmd-early-sim", "cmd-early-file/out");
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  options = RegisterSimulated("cmd-early-sim", "cmd-early");
  options.xrays[1] = options.xrays[0];
  EXPECT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-early"));
}

TEST(Commands, ARerunReplacesEveryOutputAndReportChecksTheXRays)
{
  ASSERT_EQ(std::system("rm -rf cmd-rerun-sim cmd-rerun && mkdir cmd-rerun && touch cmd-rerun/entropy_Z.png "
                        "cmd-rerun/mask_Z.png cmd-rerun/notes.txt"), 0);
  const xp::SimulateOptions simulate = KVSimulation(PhantomCT(), "3,-2,1,0,0,1", 10.0, false, "cmd-rerun-sim");
  ASSERT_EQ(xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); }), xp::ExitOk);
  const xp::RegisterOptions options = RegisterSimulated("cmd-rerun-sim", "cmd-rerun");
  ASSERT_EQ(xp::GuardedRun("register", [&] { return xp::RunRegister(options); }), xp::ExitOk);
  EXPECT_FALSE(Exists("cmd-rerun/entropy_Z.png")) << "an earlier run's image was left beside this run's result";
  EXPECT_FALSE(Exists("cmd-rerun/mask_Z.png"));
  EXPECT_TRUE(Exists("cmd-rerun/notes.txt")) << "files xpose does not write are the user's";
  ASSERT_TRUE(xp::ReadRegistrationRecord("cmd-rerun/result.json").inputs.has_value());
  EXPECT_EQ(xp::ReadRegistrationRecord("cmd-rerun/result.json").inputs->xrayMD5.size(), 2u);
  // The X-ray changes after the registration: the report would show other images, so it refuses.
  ASSERT_EQ(std::system("cp cmd-rerun-sim/xray_B.png cmd-rerun-sim/xray_A.png"), 0);
  xp::ReportOptions report;
  report.result = "cmd-rerun/result.json";
  report.outputDirectory = "cmd-rerun-report";
  EXPECT_EQ(xp::GuardedRun("report", [&] { return xp::RunReport(report); }), xp::ExitBadInput);
}

TEST(Commands, WorkBeyondReasonAndClampedOptionsAreRefused)
{
  xp::DRROptions drr = SmallDRR("cmd-step");
  drr.stepSize = 1e-9;
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitBadInput) << "a step that never ends";
  drr.stepSize = 0.05; // finer than 1/16 of the 3 mm voxels
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitBadInput);
  drr.stepSize = std::nan("");
  EXPECT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-step"));
  drr.stepSize = 0.0;
  ASSERT_EQ(xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); }), xp::ExitOk);
  xp::MaskOptions mask; // a real X-ray: without the checks the filter would clamp and succeed
  mask.xray = "cmd-step/drr_A.png";
  mask.outputDirectory = "cmd-mask-window";
  mask.window = 100;
  EXPECT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(mask); }), xp::ExitBadInput);
  mask.window = 7;
  mask.binWidth = 0;
  EXPECT_EQ(xp::GuardedRun("mask", [&] { return xp::RunMask(mask); }), xp::ExitBadInput);
  EXPECT_FALSE(Exists("cmd-mask-window"));
}

TEST(Commands, GeometryFromProjectionMatricesRoundTripsTheReferenceGeometry)
{
  // The reference geometry's imagers as projection matrices (as a calibration would give them,
  // at an arbitrary scale), back through `xpose geometry`: sources and panel centres within
  // 0.1 mm, directions within 0.01 degree.
  const xp::StereoGeometry reference = xp::ReadStereoGeometry(Geometry);
  xp::GeometryOptions options;
  for (const xp::XRayView& view : reference.views)
  {
    const std::string file = "cmd-geometry-P_" + view.name + ".txt";
    std::ofstream out(file);
    out.precision(17);
    out << "# " << view.name << "\n" << 3.5 * xp::ProjectionMatrixOf(view) << "\n";
    options.projectionMatrices.push_back(file);
    options.names.push_back(view.name);
  }
  options.pixelSpacing = std::to_string(reference.views[0].pixelSpacing[0]);
  options.size = std::to_string(reference.views[0].Columns()) + "x" + std::to_string(reference.views[0].Rows());
  options.output = "cmd-geometry.json";
  std::remove(options.output.c_str());
  ASSERT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(options); }), xp::ExitOk);
  const xp::StereoGeometry read = xp::ReadStereoGeometry(options.output);
  ExpectSameImagers(read, reference);
  // The same imagers as pinhole calibrations: K in pixels, [R | t] from Room to camera.
  xp::GeometryOptions pinhole = options;
  pinhole.projectionMatrices.clear();
  for (const xp::XRayView& view : reference.views)
  {
    Eigen::Matrix3d rotation; // rows: the panel's row and column directions, source to panel
    rotation << view.rowDirection.transpose(), view.columnDirection.transpose(), -view.NormalTowardsSource().transpose();
    Eigen::Matrix<double, 3, 4> rt;
    rt << rotation, -rotation * view.source;
    const Eigen::Matrix3d intrinsics = xp::ProjectionMatrixOf(view).leftCols<3>() * rotation.transpose();
    const std::string k = "cmd-geometry-K_" + view.name + ".txt", e = "cmd-geometry-Rt_" + view.name + ".txt";
    std::ofstream(k) << std::setprecision(17) << intrinsics << "\n";
    std::ofstream(e) << std::setprecision(17) << rt << "\n";
    pinhole.intrinsics.push_back(k);
    pinhole.extrinsics.push_back(e);
  }
  std::remove(options.output.c_str());
  ASSERT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(pinhole); }), xp::ExitOk);
  const xp::StereoGeometry fromPinhole = xp::ReadStereoGeometry(options.output);
  ExpectSameImagers(fromPinhole, reference);
  xp::GeometryOptions both = pinhole;
  both.projectionMatrices = options.projectionMatrices;
  EXPECT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(both); }), xp::ExitBadInput) << "one source only";

  // Bad input: a name short, a spacing whose ratio P contradicts; exit 2 and no file written.
  std::remove(options.output.c_str());
  xp::GeometryOptions bad = options;
  bad.names.pop_back();
  EXPECT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(bad); }), xp::ExitBadInput);
  bad = options;
  bad.pixelSpacing += ",0.5";
  EXPECT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(bad); }), xp::ExitBadInput);
  struct stat info;
  EXPECT_NE(stat(options.output.c_str(), &info), 0) << "nothing written";
}

// The real wrist set through the user's path: `xpose geometry --camera-calibration` and the
// TIFF reader. Twelve skin-marker dots on the forearm, found in frame 158 of both cameras (file
// pixels, column from the left, row from the top; dark local minima), must meet as rays
// through the geometry's views (their closest approach within 0.5 mm, each reprojected within
// one pixel), and the X-rays as read must show each dot where its pixel says. A flipped row or
// column axis of the import or of the reader moves the rays apart by millimetres and the dots
// off their pixels.
TEST(Commands, WristCalibrationsMeetAtTheMarkersOfBothViews)
{
  const std::string wrist = std::string(XP_SHARED_DATA_DIR) + "/real-biplane-wrist/";
  if (!Exists(wrist + "xr_calib_wrist_cam01.txt"))
  {
    GTEST_SKIP() << "shared wrist set not found at " << wrist << " (../shared/data beside the project)";
  }
  xp::GeometryOptions options;
  options.cameraCalibrations = { wrist + "xr_calib_wrist_cam01.txt", wrist + "xr_calib_wrist_cam02.txt" };
  options.pixelSpacing = "0.2";
  options.output = "cmd-wrist-geometry.json";
  std::remove(options.output.c_str());
  ASSERT_EQ(xp::GuardedRun("geometry", [&] { return xp::RunGeometry(options); }), xp::ExitOk);
  const xp::StereoGeometry geometry = xp::ReadStereoGeometry(options.output);
  ASSERT_EQ(geometry.views.size(), 2u);
  const xp::XRayView& a = geometry.views[0];
  const xp::XRayView& b = geometry.views[1];
  const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> dots = { { { 769, 1316 }, { 900, 1378 } },
    { { 796, 1336 }, { 881, 1397 } }, { { 755, 1347 }, { 897, 1410 } }, { { 789, 1368 }, { 882, 1430 } },
    { { 757, 1371 }, { 892, 1435 } }, { { 781, 1393 }, { 883, 1457 } }, { { 929, 1401 }, { 606, 1412 } },
    { { 939, 1405 }, { 626, 1420 } }, { { 934, 1442 }, { 604, 1453 } }, { { 942, 1443 }, { 621, 1459 } },
    { { 936, 1468 }, { 598, 1478 } }, { { 945, 1469 }, { 623, 1486 } } };
  std::vector<double> gaps, reprojections;
  for (const auto& [inA, inB] : dots)
  {
    const xp::Ray rayA = a.PixelRay(inA[0], inA[1]), rayB = b.PixelRay(inB[0], inB[1]);
    double gap = 0.0;
    const Eigen::Vector3d point =
      xp::ClosestApproach({ { rayA.origin, rayA.direction }, { rayB.origin, rayB.direction } }, &gap);
    gaps.push_back(gap);
    reprojections.push_back(std::max((a.Project(point) - inA).norm(), (b.Project(point) - inB).norm()));
    EXPECT_LT(gap, 0.5) << "dot at A " << inA.transpose() << ", B " << inB.transpose();
    EXPECT_LT(reprojections.back(), 1.0) << "dot at A " << inA.transpose() << ", B " << inB.transpose();
  }
  std::sort(gaps.begin(), gaps.end());
  std::sort(reprojections.begin(), reprojections.end());
  std::cout << "wrist markers: rays " << gaps[gaps.size() / 2] << " mm apart (median; largest " << gaps.back()
            << "), reprojected within " << reprojections[reprojections.size() / 2] << " px (median; largest "
            << reprojections.back() << ")\n";

  // Each dot is darker than the ring 5-7 pixels about it by 10 grey levels or more, where the
  // reader puts the file's pixel; turned upside down, most are not.
  const auto darkDots = [&](const std::string& file, int which, bool upsideDown)
  {
    const vtkSmartPointer<vtkImageData> xray = xp::ReadXRayTIFF(file);
    const int rows = xray->GetDimensions()[1];
    const auto value = [&](int column, int row) // row from the top; VTK's j runs up
    { return xray->GetScalarComponentAsDouble(column, rows - 1 - (upsideDown ? rows - 1 - row : row), 0, 0); };
    int dark = 0;
    for (const auto& pair : dots)
    {
      const Eigen::Vector2d& pixel = which == 0 ? pair.first : pair.second;
      const int c = static_cast<int>(pixel[0]), r = static_cast<int>(pixel[1]);
      double ring = 0.0;
      int count = 0;
      for (int dr = -7; dr <= 7; ++dr)
        for (int dc = -7; dc <= 7; ++dc)
          if (const double d = std::hypot(dc, dr); d >= 5.0 && d <= 7.0)
            ring += value(c + dc, r + dr), ++count;
      dark += ring / count - value(c, r) >= 10.0 ? 1 : 0;
    }
    return dark;
  };
  const int count = static_cast<int>(dots.size());
  EXPECT_EQ(darkDots(wrist + "xr_rad_uln_cam01_UND.0158.tif", 0, false), count);
  EXPECT_EQ(darkDots(wrist + "xr_rad_uln_cam02_UND.0158.tif", 1, false), count);
  EXPECT_LT(darkDots(wrist + "xr_rad_uln_cam01_UND.0158.tif", 0, true), count / 2) << "the check must see a flip";
}

// `bench register` prints each variant's stages (optimiser x render strides x travel) and one line per
// variant side by side, from the same trials; an unknown optimiser or a malformed stride is bad input.
TEST(Commands, BenchRegisterPrintsStagesPerVariant)
{
  xp::BenchRegisterOptions options;
  options.ct = PhantomCT();
  options.geometry = Geometry;
  options.scenario = "noisy";
  options.trials = 1;
  options.size = "128x96";
  options.optimizers = { "nelder-mead", "nelder-mead/bobyqa" };
  options.renderStrides = { "1/1", "2/2" };
  options.travels = { "half", "quarter" };
  ::testing::internal::CaptureStdout();
  const int code = xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(options); });
  const std::string out = ::testing::internal::GetCapturedStdout();
  ASSERT_EQ(code, xp::ExitOk) << out;
  for (const char* text : { "nelder-mead, strides 1/1, half travel: medians", "nelder-mead/bobyqa, strides 2/2, quarter travel: medians",
         "| coarse search", "| fine | 1/1 | 1 |", "| landscape | 1/1 | 1 |", "Variants side by side", "the schedule",
         "refinement    fine", "| model evaluations |", "| cores busy |", "| nelder-mead, strides 1/1, half travel | ",
         "| nelder-mead, strides 2/2, half travel | ", "| nelder-mead/bobyqa, strides 1/1, quarter travel | ",
         "median time with the CT read (s)", "against 100 % of the CT's slices;", "\nmachine: ", " hardware threads, ray caster " })
    EXPECT_NE(out.find(text), std::string::npos) << text << "\n" << out;
  // The reference's time ratio to itself; every ray cast at stride 1, about a quarter at 2.
  const auto row = [&](const std::string& name)
  {
    const size_t at = out.find("| " + name + " | ", out.find("Variants side by side"));
    return at == std::string::npos ? std::string() : out.substr(at, out.find('\n', at) - at);
  };
  EXPECT_NE(row("nelder-mead, strides 1/1, half travel").find("| 1.00 |"), std::string::npos) << out;
  const auto megaRays = [&](const std::string& name)
  {
    std::string text = row(name);
    for (int column = 0; column < 6 && !text.empty(); ++column)
      text = text.substr(text.find('|') + 1);
    return std::atof(text.c_str());
  };
  EXPECT_LT(megaRays("nelder-mead, strides 2/2, half travel"), 0.5 * megaRays("nelder-mead, strides 1/1, half travel")) << out;

  options.renderStrides = { "1/1" };
  options.optimizers = { "nelder-mead", "nelder-mead/simplex" };
  EXPECT_EQ(xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(options); }), xp::ExitBadInput);
  options.optimizers = { "nelder-mead" };
  options.renderStrides = { "2-2" };
  EXPECT_EQ(xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(options); }), xp::ExitBadInput);
  options.renderStrides = { "1/0" };
  options.travels = { "half", "eighth" };
  EXPECT_EQ(xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(options); }), xp::ExitBadInput);
  options.travels = { "half" };
  options.without = { "truncation" }; // an effect of the clinical scenario only
  EXPECT_EQ(xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(options); }), xp::ExitBadInput);
}
