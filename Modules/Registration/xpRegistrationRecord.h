/**
 * @file xpRegistrationRecord.h
 * @brief result.json: the record of one registration, written and read by this one unit
 *        (jsoncpp) for `xpose register`, `xpose report`, the Python example and the tests.
 *
 * The record holds what a clinical user acts on (status, correction, the gate's failures with
 * their codes), the figures behind it (similarity, explained information, masks, timing), and,
 * when a command wrote it, the inputs that let `xpose report` rebuild the pictures.
 */
#ifndef xpRegistrationRecord_h
#define xpRegistrationRecord_h

#include "vtkXPRegistrationModule.h"

#include "xpAttenuationVolume.h"
#include "xpCouch.h"
#include "xpStereoRegistration.h"

#include <optional>
#include <array>
#include <string>
#include <vector>

namespace xp
{

/** How the record's poses are to be read (Coordinates.md). */
inline constexpr const char* CorrectionConvention =
  "IEC 61217 fixed; p' = R(p - iso) + iso + t; R = Rz(yaw) Ry(roll) Rx(pitch)";

/** A registration's input files and the options that read them, as the options name them: what a
 *  command registers (RegistrationSources) and what result.json's `inputs` keeps of it. */
struct RegistrationFiles
{
  std::string ct;                   ///< DICOM folder, .mha/.mhd, .nii/.nii.gz or a TIFF stack (--ct)
  std::string series;               ///< Series Instance UID when the folder holds several (--series)
  std::optional<Eigen::Vector3d> voxelSize; ///< a TIFF stack's voxel size, mm (--voxel-size)
  std::string geometry;             ///< the stereo geometry JSON (--geometry)
  std::vector<std::string> xrays;   ///< one per imager, in the geometry's order (--xray)
  std::vector<std::string> rois;    ///< optional, one per X-ray (--roi)
  std::optional<Eigen::Vector2i> size; ///< registration resolution per view, dividing the panel; none: the X-rays' own (--size)
  std::optional<Eigen::Vector3d> isocenterInCT; ///< the CT point (LPS mm) at the isocentre; none: the CT's centre (--iso-ct)
  double muWater = WaterAttenuationPerMM; ///< water's attenuation per mm (--mu-water)
  bool removeTable = false;         ///< render DRRs from the segmented body, without the CT's table
};

/** The files and options a command registered (absolute paths), each X-ray's MD5 and whether the
 *  entropy masks were on: enough for `xpose report` to read them again and check they are the same. */
struct RegistrationRecordInputs : RegistrationFiles
{
  std::vector<std::string> xrayMD5;
  bool entropyMask = true;
};

struct RegistrationRecord
{
  bool ok = false;
  Pose misalignment, correction;
  /** For an ok result: the motion of the room's couch that carries out the correction as far as
   *  it can (xpCouch.h), the target it puts back (CT LPS mm) and the action levels that decided
   *  its action. */
  std::optional<CouchMotion> couch;
  Eigen::Vector3d targetInCT = Eigen::Vector3d::Zero();
  ActionLevels actionLevels;
  Pose initialPose; ///< where the search began (--initial-pose; zero: the planned set-up)
  bool boneOnly = false;                                   ///< matched within the bone's shadow
  std::optional<TableChoice> table; ///< with StereoRegistrationSettings::chooseTable: what the X-rays chose
  double restartsApartMM = -1.0, restartsApartDegrees = -1.0; ///< bones: restarts' farthest end (-1: none)
  std::vector<std::string> viewNames;
  std::vector<double> similarity, explained, uncovered, viewResidualMM, validFraction; ///< per view
  std::vector<double> xraySmoothingPixels; ///< per view: the X-ray's smoothing sd (pixels)
  std::vector<double> xrayRankNoise; ///< per view: the X-ray's noise on its ranks (levels of 4096)
  /** Per view, when the CT coverage mask was on: the anatomy each X-ray shows beyond the CT's
   *  end faces and the faces whose rays were left out (xpCTCoverage.h). */
  std::vector<EndFaceEvidence> endFaces;
  double objective = 0.0;
  std::vector<GateFailure> failures;
  long long drrCount = 0;
  std::string device = "cpu"; ///< where the rays were cast: "cpu" or "cuda (GPU name)"
  RenderStride searchRenderStride, fineRenderStride; ///< rays cast on every N-th pixel of rows and columns (StereoSimilarity::SetRenderStride)
  std::array<int, 3> finePlaneSteps{ { 1, 1, 1 } }; ///< the refinement's rays on every N-th voxel plane, per CT index axis
  int evaluations = 0;
  double readSeconds = 0.0, prealignSeconds = 0.0, maskSeconds = 0.0, fineSeconds = 0.0, totalSeconds = 0.0;
  double searchApartMM = 0.0, searchApartDegrees = 0.0, searchObjectiveRatio = 1.0;
  std::array<double, 6> uncertainty{}; ///< per axis (mm, degrees); infinite: no maximum along it
  /** Per view: correlation of the X-ray with the DRR at the start pose (< 0: bright means
   *  attenuation, as log images). */
  std::vector<double> xrayCorrelation;
  std::vector<double> halvesApartMM; ///< per view
  /** Per view: StereoRegistrationResult::edgeDistanceMM and edgeDistanceShiftedMM (empty in
   *  records written before them). */
  std::vector<double> edgeDistanceMM, edgeDistanceShiftedMM;
  double peakMargin = 0.0;
  std::array<double, 12> peakLeads{}; ///< StereoRegistrationResult::peakLeads
  /** The 6-DOF stages as they ran: where each begins in the trace, its evaluations, its images'
   *  size and its wall time (evaluations and size: 0 in records written before them). */
  std::vector<RegistrationStage> stages;
  std::vector<double> objectiveTrace;
  RegistrationSchedule schedule; ///< the stages as scheduled (empty in records written before it)
  /** The pre-alignment's 2D work beside the stereo evaluations: its iterations and DRRs. */
  int prealignIterations = 0;
  long long prealignDRRs = 0;
  std::optional<RegistrationRecordInputs> inputs; ///< absent when no command wrote the record
  /** The volume's own coordinates (a DICOM CT's patient LPS mm; a TIFF volume's voxel grid in mm,
   *  its first voxel at 0) to Room mm at the result, and the volume's centre in them: what places
   *  two bones registered apart in one frame (`xpose relative`). Absent when no command wrote
   *  the record, or in records written before them. */
  std::optional<Eigen::Isometry3d> volumeToRoom;
  Eigen::Vector3d volumeCenter = Eigen::Vector3d::Zero();

