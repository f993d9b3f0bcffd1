#include "xpDICOMDataSet.h"

#include "xpError.h"
#include "xpSpatialRegistration.h"

#include <gdcmTrace.h>

#include <gdcmReader.h>
#include <gdcmSequenceOfItems.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <cstring>
#include <ctime>

namespace xp
{
namespace dicom
{

/** A text element; UI values are padded with NUL, others with a space, to even length. */
gdcm::DataElement Text(uint16_t group, uint16_t element, gdcm::VR vr, std::string value)
{
  if (value.size() % 2)
    value += vr == gdcm::VR::UI ? '\0' : ' ';
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<uint32_t>(value.size()));
  return de;
}

void Put(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr, const std::string& value)
{
  ds.Replace(Text(group, element, vr, value));
}

/** A sequence element holding `items` (each a data set). */
void PutSequence(gdcm::DataSet& ds, uint16_t group, uint16_t element, const std::vector<gdcm::DataSet>& items)
{
  gdcm::SmartPointer<gdcm::SequenceOfItems> sequence = new gdcm::SequenceOfItems;
  sequence->SetLengthToUndefined();
  for (const gdcm::DataSet& nested : items)
  {
    gdcm::Item item;
    item.SetVLToUndefined();
    item.SetNestedDataSet(nested);
    sequence->AddItem(item);
  }
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::SQ);
  de.SetValue(*sequence);
  de.SetVLToUndefined();
  ds.Replace(de);
}

/** A decimal string of at most 16 characters. */
std::string DS(double value)
{
  char text[32];
  for (int digits = 12; digits > 1; --digits)
  {
    std::snprintf(text, sizeof(text), "%.*g", digits, value == 0.0 ? 0.0 : value);
    if (std::string(text).size() <= 16)
      break;
  }
  return text;
}

namespace
{

std::string Stored(const gdcm::DataSet& ds, const gdcm::Tag& tag)
{
  if (!ds.FindDataElement(tag))
    return "";
  const gdcm::ByteValue* value = ds.GetDataElement(tag).GetByteValue();
  return value ? std::string(value->GetPointer(), value->GetLength()) : std::string();
}

std::string Trimmed(std::string text)
{
  while (!text.empty() && (text.back() == ' ' || text.back() == '\0'))
    text.pop_back();
  return text;
}

} // namespace

std::string Value(const gdcm::DataSet& ds, const gdcm::Tag& tag)
{
  return Trimmed(Stored(ds, tag));
}

void CopyPatientAndStudy(const std::string& ctFile, gdcm::DataSet& ds)
{
  gdcm::Reader reader;
  reader.SetFileName(ctFile.c_str());
  if (!reader.ReadUpToTag(gdcm::Tag(0x7fe0, 0x0010)))
    throw InputError(ctFile, "unreadable DICOM header");
  const gdcm::DataSet& source = reader.GetFile().GetDataSet();
  // Patient and General Study, as the CT has them (type 2 attributes empty when it has none).
  const uint16_t copied[][2] = { { 0x0008, 0x0005 }, { 0x0008, 0x0020 }, { 0x0008, 0x0030 }, { 0x0008, 0x0050 },
    { 0x0008, 0x0090 }, { 0x0008, 0x1030 }, { 0x0010, 0x0010 }, { 0x0010, 0x0020 }, { 0x0010, 0x0030 },
    { 0x0010, 0x0040 }, { 0x0020, 0x0010 } };
  const gdcm::VR copiedVR[] = { gdcm::VR::CS, gdcm::VR::DA, gdcm::VR::TM, gdcm::VR::SH, gdcm::VR::PN, gdcm::VR::LO,
    gdcm::VR::PN, gdcm::VR::LO, gdcm::VR::DA, gdcm::VR::CS, gdcm::VR::SH };
  for (size_t i = 0; i < sizeof(copied) / sizeof(copied[0]); ++i)
  {
    const gdcm::Tag tag(copied[i][0], copied[i][1]);
    if (tag == gdcm::Tag(0x0008, 0x0005) && !source.FindDataElement(tag))
      continue; // the default repertoire
    Put(ds, copied[i][0], copied[i][1], copiedVR[i], Value(source, tag));
  }
}

