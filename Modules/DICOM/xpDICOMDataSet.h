/**
 * @file xpDICOMDataSet.h
 * @brief Small helpers for the DICOM objects xpose writes (module-private): elements with the
 *        padding DICOM wants, sequences, decimal strings, and the patient and study of a CT.
 */
#ifndef xpDICOMDataSet_h
#define xpDICOMDataSet_h

#include "xpDICOMSeries.h"

#include <gdcmDataSet.h>
#include <gdcmWriter.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace xp
{
namespace dicom
{

/** A text element; UI values are padded with NUL, others with a space, to even length. */
gdcm::DataElement Text(uint16_t group, uint16_t element, gdcm::VR vr, std::string value);
void Put(gdcm::DataSet& ds, uint16_t group, uint16_t element, gdcm::VR vr, const std::string& value);
/** A sequence element holding `items` (each a data set). */
void PutSequence(gdcm::DataSet& ds, uint16_t group, uint16_t element, const std::vector<gdcm::DataSet>& items);
/** A decimal string of at most 16 characters. */
std::string DS(double value);
/** The value of `tag` in `ds` without its padding, empty when absent. */
std::string Value(const gdcm::DataSet& ds, const gdcm::Tag& tag);
/**
 * Copies the Patient and General Study attributes of the CT file `ctFile` into `ds` (type 2
 * ones empty where the CT has none). Throws xp::InputError naming the file when it cannot be read.
 */
void CopyPatientAndStudy(const std::string& ctFile, gdcm::DataSet& ds);
/**
 * Starts an instance of the CT's study in `ds`: patient and study copied from the CT's first
 * file, SOP class and a new SOP Instance UID (returned), creation and content date and time,
 * modality, xpose as manufacturer and software, and series `seriesUID` (number 1). Throws
 * xp::InputError naming the CT when it has no file or no Study Instance UID.
 */
std::string BeginInstance(gdcm::DataSet& ds, const CTSeriesInfo& ct, const std::string& sopClassUID,
  const std::string& modality, const std::string& seriesDescription, const std::string& seriesUID);

/** One value of a decimal string (DS): a finite number, blanks and NULs after it allowed. Not
 *  std::stod, which takes "nan" and "inf", which no decimal string may hold. */
bool ParseDecimal(const std::string& word, double& value);
/** "(0018,1110)" */
std::string TagText(uint16_t group, uint16_t element);
/**
 * The numbers of a DS/IS element: exactly `count` finite ones; none when the element is absent
 * and not `required`. Throws xp::InputError naming `path`, `name` and the tag otherwise.
 */
std::vector<double> ReadNumbers(const gdcm::DataSet& ds, uint16_t group, uint16_t element, size_t count,
  const std::string& name, const std::string& path, bool required);
/** Rows (0028,0010) and Columns (0028,0011), at least 1; throws xp::InputError naming `path`. */
void ReadRowsAndColumns(const gdcm::DataSet& ds, const std::string& path, int& rows, int& columns);

/** Compares geometry tags of a file with the values a geometry file's imager implies. */
class TagComparison
{
public:
  TagComparison(const gdcm::DataSet& ds, const std::string& path, const std::string& imager)
    : DataSet(ds)
    , Path(path)
    , Imager(imager)
  {
  }
  /** Adds a line when the element is present and one of its values is beyond `tolerance` of
   *  `wanted` (angles: around the circle). */
  void Compare(uint16_t group, uint16_t element, const std::string& name, const std::vector<double>& wanted,
    double tolerance, const std::string& unit, bool angle);
  /** Adds a line as it is. */
  void Add(const std::string& line) { this->Lines.push_back(line); }
  const std::vector<std::string>& Differences() const { return this->Lines; }

private:
  const gdcm::DataSet& DataSet;
  std::string Path;
  std::string Imager;
  std::vector<std::string> Lines;
};

/** Content / instance creation date and time (DA, TM) of now, local time. */
void PutNow(gdcm::DataSet& ds);
/** A binary unsigned short (US) element, little-endian as the transfer syntax. */
void PutUS(gdcm::DataSet& ds, uint16_t group, uint16_t element, uint16_t value);
/** Pixel data (7FE0,0010) of `bytes` bytes (padded to even length) as `vr` (OB or OW). */
void PutPixelData(gdcm::DataSet& ds, gdcm::VR vr, const void* pixels, size_t bytes);
/** The binary float (FL) element `tag`, if present and four bytes long. */
bool GetFL(const gdcm::DataSet& ds, const gdcm::Tag& tag, float& value);
/**
 * Writes `writer`'s data set to `path` (explicit VR little endian, file meta information
 * filled in); on failure removes what was written and throws xp::Error naming `path` and `what`.
 */
void WriteFile(gdcm::Writer& writer, const std::string& path, const std::string& what);

} // namespace dicom
} // namespace xp

#endif
