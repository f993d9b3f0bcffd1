/**
 * @file xpHeadPhantom.h
 * @brief A procedural CT of a head on a head rest, in HU, DICOM patient coordinates (HFS).
 *
 * Skin and scalp, a skull of cortical and diploe bone, brain with ventricles, orbits and eyes,
 * air sinuses and the nasal cavity, dense petrous bones, maxilla, mandible and teeth, the
 * cervical spine, and fixation objects present in the CT: a carbon-fibre head rest, the couch
 * top, a thermoplastic mask and its frame. The centre of the volume is the LPS origin.
 */
#ifndef xpHeadPhantom_h
#define xpHeadPhantom_h

#include "vtkXPPhantomModule.h"

#include "xpDICOMSeriesWriter.h"

namespace xp
{

/** HU of the phantom at a point (LPS mm, head centred at the origin). */
VTKXPPHANTOM_EXPORT double HeadPhantomHU(const Eigen::Vector3d& lps);

/** The phantom sampled on an axial grid of isotropic `spacing` mm covering the whole head. */
VTKXPPHANTOM_EXPORT CTVolumeData MakeHeadPhantom(double spacing = 1.0);

} // namespace xp

#endif
