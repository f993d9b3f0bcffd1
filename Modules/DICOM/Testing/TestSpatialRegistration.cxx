// The DICOM Spatial Registration (REG) of a result: valid by dciodvfy, linked to the CT, and its
// matrix moves CT points as the misalignment (Coordinates.md) moves the patient in the room.
#include "xpDICOMSeries.h"
#include "xpError.h"
#include "xpDICOMSeriesWriter.h"
#include "xpPose.h"
#include "xpSpatialRegistration.h"
#include "xpTestDICOM.h"
#include "xpTestFolders.h"

#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <gtest/gtest.h>
#include <memory>
#include <sstream>

using xp::testing::FreshFolder;

namespace
{

xp::CTVolumeData SmallCT()
{
  xp::CTVolumeData v;
  v.dimensions = { 8, 6, 5 };
  v.spacing = { 1.0, 1.0, 2.0 };
  v.origin = { -4.0, -3.0, 100.0 };
  v.hounsfield.assign(8 * 6 * 5, 0.0f);
  return v;
}

std::string Text(const gdcm::DataSet& ds, uint16_t group, uint16_t element)
{
  const gdcm::Tag tag(group, element);
  if (!ds.FindDataElement(tag) || !ds.GetDataElement(tag).GetByteValue())
    return "";
  const gdcm::ByteValue* v = ds.GetDataElement(tag).GetByteValue();
  std::string text(v->GetPointer(), v->GetLength());
  while (!text.empty() && (text.back() == ' ' || text.back() == '\0'))
    text.pop_back();
  return text;
}

const gdcm::DataSet& Item(const gdcm::DataSet& ds, uint16_t group, uint16_t element, size_t index)
{
  const gdcm::SmartPointer<gdcm::SequenceOfItems> sequence =
    ds.GetDataElement(gdcm::Tag(group, element)).GetValueAsSQ();
  return sequence->GetItem(index).GetNestedDataSet();
}

/** Room point of planned CT point p moved by the misalignment, written out from Coordinates.md. */
Eigen::Vector3d MovedInRoom(const Eigen::Isometry3d& planned, const xp::Pose& m, const Eigen::Vector3d& iso,
  const Eigen::Vector3d& p)
{
  const double deg = M_PI / 180.0;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(m.yaw * deg, Eigen::Vector3d::UnitZ()) *
    Eigen::AngleAxisd(m.roll * deg, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(m.pitch * deg, Eigen::Vector3d::UnitX()))
                              .toRotationMatrix();
  return R * (planned * p - iso) + iso + m.translation;
}

} // namespace

TEST(SpatialRegistration, MatrixMovesCTPointsAsTheMisalignmentMovesThePatient)
{
  const Eigen::Vector3d iso(0.0, 0.0, 0.0), isoInCT(10.0, -20.0, 130.0);
  const Eigen::Isometry3d planned = xp::PlannedCTToRoom(xp::PatientPosition::HFS, isoInCT, iso);
  xp::Pose m;
  m.translation = Eigen::Vector3d(4.0, -7.5, 2.25);
  m.pitch = 1.5;
  m.roll = -2.0;
  m.yaw = 3.0;
  const Eigen::Isometry3d inCT = xp::MisalignmentInCT(planned, m, iso);
  for (const Eigen::Vector3d& p : { isoInCT, Eigen::Vector3d(60.0, 30.0, 90.0), Eigen::Vector3d(-80.0, 45.0, 170.0) })
  {
    // The anatomy at planned CT point p, found at CT point inCT * p, sits in the room where the
    // misalignment moved it.
    EXPECT_LT((planned * (inCT * p) - MovedInRoom(planned, m, iso, p)).norm(), 1e-9) << p.transpose();
  }
  // The same rotation angle as the misalignment's, about the CT point at the isocentre.
  const double angle = Eigen::AngleAxisd(inCT.linear()).angle();
  EXPECT_NEAR(angle, Eigen::AngleAxisd(m.ToTransform(iso).linear()).angle(), 1e-12);
}

