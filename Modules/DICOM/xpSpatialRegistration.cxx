#include "xpSpatialRegistration.h"

#include "xpDICOMDataSet.h"
#include "xpError.h"

#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>
#include <gdcmTrace.h>
#include <gdcmWriter.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <ctime>
#include <fstream>
#include <random>
#include <sstream>
#include <cmath>
#include <cstdlib>

namespace xp
{

using dicom::DS;
using dicom::Put;
using dicom::PutSequence;
using dicom::Value;

namespace
{

const char* SpatialRegistrationStorage = "1.2.840.10008.5.1.4.1.1.66.1";

/** The rigid matrix item of a Registration Sequence item, row-major. */
gdcm::DataSet MatrixRegistration(const Eigen::Isometry3d& transform)
{
  std::string values;
  const Eigen::Matrix4d m = transform.matrix();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      values += (values.empty() ? "" : "\\") + DS(m(r, c));
  gdcm::DataSet matrix;
  Put(matrix, 0x3006, 0x00c6, gdcm::VR::DS, values);  // Frame of Reference Transformation Matrix
  Put(matrix, 0x0070, 0x030c, gdcm::VR::CS, "RIGID"); // Frame of Reference Transformation Matrix Type
  gdcm::DataSet registration;
  PutSequence(registration, 0x0070, 0x030a, { matrix }); // Matrix Sequence
  PutSequence(registration, 0x0070, 0x030d, {});         // Registration Type Code Sequence (type 2)
  return registration;
}

/** A Registration Sequence item: `frameOfReference` into the REG's, and the images it applies to. */
gdcm::DataSet RegistrationItem(
  const std::string& frameOfReference, const Eigen::Isometry3d& transform, const std::vector<gdcm::DataSet>& images = {})
{
  gdcm::DataSet item;
  Put(item, 0x0020, 0x0052, gdcm::VR::UI, frameOfReference);
  if (!images.empty())
    PutSequence(item, 0x0008, 0x1140, images); // Referenced Image Sequence
  PutSequence(item, 0x0070, 0x0309, { MatrixRegistration(transform) }); // Matrix Registration Sequence
  return item;
}

/** Referenced Image / Instance Sequence items: class and instance UIDs. */
std::vector<gdcm::DataSet> ImageItems(const std::vector<InstanceReference>& images)
{
  std::vector<gdcm::DataSet> items;
  for (const InstanceReference& image : images)
  {
    gdcm::DataSet item;
    Put(item, 0x0008, 0x1150, gdcm::VR::UI, image.sopClassUID);
    Put(item, 0x0008, 0x1155, gdcm::VR::UI, image.sopInstanceUID);
    items.push_back(item);
  }
  return items;
}

/** The distinct values of one UID of `references`, in order of first appearance. */
std::vector<std::string> Distinct(const std::vector<InstanceReference>& references, std::string InstanceReference::*uid)
{
  std::vector<std::string> values;
  for (const InstanceReference& r : references)
    if (std::find(values.begin(), values.end(), r.*uid) == values.end())
      values.push_back(r.*uid);
  return values;
}

/** Referenced Series Sequence items: each series with its instances. */
std::vector<gdcm::DataSet> SeriesItems(const std::vector<InstanceReference>& references)
{
  std::vector<gdcm::DataSet> items;
  for (const std::string& series : Distinct(references, &InstanceReference::seriesInstanceUID))
  {
    std::vector<InstanceReference> ofSeries;
    std::copy_if(references.begin(), references.end(), std::back_inserter(ofSeries),
      [&](const InstanceReference& r) { return r.seriesInstanceUID == series; });
    gdcm::DataSet item;
    PutSequence(item, 0x0008, 0x114a, ImageItems(ofSeries)); // Referenced Instance Sequence
    Put(item, 0x0020, 0x000e, gdcm::VR::UI, series);
    items.push_back(item);
  }
  return items;
}

} // namespace

std::optional<InstanceReference> ReadInstanceReference(const std::string& path)
{
  gdcm::Trace::WarningOff();
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  if (!reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010)))
    return std::nullopt;
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  InstanceReference reference{ Value(ds, gdcm::Tag(0x0008, 0x0016)), Value(ds, gdcm::Tag(0x0008, 0x0018)),
    Value(ds, gdcm::Tag(0x0020, 0x000e)), Value(ds, gdcm::Tag(0x0020, 0x000d)) };
  if (reference.sopClassUID.empty() || reference.sopInstanceUID.empty() || reference.seriesInstanceUID.empty() ||
    reference.studyInstanceUID.empty())
    return std::nullopt;
  return reference;
}

