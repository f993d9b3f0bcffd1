// DRRs as RT Images: valid by dciodvfy, linked to the CT, and their tags alone give back the
// imager they were rendered for (source and panel centre within 0.1 mm, directions 0.01 degree).
#include "xpReferenceGeometry.h"

#include "xpDICOMSeries.h"
#include "xpDICOMSeriesWriter.h"
#include "xpError.h"
#include "xpImageIO.h"
#include "xpRTImage.h"
#include "xpSpatialRegistration.h"
#include "xpXRayGeometryTags.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <gtest/gtest.h>
#include <sstream>
#include <vtkImageData.h>
#include <vtkNew.h>

using xp::testing::DciodvfyReport;
using xp::testing::ExpectDcmtkReads;
using xp::testing::FreshFolder;
using xp::testing::HaveDciodvfy;

namespace
{

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

xp::CTSeriesInfo SmallSeries(const std::string& dir)
{
  xp::CTVolumeData v;
  v.dimensions = { 8, 6, 5 };
  v.spacing = { 1.0, 1.0, 2.0 };
  v.origin = { -4.0, -3.0, 100.0 };
  v.hounsfield.assign(8 * 6 * 5, 0.0f);
  EXPECT_EQ(std::system(("mkdir -p " + dir).c_str()), 0);
  xp::WriteCTSeries(v, dir);
  return xp::ScanCTSeries(dir);
}

xp::RTImageDRR DRROf(const xp::XRayView& view)
{
  xp::RTImageDRR drr;
  drr.view = view;
  drr.isocenterInCT = Eigen::Vector3d(0.0, 0.0, 104.0);
  drr.pixels.resize(static_cast<size_t>(view.Columns()) * view.Rows());
  for (size_t i = 0; i < drr.pixels.size(); ++i)
    drr.pixels[i] = static_cast<uint16_t>(i % 4096);
  drr.description = "DRR at the planned set-up";
  return drr;
}

} // namespace

TEST(RTImage, DRRsAreValidAndTheirTagsGiveBackTheImager)
{
  const std::string dir = FreshFolder("rtimage");
  const xp::CTSeriesInfo ct = SmallSeries(dir + "/ct");
  const std::string series = xp::NewDICOMUID();
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  int instance = 0;
  for (const xp::XRayView& panel : reference.views)
  {
    const xp::XRayView view = panel.Resampled(128, 96);
    const std::string path = dir + "/drr_" + view.name + ".dcm";
    xp::WriteRTImageDRR(ct, DRROf(view), series, ++instance, path);
    ExpectDcmtkReads(path);
    const xp::XRayView back = xp::ReadRTImageView(path, reference.isocenter);
    EXPECT_EQ(back.name, view.name);
    EXPECT_LT((back.source - view.source).norm(), 0.1);
    EXPECT_LT((back.detectorCenter - view.detectorCenter).norm(), 0.1);
    EXPECT_LT(DegreesApart(back.rowDirection, view.rowDirection), 0.01);
    EXPECT_LT(DegreesApart(back.columnDirection, view.columnDirection), 0.01);
    EXPECT_NEAR(back.pixelSpacing[0], view.pixelSpacing[0], 1e-9);
    EXPECT_EQ(back.size, view.size);

    if (HaveDciodvfy())
    {
      const std::string report = DciodvfyReport(path);
      EXPECT_EQ(report.find("Error"), std::string::npos) << report;
    }
  }
  if (!HaveDciodvfy())
    GTEST_SKIP() << "dciodvfy (Debian package dicom3tools) not installed: the IOD check is skipped";
}

