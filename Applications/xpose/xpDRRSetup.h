// Shared set-up of the DRR filter for the `drr` and `bench` subcommands (internal header).
#ifndef xpDRRSetup_h
#define xpDRRSetup_h

#include "vtkXPDRRFilter.h"
#include "xpDICOMSeries.h"
#include "xpRTImage.h"
#include "xpStereoGeometry.h"
#include "xpVolumeIO.h"

#include <vtkSmartPointer.h>

#include <string>

namespace xp
{

struct DRRSetup
{
  CTVolume ct;
  StereoGeometry geometry;
  PatientSetup patient;
  vtkSmartPointer<vtkXPDRRFilter> filter;
};

/**
 * Reads the geometry and the CT and configures one DRR filter (view set later per imager).
 * `isocenterInCT` is "x,y,z" in LPS mm or empty for the CT centre; `method` trilinear|siddon; `voxelSize` "x,y,z" mm for a TIFF volume (--voxel-size), else empty.
 */
DRRSetup MakeDRRSetup(const std::string& ctPath, const std::string& series, const std::string& voxelSize,
  const std::string& geometryPath,
  const std::string& isocenterInCT, double muWater, const std::string& method, double stepSize);

/**
 * The CT series that DICOM output refers to, checked before any work: `option` (--dicom-out)
 * needs the CT as a DICOM series with a Study Instance UID and a Frame of Reference UID.
 */
CTSeriesInfo DICOMSeriesForOutput(const std::string& ct, const std::string& series, const std::string& option);

/** Checks, before any work, that every imager of `geometry` can be written as an RT Image
 *  (panels normal to the beam axis, not mirrored); throws xp::InputError naming `option`. */
void CheckRTImageViews(const StereoGeometry& geometry, const std::string& option);

/** The RT Image of the 12-bit DRR the filter rendered last (output 0) for its output view. */
RTImageDRR RTImageOfLastDRR(const DRRSetup& setup, const std::string& description);

} // namespace xp

#endif
