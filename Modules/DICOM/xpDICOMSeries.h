/**
 * @file xpDICOMSeries.h
 * @brief Finding, checking and reading one CT series in a folder of DICOM files (GDCM).
 *
 * Slices are sorted by their position along the slice normal (never by file name), and the
 * series is refused, with the file named, when it could not give a correct volume: unreadable or
 * truncated files, several series without a choice, a missing slice or non-uniform spacing,
 * gantry tilt, mixed sizes or orientations, not a CT.
 */
#ifndef xpDICOMSeries_h
#define xpDICOMSeries_h

#include "vtkXPDICOMModule.h"

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace xp
{

struct VTKXPDICOM_EXPORT CTSeriesInfo
{
  std::string directory;
  std::string seriesInstanceUID;
  std::string seriesDescription;
  std::string patientPosition;         ///< DICOM (0018,5100), "HFS" when absent
  std::vector<std::string> files;      ///< sorted along the slice normal
  std::vector<std::string> sopInstanceUIDs; ///< of `files`, in the same order
  std::string sopClassUID;             ///< of the first file (CT Image Storage, or Enhanced ...)
  std::string studyInstanceUID;        ///< of the first file
  std::string frameOfReferenceUID;     ///< of the first file; empty when it has none
  int columns = 0;                     ///< pixels per row
  int rows = 0;                        ///< rows per slice
  Eigen::Vector3d spacing;             ///< between columns, between rows, between slices (mm)
  Eigen::Vector3d origin;              ///< centre of the first voxel, LPS mm
  Eigen::Matrix3d direction;           ///< columns: row direction, column direction, slice normal
  /** Every slice stores integers of at most 16 bits with Rescale Slope 1 and a whole Rescale
   *  Intercept: its HU are whole numbers, kept as 16-bit integers (clamped to -32768..32767). */
  bool wholeHU16 = false;
};

/**
 * Scans `directory` (not recursively) and returns the CT series there. With several series
 * present, `seriesUID` selects one; empty and ambiguous throws xp::InputError listing them.
 */
VTKXPDICOM_EXPORT CTSeriesInfo ScanCTSeries(const std::string& directory, const std::string& seriesUID = "");

/**
 * Reads the pixels of a scanned series in Hounsfield units (rescale slope/intercept applied),
 * x fastest, slice by slice in sorted order, into `hounsfield`, which has room for
 * columns x rows x slices values. Throws xp::InputError naming the file that fails.
 */
VTKXPDICOM_EXPORT void ReadCTSeriesVoxels(const CTSeriesInfo& info, float* hounsfield);
/** The same as 16-bit HU, for a series whose info.wholeHU16 is set. */
VTKXPDICOM_EXPORT void ReadCTSeriesVoxels(const CTSeriesInfo& info, int16_t* hounsfield);

} // namespace xp

#endif
