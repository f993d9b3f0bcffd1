/**
 * @file xpDICOMSeriesWriter.h
 * @brief Writes a CT volume as a DICOM CT Image Storage series (one file per slice, GDCM).
 *
 * Used for the built-in phantom and by tests that need DICOM with known properties.
 */
#ifndef xpDICOMSeriesWriter_h
#define xpDICOMSeriesWriter_h

#include "vtkXPDICOMModule.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace xp
{

/** A CT volume in HU on a grid in DICOM patient coordinates (LPS), x fastest. */
struct CTVolumeData
{
  Eigen::Vector3i dimensions = Eigen::Vector3i::Zero();
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();               ///< mm
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();                ///< first voxel centre, LPS mm
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();         ///< columns: i, j, k axes in LPS
  std::vector<float> hounsfield;
};

struct CTSeriesWriteOptions
{
  std::string patientName = "XPOSE^PHANTOM";
  std::string patientID = "XP0001";
  std::string seriesDescription;
  std::string patientPosition = "HFS";
  std::string modality = "CT";          ///< tests write other values to check the reader refuses them
  std::string seriesInstanceUID;        ///< generated when empty
  std::string studyInstanceUID;         ///< generated when empty
  std::string filePrefix = "slice";     ///< files are <prefix>-NNNN.dcm
  double gantryTiltDegrees = 0.0;       ///< written to (0018,1120); slice positions are sheared to match
};

/** Writes `volume` into `directory` (which must exist); returns the file names in slice order. */
VTKXPDICOM_EXPORT std::vector<std::string> WriteCTSeries(
  const CTVolumeData& volume, const std::string& directory, const CTSeriesWriteOptions& options = {});

} // namespace xp

#endif