std::string BeginInstance(gdcm::DataSet& ds, const CTSeriesInfo& ct, const std::string& sopClassUID,
  const std::string& modality, const std::string& seriesDescription, const std::string& seriesUID)
{
  if (ct.files.empty() || ct.studyInstanceUID.empty())
    throw InputError(ct.files.empty() ? ct.directory : ct.files.front(),
      "Study Instance UID (0020,000D) missing: an object of the CT's study cannot be made");
  gdcm::Trace::WarningOff(); // xpose reports its own errors
  CopyPatientAndStudy(ct.files.front(), ds);
  const std::string sopInstanceUID = NewDICOMUID();
  Put(ds, 0x0008, 0x0016, gdcm::VR::UI, sopClassUID);
  Put(ds, 0x0008, 0x0018, gdcm::VR::UI, sopInstanceUID);
  PutNow(ds);
  Put(ds, 0x0008, 0x0060, gdcm::VR::CS, modality);
  Put(ds, 0x0008, 0x0070, gdcm::VR::LO, "xpose");
  Put(ds, 0x0008, 0x103e, gdcm::VR::LO, seriesDescription.substr(0, 64));
  Put(ds, 0x0018, 0x1020, gdcm::VR::LO, "xpose");
  Put(ds, 0x0020, 0x000d, gdcm::VR::UI, ct.studyInstanceUID);
  Put(ds, 0x0020, 0x000e, gdcm::VR::UI, seriesUID);
  Put(ds, 0x0020, 0x0011, gdcm::VR::IS, "1");
  return sopInstanceUID;
}

void PutNow(gdcm::DataSet& ds)
{
  const std::time_t now = std::time(nullptr);
  std::tm local{};
  localtime_r(&now, &local);
  char date[16], time[16];
  std::strftime(date, sizeof(date), "%Y%m%d", &local);
  std::strftime(time, sizeof(time), "%H%M%S", &local);
  Put(ds, 0x0008, 0x0012, gdcm::VR::DA, date); // Instance Creation Date
  Put(ds, 0x0008, 0x0013, gdcm::VR::TM, time);
  Put(ds, 0x0008, 0x0023, gdcm::VR::DA, date); // Content Date
  Put(ds, 0x0008, 0x0033, gdcm::VR::TM, time);
}

void PutUS(gdcm::DataSet& ds, uint16_t group, uint16_t element, uint16_t value)
{
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  de.SetByteValue(reinterpret_cast<const char*>(&value), 2);
  ds.Replace(de);
}

void PutPixelData(gdcm::DataSet& ds, gdcm::VR vr, const void* pixels, size_t bytes)
{
  std::string data(static_cast<const char*>(pixels), bytes);
  if (data.size() % 2)
    data.push_back('\0');
  gdcm::DataElement de(gdcm::Tag(0x7fe0, 0x0010));
  de.SetVR(vr);
  de.SetByteValue(data.data(), static_cast<uint32_t>(data.size()));
  ds.Replace(de);
}

bool ParseDecimal(const std::string& word, double& value)
{
  char* end = nullptr;
  value = std::strtod(word.c_str(), &end);
  if (end == word.c_str() || !std::isfinite(value))
    return false;
  for (; end != word.c_str() + word.size(); ++end)
    if (!std::isspace(static_cast<unsigned char>(*end)) && *end != '\0')
      return false;
  return true;
}

std::string TagText(uint16_t group, uint16_t element)
{
  char tag[16];
  std::snprintf(tag, sizeof(tag), "(%04X,%04X)", group, element);
  return tag;
}

