// The imager a DX file's own tags describe: the reference views written as DX positioner terms come
// back within 0.1 mm and 0.01 degree; a moved imager is reported tag by tag; missing and
// contradictory tags are named.
#include "xpReferenceGeometry.h"

#include "xpCArmGeometry.h"
#include "xpError.h"
#include "xpPose.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"
#include "xpXRayGeometryTags.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

using xp::testing::FreshFolder;
using xp::testing::TestElement;

namespace
{

std::string DS(double value)
{
  char text[32];
  std::snprintf(text, sizeof(text), "%.9g", value);
  return text;
}

double DegreesApart(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
{
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

/** The DX tags of `view` (a 40 x 30 panel), as a C-arm would write them, with `position`. */
std::vector<TestElement> DXTagsOf(const xp::XRayView& view, const Eigen::Vector3d& iso, const std::string& position)
{
  const xp::CArmGeometry g = xp::CArmGeometryOf(view, xp::PatientToRoomRotation(xp::PatientPosition::HFS), iso);
  std::vector<TestElement> tags = {
    { 0x0008, 0x0016, gdcm::VR::UI, "1.2.840.10008.5.1.4.1.1.1.1" },
    { 0x0018, 0x1110, gdcm::VR::DS, DS(g.sourceToDetector) },
    { 0x0018, 0x1111, gdcm::VR::DS, DS(g.sourceToPatient) },
    { 0x0018, 0x1510, gdcm::VR::DS, DS(g.primaryAngle) },
    { 0x0018, 0x1511, gdcm::VR::DS, DS(g.secondaryAngle) },
    { 0x0018, 0x1164, gdcm::VR::DS, DS(g.imagerPixelSpacing[0]) + "\\" + DS(g.imagerPixelSpacing[1]) },
    { 0x0020, 0x0020, gdcm::VR::CS, g.rowOrientation + "\\" + g.columnOrientation },
  };
  if (!position.empty())
    tags.push_back({ 0x0018, 0x5100, gdcm::VR::CS, position });
  return tags;
}

std::vector<TestElement> Without(std::vector<TestElement> tags, uint16_t element)
{
  tags.erase(std::remove_if(tags.begin(), tags.end(), [&](const TestElement& e) { return e.element == element; }), tags.end());
  return tags;
}

std::string ReadError(const std::string& path, const std::string& fallback = "")
{
  try
  {
    xp::ReadXRayViewFromTags(path, Eigen::Vector3d::Zero(), fallback);
  }
  catch (const xp::InputError& e)
  {
    return e.what();
  }
  return "";
}

} // namespace

TEST(XRayGeometryTags, DXTagsGiveBackTheReferenceImagers)
{
  const std::string dir = FreshFolder("dx-geometry");
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  for (const xp::XRayView& panel : reference.views)
  {
    const xp::XRayView view = panel.Resampled(40, 30);
    const std::string path = dir + "/dx_" + view.name + ".dcm";
    xp::testing::WriteDX(path, "DX", false, DXTagsOf(view, reference.isocenter, "HFS"));
    const xp::XRayView back = xp::ReadXRayViewFromTags(path, reference.isocenter);
    EXPECT_LT((back.source - view.source).norm(), 0.1) << view.name;
    EXPECT_LT((back.detectorCenter - view.detectorCenter).norm(), 0.1);
    EXPECT_LT(DegreesApart(back.rowDirection, view.rowDirection), 0.01);
    EXPECT_LT(DegreesApart(back.columnDirection, view.columnDirection), 0.01);
    EXPECT_NEAR(back.pixelSpacing[0], view.pixelSpacing[0], 1e-6);
    EXPECT_EQ(back.size, view.size);
    EXPECT_TRUE(xp::XRayTagDisagreements(path, view, reference.isocenter).empty());
    // The other imager: every tag that differs is named with both values.
    const xp::XRayView other = reference.views[view.name == "A" ? 1 : 0].Resampled(40, 30);
    const std::vector<std::string> lines = xp::XRayTagDisagreements(path, other, reference.isocenter);
    ASSERT_EQ(lines.size(), 2u);
    EXPECT_NE(lines[0].find("Positioner Primary Angle (0018,1510)"), std::string::npos) << lines[0];
    EXPECT_NE(lines[1].find("Patient Orientation (0020,0020)"), std::string::npos) << lines[1];
  }
}

TEST(XRayGeometryTags, PatientPositionComesFromTheFileOrTheCaller)
{
  const std::string dir = FreshFolder("dx-position");
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  const xp::XRayView view = reference.views[0].Resampled(40, 30);
  const std::string path = dir + "/dx.dcm";
  xp::testing::WriteDX(path, "DX", false, DXTagsOf(view, reference.isocenter, ""));
  EXPECT_NE(ReadError(path).find("Patient Position (0018,5100) missing"), std::string::npos) << ReadError(path);
  const xp::XRayView supine = xp::ReadXRayViewFromTags(path, reference.isocenter, "HFS");
  EXPECT_LT((supine.source - view.source).norm(), 0.1);
  // Prone, the same positioner angles put the source on the other side of the room's vertical.
  const xp::XRayView prone = xp::ReadXRayViewFromTags(path, reference.isocenter, "HFP");
  EXPECT_GT(prone.source.z(), 700.0);
  EXPECT_LT(supine.source.z(), -700.0);
}

TEST(XRayGeometryTags, MissingAndContradictoryTagsAreNamed)
{
  const std::string dir = FreshFolder("dx-bad");
  const xp::StereoGeometry reference = xp::testing::ReferenceStereoGeometry();
  const std::vector<TestElement> good = DXTagsOf(reference.views[0].Resampled(40, 30), reference.isocenter, "HFS");
  const struct
  {
    uint16_t element;
    const char* named;
  } missing[] = { { 0x1110, "Distance Source to Detector (0018,1110)" }, { 0x1111, "Distance Source to Patient (0018,1111)" },
    { 0x1510, "Positioner Primary Angle (0018,1510)" }, { 0x1511, "Positioner Secondary Angle (0018,1511)" },
    { 0x0020, "Patient Orientation (0020,0020)" } };
  for (const auto& m : missing)
  {
    const std::string path = dir + "/missing.dcm";
    xp::testing::WriteDX(path, "DX", false, Without(good, m.element));
    const std::string message = ReadError(path);
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(m.named), std::string::npos) << m.named << ": " << message;
  }
  // One element replaced: the message names what is wrong.
  const auto errorWith = [&](const TestElement& replaced, const char* modality = "DX")
  {
    std::vector<TestElement> tags = good;
    tags.push_back(replaced);
    xp::testing::WriteDX(dir + "/replaced.dcm", modality, false, tags);
    return ReadError(dir + "/replaced.dcm");
  };
  // The panel nearer than the isocentre.
  EXPECT_NE(errorWith({ 0x0018, 0x1110, gdcm::VR::DS, "800" }).find("Distance Source to Patient (0018,1111)"), std::string::npos);
  EXPECT_NE(errorWith({ 0x0018, 0x1508, gdcm::VR::CS, "COLUMN" }).find("Positioner Type (0018,1508)"), std::string::npos);
  EXPECT_NE(errorWith({ 0x0018, 0x1510, gdcm::VR::DS, "LAO" }).find("'LAO' is not a finite number"), std::string::npos);
  EXPECT_NE(errorWith({ 0x0008, 0x0016, gdcm::VR::UI, "1.2.840.10008.5.1.4.1.1.2" }, "OT").find("SOP Class UID (0008,0016)"),
    std::string::npos);
}