TEST(SpatialRegistration, WritesAValidREGLinkedToTheCT)
{
  const std::string dir = FreshFolder("reg");
  ASSERT_EQ(std::system(("mkdir -p " + dir + "/ct").c_str()), 0);
  xp::CTSeriesWriteOptions options;
  options.patientName = "DOE^JANE";
  options.patientID = "P123";
  xp::WriteCTSeries(SmallCT(), dir + "/ct", options);
  const xp::CTSeriesInfo ct = xp::ScanCTSeries(dir + "/ct");
  ASSERT_FALSE(ct.frameOfReferenceUID.empty());
  ASSERT_EQ(ct.sopInstanceUIDs.size(), 5u);

  xp::SpatialRegistration registration;
  registration.ctToSession = Eigen::Translation3d(1.0, -2.0, 3.5) * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ());
  registration.contentDescription = "estimated misalignment; table correction = its inverse";
  // The X-rays: one of the CT's study, one of another (the treatment session's) study.
  const std::string dx = "1.2.840.10008.5.1.4.1.1.1.1";
  registration.sessionImages = { { dx, "1.2.3.4.1", "1.2.3.4", ct.studyInstanceUID }, { dx, "1.2.3.5.1", "1.2.3.5", "1.2.3" } };
  const std::string uid = xp::WriteSpatialRegistration(ct, registration, dir + "/reg.dcm");
  EXPECT_EQ(uid.rfind("2.25.", 0), 0u);
  EXPECT_LE(uid.size(), 64u);

  xp::testing::ExpectDcmtkReads(dir + "/reg.dcm");
  gdcm::Reader reader;
  reader.SetFileName((dir + "/reg.dcm").c_str());
  ASSERT_TRUE(reader.Read());
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  EXPECT_EQ(Text(ds, 0x0008, 0x0016), "1.2.840.10008.5.1.4.1.1.66.1");
  EXPECT_EQ(Text(ds, 0x0008, 0x0060), "REG");
  EXPECT_EQ(Text(ds, 0x0010, 0x0010), "DOE^JANE");
  EXPECT_EQ(Text(ds, 0x0010, 0x0020), "P123");
  EXPECT_EQ(Text(ds, 0x0020, 0x000d), ct.studyInstanceUID);
  EXPECT_NE(Text(ds, 0x0020, 0x000e), ct.seriesInstanceUID);
  const std::string session = Text(ds, 0x0020, 0x0052);
  EXPECT_NE(session, ct.frameOfReferenceUID);
  // Registration Sequence: the session (identity), then the CT's Frame of Reference with the matrix.
  const gdcm::DataSet& fixed = Item(ds, 0x0070, 0x0308, 1);
  const gdcm::DataSet& moving = Item(ds, 0x0070, 0x0308, 2);
  EXPECT_EQ(Text(fixed, 0x0020, 0x0052), session);
  EXPECT_EQ(Text(moving, 0x0020, 0x0052), ct.frameOfReferenceUID);
  const gdcm::DataSet& matrixItem = Item(Item(moving, 0x0070, 0x0309, 1), 0x0070, 0x030a, 1);
  EXPECT_EQ(Text(matrixItem, 0x0070, 0x030c), "RIGID");
  const Eigen::Matrix4d m = xp::ReadSpatialRegistrationMatrix(dir + "/reg.dcm", ct.frameOfReferenceUID).matrix();
  EXPECT_LT((m - registration.ctToSession.matrix()).cwiseAbs().maxCoeff(), 1e-9) << m;
  EXPECT_TRUE(xp::ReadSpatialRegistrationMatrix(dir + "/reg.dcm", session).isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_THROW(xp::ReadSpatialRegistrationMatrix(dir + "/reg.dcm", "1.2.3"), xp::InputError);
  EXPECT_THROW(xp::ReadSpatialRegistrationMatrix(ct.files.front(), ct.frameOfReferenceUID), xp::InputError);
  // Every CT image is referenced, and the X-rays in the session's Frame of Reference.
  const gdcm::DataSet& series = Item(ds, 0x0008, 0x1115, 1);
  EXPECT_EQ(Text(series, 0x0020, 0x000e), ct.seriesInstanceUID);
  EXPECT_EQ(series.GetDataElement(gdcm::Tag(0x0008, 0x114a)).GetValueAsSQ()->GetNumberOfItems(), 5u);
  EXPECT_EQ(Text(Item(fixed, 0x0008, 0x1140, 1), 0x0008, 0x1155), "1.2.3.4.1");
  EXPECT_EQ(Text(Item(fixed, 0x0008, 0x1140, 2), 0x0008, 0x1155), "1.2.3.5.1");
  EXPECT_EQ(Text(Item(ds, 0x0008, 0x1115, 2), 0x0020, 0x000e), "1.2.3.4"); // same study
  const gdcm::DataSet& otherStudy = Item(ds, 0x0008, 0x1200, 1);
  EXPECT_EQ(Text(otherStudy, 0x0020, 0x000d), "1.2.3");
  EXPECT_EQ(Text(Item(Item(otherStudy, 0x0008, 0x1115, 1), 0x0008, 0x114a, 1), 0x0008, 0x1155), "1.2.3.5.1");
  // An X-ray's identity comes from its own file; a file that is not DICOM has none.
  const std::optional<xp::InstanceReference> own = xp::ReadInstanceReference(ct.files.front());
  ASSERT_TRUE(own.has_value());
  EXPECT_EQ(own->seriesInstanceUID, ct.seriesInstanceUID);
  EXPECT_EQ(own->studyInstanceUID, ct.studyInstanceUID);
  std::ofstream(dir + "/note.txt") << "not DICOM";
  EXPECT_FALSE(xp::ReadInstanceReference(dir + "/note.txt").has_value());

  if (!xp::testing::HaveDciodvfy())
    GTEST_SKIP() << "dciodvfy (Debian package dicom3tools) not installed: the IOD check is skipped";
  const std::string report = xp::testing::DciodvfyReport(dir + "/reg.dcm");
  EXPECT_EQ(report.find("Error"), std::string::npos) << report;
}
