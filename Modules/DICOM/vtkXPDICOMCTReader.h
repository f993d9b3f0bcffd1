/**
 * @class vtkXPDICOMCTReader
 * @brief Reads one DICOM CT series from a folder into vtkImageData in Hounsfield units.
 *
 * Output: HU as 16-bit integers (VTK_SHORT) when every slice stores integers of at most 16 bits
 * with Rescale Slope 1 and a whole Rescale Intercept - the usual CT - with the rare values
 * beyond -32768..32767 (padding, overflow) clamped; as float otherwise. Origin, spacing and
 * DirectionMatrix from Image Position/Orientation
 * (Patient) so that index-to-physical gives DICOM patient coordinates (LPS, mm); slices sorted
 * along the slice normal. Compressed transfer syntaxes are decoded by GDCM. Errors (corrupt
 * file, several series, missing slice, gantry tilt, not a CT) are reported with vtkErrorMacro
 * and kept in GetErrorText().
 */
#ifndef vtkXPDICOMCTReader_h
#define vtkXPDICOMCTReader_h

#include "vtkImageAlgorithm.h"
#include "vtkXPDICOMModule.h"

#include <memory>
#include <string>

namespace xp
{
struct CTSeriesInfo;
}

class VTKXPDICOM_EXPORT vtkXPDICOMCTReader : public vtkImageAlgorithm
{
public:
  static vtkXPDICOMCTReader* New();
  vtkTypeMacro(vtkXPDICOMCTReader, vtkImageAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /** The folder holding the series (not searched recursively). */
  vtkSetStdStringFromCharMacro(DirectoryName);
  vtkGetCharFromStdStringMacro(DirectoryName);
  ///@}

  ///@{
  /** Series Instance UID to read when the folder holds several; empty means "the only one". */
  vtkSetStdStringFromCharMacro(SeriesInstanceUID);
  vtkGetCharFromStdStringMacro(SeriesInstanceUID);
  ///@}

  /** Patient Position (0018,5100) of the series read ("HFS" when absent); valid after Update. */
  std::string GetPatientPosition() const;

  /** The message of the last failure, empty after a successful update. */
  const std::string& GetErrorText() const { return this->ErrorText; }

protected:
  vtkXPDICOMCTReader();
  ~vtkXPDICOMCTReader() override;

  int RequestInformation(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  std::string DirectoryName;
  std::string SeriesInstanceUID;
  std::string ErrorText;
  std::unique_ptr<xp::CTSeriesInfo> Info;

private:
  vtkXPDICOMCTReader(const vtkXPDICOMCTReader&) = delete;
  void operator=(const vtkXPDICOMCTReader&) = delete;
};

#endif