std::vector<double> ReadNumbers(const gdcm::DataSet& ds, uint16_t group, uint16_t element, size_t count,
  const std::string& name, const std::string& path, bool required)
{
  const std::string text = Value(ds, gdcm::Tag(group, element));
  const std::string tag = TagText(group, element);
  if (text.empty())
  {
    if (required)
      throw InputError(path, name + " " + tag + " missing: the imager's geometry cannot be rebuilt");
    return {};
  }
  std::vector<double> values;
  std::stringstream words(text);
  std::string word;
  while (std::getline(words, word, '\\'))
  {
    double value = 0.0;
    if (!ParseDecimal(word, value))
      throw InputError(path, name + " " + tag + ": '" + word + "' is not a finite number");
    values.push_back(value);
  }
  if (values.size() != count)
    throw InputError(path, name + " " + tag + ": expected " + std::to_string(count) + " values, found " + std::to_string(values.size()));
  return values;
}

void ReadRowsAndColumns(const gdcm::DataSet& ds, const std::string& path, int& rows, int& columns)
{
  const gdcm::Tag rowsTag(0x0028, 0x0010), columnsTag(0x0028, 0x0011);
  uint16_t values[2] = { 0, 0 };
  for (int i = 0; i < 2; ++i)
  {
    const gdcm::Tag& tag = i == 0 ? rowsTag : columnsTag;
    if (!ds.FindDataElement(tag) || !ds.GetDataElement(tag).GetByteValue() || ds.GetDataElement(tag).GetByteValue()->GetLength() != 2)
      throw InputError(path, i == 0 ? "Rows (0028,0010) missing" : "Columns (0028,0011) missing");
    std::memcpy(&values[i], ds.GetDataElement(tag).GetByteValue()->GetPointer(), 2);
  }
  if (values[0] < 1 || values[1] < 1)
    throw InputError(path, "Rows (0028,0010) / Columns (0028,0011) must be at least 1");
  rows = values[0];
  columns = values[1];
}

void TagComparison::Compare(uint16_t group, uint16_t element, const std::string& name, const std::vector<double>& wanted,
  double tolerance, const std::string& unit, bool angle)
{
  const std::vector<double> found = ReadNumbers(this->DataSet, group, element, wanted.size(), name, this->Path, false);
  if (found.empty())
    return;
  bool apart = false;
  std::string foundText, wantedText;
  for (size_t i = 0; i < wanted.size(); ++i)
  {
    double difference = std::abs(found[i] - wanted[i]);
    if (angle)
      difference = std::min(difference, 360.0 - std::fmod(difference, 360.0));
    apart = apart || difference > tolerance;
    foundText += (i ? "\\" : "") + DS(found[i]);
    wantedText += (i ? "\\" : "") + DS(wanted[i]);
  }
  if (apart)
    this->Lines.push_back(name + " " + TagText(group, element) + " = " + foundText + " " + unit +
      ", the geometry file's imager " + this->Imager + " has " + wantedText + " " + unit);
}

bool GetFL(const gdcm::DataSet& ds, const gdcm::Tag& tag, float& value)
{
  if (!ds.FindDataElement(tag) || !ds.GetDataElement(tag).GetByteValue() || ds.GetDataElement(tag).GetByteValue()->GetLength() != 4)
    return false;
  std::memcpy(&value, ds.GetDataElement(tag).GetByteValue()->GetPointer(), 4);
  return true;
}

void WriteFile(gdcm::Writer& writer, const std::string& path, const std::string& what)
{
  writer.GetFile().GetHeader().SetDataSetTransferSyntax(gdcm::TransferSyntax::ExplicitVRLittleEndian);
  writer.SetFileName(path.c_str());
  if (!writer.Write())
  {
    std::remove(path.c_str());
    throw Error(path, "cannot write the DICOM " + what);
  }
}

} // namespace dicom
} // namespace xp