  std::vector<std::string> Reasons() const;
};

/**
 * One top-level field of result.json as the record's schema lists it. The schema is one table
 * (xpRegistrationRecord.cxx) from which the writer and the reader are both driven: a field is
 * added by one row there, and the user guide's table is checked against it by a test.
 */
struct RegistrationRecordField
{
  std::string name;    ///< the key in result.json
  std::string type;    ///< "text", "number", "pose", "per view", "object", ...
  std::string unit;    ///< "mm", "deg", "s", ... (empty: none, or mixed and named inside)
  std::string meaning; ///< one line
  /** When it is written: "always", or the condition under which the record holds it. */
  std::string presence;
  /** Whether a record without it is refused (false: absent in records written before it, or
   *  written only where it applies; the reader keeps the record's default). */
  bool required = false;
  /** Whether the reader takes it back (false: derived from other fields, as `reasons`). */
  bool read = true;
};

/** result.json's fields, in the order the reader takes them. */
VTKXPREGISTRATION_EXPORT const std::vector<RegistrationRecordField>& RegistrationRecordSchema();

/** The record of a result whose views carry `viewNames`; timings of reading and of the whole
 *  run are the caller's. */
VTKXPREGISTRATION_EXPORT RegistrationRecord MakeRegistrationRecord(
  const StereoRegistrationResult& result, const std::vector<std::string>& viewNames);

/** result.json's text. */
VTKXPREGISTRATION_EXPORT std::string RegistrationRecordJSON(const RegistrationRecord& record);

/** Parses result.json's text; throws xp::InputError naming `origin` (the file) and the field. */
VTKXPREGISTRATION_EXPORT RegistrationRecord ParseRegistrationRecord(const std::string& text, const std::string& origin);

/** Reads and parses a result.json file. */
VTKXPREGISTRATION_EXPORT RegistrationRecord ReadRegistrationRecord(const std::string& path);

} // namespace xp

#endif
