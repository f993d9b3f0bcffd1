/**
 * @file xpRegistrationSession.h
 * @brief One registration: its inputs read and checked, the registration filter run on them,
 *        and its result as one value (the record that result.json holds).
 *
 * `xpose register` (and so `track` and `listen`, which register through it), each trial of
 * `xpose evaluate` and the Python class vtkXPRegistrationSession drive this object: sources fill
 * it (files: xpRegistrationSources.h; images in memory: the second constructor), writers consume
 * what it yields (xpRegistrationWriters.h), and a command adds only its options, its console lines
 * and its choice of writers.
 */
#ifndef xpRegistrationSession_h
#define xpRegistrationSession_h

#include "vtkXPSessionModule.h"

#include "xpGlobalSearch.h"
#include "xpRegistrationRecord.h"
#include "xpRegistrationSources.h"
#include "xpStereoRegistration.h"

#include <vtkSmartPointer.h>

#include <vector>

class vtkXPStereoRegistrationFilter;

namespace xp
{

class VTKXPSESSION_EXPORT RegistrationSession
{
public:
  /** Reads and checks every input of `sources` before any registration work; throws
   *  xp::InputError naming the file or the option. */
  explicit RegistrationSession(const RegistrationSources& sources);
  /**
   * A session on images in memory (the trials of `xpose evaluate`): the CT in HU placed by
   * `patient`, and the geometry at the registration size; the X-rays come with SetXRays. The CT's
   * attenuation volume is kept between runs.
   */
  RegistrationSession(vtkImageData* ct, const PatientSetup& patient, const StereoGeometry& geometry,
    double muWater = WaterAttenuationPerMM);
  ~RegistrationSession();
  RegistrationSession(const RegistrationSession&) = delete;
  RegistrationSession& operator=(const RegistrationSession&) = delete;

  /** Replaces the X-rays (one per imager, at the geometry's panel size) and ROIs (none, or one
   *  each), and Inputs().views with them; throws xp::InputError when one does not fit its imager. */
  void SetXRays(const std::vector<vtkSmartPointer<vtkImageData>>& xrays,
    const std::vector<vtkSmartPointer<vtkImageData>>& rois = {});

  /** A session read from files: its X-rays replaced by `xrays` (one per imager, the ROIs as
   *  before), read and checked like the first; the CT stays as read (a tracked frame). */
  void ReadXRays(const std::vector<std::string>& xrays);

  /** The files it was read from; empty for a session on images in memory. */
  const RegistrationSources& Sources() const { return this->Given; }
  const RegistrationInputs& Inputs() const { return this->Read; }
  /** Whether it was read from files (the DICOM writer and `xpose report` need them). */
  bool FromFiles() const { return !this->Given.ct.empty(); }
  /** Seconds spent reading and checking the inputs. */
  double ReadSeconds() const { return this->SecondsToRead; }

  /**
   * Starts for a volume that has no planned set-up (a bone cut from a CT, xpGlobalSearch.h), best
   * first; throws xp::InputError naming --global-search when no orientation matches both X-rays.
   */
  std::vector<GlobalCandidate> FindStarts() const;

  /** The registration filter, set up with the inputs: observe its progress before Run, read its
   *  output images (per view: DRR, mask, entropy map) after. */
  vtkXPStereoRegistrationFilter* Filter() const;

  /**
   * Registers with `settings` (its initialPose: where the search starts, zero for the planned
   * set-up) and returns the result's record, its files included when it was read from them;
   * throws xp::InputError when the filter refuses an input.
   */
  const RegistrationRecord& Run(const StereoRegistrationSettings& settings);

  /** After Run: the registration's result, the settings it ran with and its record. */
  const StereoRegistrationResult& Result() const;
  const StereoRegistrationSettings& Settings() const { return this->RunSettings; }
  const RegistrationRecord& Record() const { return this->Recorded; }
  /** After Run: the record's read and total times as a driver measured them on its own clock,
   *  from its start (by default they count the session's own work only). */
  void SetTimes(double readSeconds, double totalSeconds)
  {
    this->Recorded.readSeconds = readSeconds;
    this->Recorded.totalSeconds = totalSeconds;
  }

private:
  void SetUpFilter();
  /** The filter's X-rays and ROIs: Read's. */
  void GiveXRaysToFilter();

  RegistrationSources Given;
  RegistrationInputs Read;
  double SecondsToRead = 0.0;
  vtkSmartPointer<vtkXPStereoRegistrationFilter> Registration;
  StereoRegistrationSettings RunSettings;
  RegistrationRecord Recorded;
};

/** What `xpose report` needs to rebuild the pictures: the sources with absolute paths, the X-rays'
 *  MD5 sums, and whether the entropy mask was on. */
VTKXPSESSION_EXPORT RegistrationRecordInputs RecordedInputs(const RegistrationSources& sources, bool entropyMask);

} // namespace xp

#endif