TEST(RTImage, MissingOrContradictoryGeometryTagsAreNamed)
{
  const std::string dir = FreshFolder("rtimage-bad");
  const xp::CTSeriesInfo ct = SmallSeries(dir + "/ct");
  const xp::XRayView view = xp::testing::ReferenceStereoGeometry().views[0].Resampled(64, 48);
  const std::string path = dir + "/drr.dcm";
  xp::WriteRTImageDRR(ct, DRROf(view), xp::NewDICOMUID(), 1, path);
  const auto errorAfter = [&](const std::string& edit)
  {
    const std::string edited = dir + "/edited.dcm";
    std::system(("cp " + path + " " + edited + " && dcmodify -nb " + edit + " " + edited + " > /dev/null 2>&1").c_str());
    try
    {
      xp::ReadRTImageView(edited, Eigen::Vector3d::Zero());
    }
    catch (const xp::InputError& e)
    {
      return std::string(e.what());
    }
    return std::string();
  };
  if (std::system("command -v dcmodify > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "dcmodify (Debian package dcmtk) not installed";
  EXPECT_NE(errorAfter("-e \"(3002,0026)\"").find("RT Image SID (3002,0026) missing"), std::string::npos);
  EXPECT_NE(errorAfter("-e \"(300A,011E)\"").find("Gantry Angle (300A,011E) missing"), std::string::npos);
  EXPECT_NE(errorAfter("-m \"(3002,000D)=0\\\\0\\\\-300\"").find("(3002,000D)"), std::string::npos);
  EXPECT_NE(errorAfter("-m \"(3002,000C)=NON_NORMAL\"").find("(3002,000C)"), std::string::npos);
  EXPECT_NE(errorAfter("-m \"(3002,0011)=0.5\"").find("Image Plane Pixel Spacing (3002,0011)"), std::string::npos);
  EXPECT_THROW(xp::ReadRTImageView(ct.files.front(), Eigen::Vector3d::Zero()), xp::InputError); // a CT image
}

TEST(RTImage, DisagreementsWithAGeometryFileNameTheTagAndBothValues)
{
  const std::string dir = FreshFolder("rtimage-check");
  const xp::CTSeriesInfo ct = SmallSeries(dir + "/ct");
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  const xp::XRayView a = reference.views[0].Resampled(64, 48), b = reference.views[1].Resampled(64, 48);
  const std::string path = dir + "/drr_A.dcm";
  xp::WriteRTImageDRR(ct, DRROf(a), xp::NewDICOMUID(), 1, path);
  EXPECT_TRUE(xp::RTImageDisagreements(path, a, reference.isocenter).empty());
  const std::vector<std::string> other = xp::RTImageDisagreements(path, b, reference.isocenter);
  ASSERT_EQ(other.size(), 1u);
  EXPECT_NE(other[0].find("Gantry Angle (300A,011E) = 225 deg"), std::string::npos) << other[0];
  EXPECT_NE(other[0].find("has 135 deg"), std::string::npos) << other[0];
  // The panel 2 mm farther from the source: SID and the receptor translation disagree.
  xp::XRayView farther = a;
  farther.detectorCenter -= 2.0 * farther.NormalTowardsSource();
  const std::vector<std::string> moved = xp::RTImageDisagreements(path, farther, reference.isocenter);
  ASSERT_EQ(moved.size(), 2u);
  EXPECT_NE(moved[0].find("RT Image SID (3002,0026) = 1499.99"), std::string::npos) << moved[0];
  EXPECT_NE(moved[0].find("has 1501.99"), std::string::npos) << moved[0];
  EXPECT_NE(moved[1].find("(3002,000D)"), std::string::npos) << moved[1];
  EXPECT_TRUE(xp::RTImageDisagreements(ct.files.front(), a, reference.isocenter).empty()) << "a CT image has no imager";

  // The pixel spacing alone: what tells a binned read-out from another panel. Another gantry
  // angle is no concern of it; the same panel at twice the spacing is.
  EXPECT_TRUE(xp::RTImageDisagreements(path, b, reference.isocenter, xp::XRayTagSubset::PixelSpacing).empty());
  const std::vector<std::string> binned =
    xp::RTImageDisagreements(path, *a.Binned(32, 24), reference.isocenter, xp::XRayTagSubset::PixelSpacing);
  ASSERT_EQ(binned.size(), 1u);
  EXPECT_NE(binned[0].find("Image Plane Pixel Spacing (3002,0011)"), std::string::npos) << binned[0];
  EXPECT_EQ(xp::XRayTagDisagreements(path, *a.Binned(32, 24), reference.isocenter, "", xp::XRayTagSubset::PixelSpacing), binned)
    << "an RT Image's tags, whatever the kind of X-ray asked";
}

TEST(SecondaryCapture, TheReportPictureIsAValidImageInTheCTsStudy)
{
  const std::string dir = FreshFolder("secondary-capture");
  const xp::CTSeriesInfo ct = SmallSeries(dir + "/ct");
  vtkNew<vtkImageData> picture;
  picture->SetDimensions(30, 20, 1);
  picture->AllocateScalars(VTK_UNSIGNED_CHAR, 3);
  auto* rgb = static_cast<unsigned char*>(picture->GetScalarPointer());
  for (int i = 0; i < 30 * 20 * 3; ++i)
    rgb[i] = static_cast<unsigned char>(i % 251);
  xp::WritePNG(picture, dir + "/summary.png");
  const std::string path = dir + "/report.dcm";
  const std::string uid = xp::WriteSecondaryCapture(ct, dir + "/summary.png", "xpose registration report: status ok", path);
  EXPECT_EQ(uid.rfind("2.25.", 0), 0u);
  ExpectDcmtkReads(path);
  EXPECT_THROW(xp::WriteSecondaryCapture(ct, dir + "/no-such.png", "", dir + "/x.dcm"), xp::InputError);
  if (!HaveDciodvfy())
    GTEST_SKIP() << "dciodvfy (Debian package dicom3tools) not installed: the IOD check is skipped";
  const std::string report = DciodvfyReport(path);
  EXPECT_EQ(report.find("Error"), std::string::npos) << report;
}