std::string NewDICOMUID()
{
  // 2.25. followed by a 128-bit random number (a version 4 UUID) in decimal, at most 39 digits.
  std::random_device device;
  unsigned __int128 value = 0;
  for (int i = 0; i < 4; ++i)
    value = (value << 32) | device();
  value &= ~(static_cast<unsigned __int128>(0xf000) << 64); // version 4: bits 76-79 = 0100
  value |= static_cast<unsigned __int128>(0x4000) << 64;
  value &= ~(static_cast<unsigned __int128>(0xc) << 60);    // variant: bits 62-63 = 10
  value |= static_cast<unsigned __int128>(0x8) << 60;
  std::string digits;
  do
  {
    digits.insert(digits.begin(), static_cast<char>('0' + static_cast<int>(value % 10)));
    value /= 10;
  } while (value != 0);
  return "2.25." + digits;
}

std::string WriteSpatialRegistration(const CTSeriesInfo& ct, const SpatialRegistration& registration, const std::string& path)
{
  if (ct.files.empty())
    throw InputError(ct.directory, "no CT images to refer to");
  const std::string& first = ct.files.front();
  if (ct.studyInstanceUID.empty())
    throw InputError(first, "Study Instance UID (0020,000D) missing: the REG must join the CT's study");
  if (ct.frameOfReferenceUID.empty())
    throw InputError(first, "Frame of Reference UID (0020,0052) missing: the REG registers the CT's Frame of Reference");
  gdcm::Writer writer;
  gdcm::DataSet& ds = writer.GetFile().GetDataSet();
  // Patient and study as the CT has them; a new series, instance and session Frame of Reference.
  const std::string sopInstanceUID = dicom::BeginInstance(
    ds, ct, SpatialRegistrationStorage, "REG", registration.seriesDescription, NewDICOMUID());
  const std::string sessionFrame = NewDICOMUID();
  Put(ds, 0x0020, 0x0013, gdcm::VR::IS, "1");
  Put(ds, 0x0020, 0x0052, gdcm::VR::UI, sessionFrame);
  Put(ds, 0x0020, 0x0060, gdcm::VR::CS, ""); // Laterality: not a paired structure
  Put(ds, 0x0020, 0x1040, gdcm::VR::LO, "");
  Put(ds, 0x0070, 0x0080, gdcm::VR::CS, registration.contentLabel.substr(0, 16));
  Put(ds, 0x0070, 0x0081, gdcm::VR::LO, registration.contentDescription.substr(0, 64));
  Put(ds, 0x0070, 0x0084, gdcm::VR::PN, registration.creator);

  // Every CT image: the registration applies to them, and the instance references them.
  std::vector<InstanceReference> ctImages;
  for (const std::string& uid : ct.sopInstanceUIDs)
    ctImages.push_back({ ct.sopClassUID, uid, ct.seriesInstanceUID, ct.studyInstanceUID });
  // The registration: the session's own Frame of Reference with its images, and the CT's into it.
  PutSequence(ds, 0x0070, 0x0308,
    { RegistrationItem(sessionFrame, Eigen::Isometry3d::Identity(), ImageItems(registration.sessionImages)),
      RegistrationItem(ct.frameOfReferenceUID, registration.ctToSession, ImageItems(ctImages)) });
  // Common Instance Reference: the series of this study, then those of other studies.
  std::vector<InstanceReference> all = ctImages;
  all.insert(all.end(), registration.sessionImages.begin(), registration.sessionImages.end());
  std::vector<gdcm::DataSet> otherStudies;
  for (const std::string& study : Distinct(all, &InstanceReference::studyInstanceUID))
  {
    std::vector<InstanceReference> ofStudy;
    std::copy_if(all.begin(), all.end(), std::back_inserter(ofStudy), [&](const InstanceReference& r) { return r.studyInstanceUID == study; });
    if (study == ct.studyInstanceUID)
    {
      PutSequence(ds, 0x0008, 0x1115, SeriesItems(ofStudy));
      continue;
    }
    gdcm::DataSet item;
    PutSequence(item, 0x0008, 0x1115, SeriesItems(ofStudy));
    Put(item, 0x0020, 0x000d, gdcm::VR::UI, study);
    otherStudies.push_back(item);
  }
  if (!otherStudies.empty())
    PutSequence(ds, 0x0008, 0x1200, otherStudies); // Studies Containing Other Referenced Instances

  dicom::WriteFile(writer, path, "Spatial Registration");
  return sopInstanceUID;
}

