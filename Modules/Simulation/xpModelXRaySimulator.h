/**
 * @file xpModelXRaySimulator.h
 * @brief X-rays made with the DRR filter's own image model (monochromatic, trilinear, -950 HU air),
 *        optionally re-weighted: the "own-model" scenarios of `xpose evaluate`. They cannot show a
 *        bias of that model; XRayPhysicsSimulator (xpXRayPhysics.h) can.
 */
#ifndef xpModelXRaySimulator_h
#define xpModelXRaySimulator_h

#include "vtkXPSimulationModule.h"

#include "vtkXPDRRFilter.h"
#include "xpPose.h"
#include "xpXRayView.h"

#include <vtkImageData.h>
#include <vtkSmartPointer.h>

#include <cstdint>
#include <random>
#include <vector>

namespace xp
{

struct XRaySimulation
{
  double noise = 0.0;       ///< quantum noise sd, 12-bit grey levels at full transmission
  bool kvContrast = false;  ///< bone attenuates more than the DRR's linear HU model says
  bool addObjects = false;  ///< a couch rail and a frame corner that only the X-ray shows
};

/**
 * Renders X-rays of one CT for many poses: the CT's attenuation model (kV contrast or not) is
 * built once. Images are 12-bit transmission, row 0 at the top.
 */
class VTKXPSIMULATION_EXPORT XRaySimulator
{
public:
  XRaySimulator(vtkImageData* ct, const PatientSetup& patient, const XRaySimulation& simulation);

  std::vector<uint16_t> Simulate(const XRayView& view, const Pose& misalignment, std::mt19937& random);

private:
  XRaySimulation Simulation;
  vtkSmartPointer<vtkImageData> CT;
  vtkSmartPointer<vtkXPDRRFilter> Filter;
};

} // namespace xp

#endif