Eigen::Isometry3d ReadSpatialRegistrationMatrix(const std::string& path, const std::string& frameOfReferenceUID)
{
  gdcm::Reader reader;
  reader.SetFileName(path.c_str());
  if (!reader.Read())
    throw InputError(path, "not a readable DICOM file");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  if (Value(ds, gdcm::Tag(0x0008, 0x0016)) != SpatialRegistrationStorage)
    throw InputError(path, "SOP Class UID (0008,0016) is not Spatial Registration Storage");
  const gdcm::Tag registrationTag(0x0070, 0x0308);
  if (!ds.FindDataElement(registrationTag) || !ds.GetDataElement(registrationTag).GetValueAsSQ())
    throw InputError(path, "Registration Sequence (0070,0308) missing");
  const gdcm::SmartPointer<gdcm::SequenceOfItems> items = ds.GetDataElement(registrationTag).GetValueAsSQ();
  for (size_t i = 1; i <= items->GetNumberOfItems(); ++i)
  {
    const gdcm::DataSet& item = items->GetItem(i).GetNestedDataSet();
    if (Value(item, gdcm::Tag(0x0020, 0x0052)) != frameOfReferenceUID)
      continue;
    const gdcm::Tag matrixRegistration(0x0070, 0x0309), matrixSequence(0x0070, 0x030a);
    if (!item.FindDataElement(matrixRegistration) || !item.GetDataElement(matrixRegistration).GetValueAsSQ() ||
      item.GetDataElement(matrixRegistration).GetValueAsSQ()->GetNumberOfItems() < 1)
      throw InputError(path, "Matrix Registration Sequence (0070,0309) missing for Frame of Reference " + frameOfReferenceUID);
    const gdcm::DataSet& registration = item.GetDataElement(matrixRegistration).GetValueAsSQ()->GetItem(1).GetNestedDataSet();
    if (!registration.FindDataElement(matrixSequence) || !registration.GetDataElement(matrixSequence).GetValueAsSQ() ||
      registration.GetDataElement(matrixSequence).GetValueAsSQ()->GetNumberOfItems() != 1)
      throw InputError(path, "Matrix Sequence (0070,030A): expected one rigid matrix");
    const gdcm::DataSet& matrix = registration.GetDataElement(matrixSequence).GetValueAsSQ()->GetItem(1).GetNestedDataSet();
    std::stringstream text(Value(matrix, gdcm::Tag(0x3006, 0x00c6)));
    Eigen::Matrix4d m;
    std::string word;
    int count = 0;
    while (std::getline(text, word, '\\') && count < 16)
    {
      char* end = nullptr;
      const double value = std::strtod(word.c_str(), &end);
      if (end == word.c_str() || !std::isfinite(value))
        break;
      m(count / 4, count % 4) = value;
      ++count;
    }
    if (count != 16 || (m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6 ||
      (m.topLeftCorner<3, 3>() * m.topLeftCorner<3, 3>().transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4)
      throw InputError(path, "Frame of Reference Transformation Matrix (3006,00C6): expected 16 numbers of a rigid transform");
    Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
    transform.linear() = m.topLeftCorner<3, 3>();
    transform.translation() = m.topRightCorner<3, 1>();
    return transform;
  }
  throw InputError(path, "Registration Sequence (0070,0308) holds no item for Frame of Reference " + frameOfReferenceUID);
}

} // namespace xp
