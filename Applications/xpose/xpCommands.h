/**
 * @file xpCommands.h
 * @brief The subcommands of `xpose`, as functions that return the process exit code.
 *
 * Exit codes: 0 success, 1 internal failure, 2 bad input (a file, a field or an option).
 * Every command writes its files into a staging folder and moves them into place only when all
 * of them are complete.
 */
#ifndef xpCommands_h
#define xpCommands_h

#include "xpAttenuationVolume.h" // WaterAttenuationPerMM
#include "xpRegistrationSources.h"  // RegistrationSources
#include "xpSessionOptions.h"       // the option checks the session shares
#include "xpStereoRegistration.h"   // StereoRegistrationSettings

#include <Eigen/Core>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace xp
{

class RegistrationSession;

struct RegistrationRecord;
struct Pose;

enum ExitCode
{
  ExitOk = 0,
  ExitFailure = 1,
  ExitBadInput = 2,
  ExitRegistrationFailed = 3 ///< the images do not support a confident correction
};

struct PhantomOptions
{
  std::string outputDirectory;
  double spacing = 1.0; ///< mm, isotropic
};

struct DRROptions
{
  std::string ct;             ///< DICOM folder, .mha/.mhd, .nii/.nii.gz or a TIFF stack
  std::string series;         ///< Series Instance UID when the folder holds several
  std::string voxelSize;      ///< "x,y,z" mm, for a TIFF stack
  std::string geometry;       ///< geometry JSON (Coordinates.md)
  std::string size;           ///< "COLSxROWS"; empty = the panel's own size
  std::string pose = "0,0,0,0,0,0";
  std::string isocenterInCT;  ///< "x,y,z" LPS mm; empty = CT centre
  std::string maskDirectory;  ///< holds mask_NAME.png per imager (non-zero = render)
  std::string method = "trilinear";
  double stepSize = 0.0;      ///< mm; 0 = smallest voxel spacing
  double muWater = WaterAttenuationPerMM; ///< 1/mm
  int threads = 0;            ///< 0 = all cores
  std::string device = "cpu";       ///< --device: auto | cpu | cuda (xpRayCaster.h, ChooseComputeDevice)
  std::string outputDirectory;
  std::string dicomOutputDirectory; ///< when set, the DRRs as RT Images too (needs a DICOM CT)
};

/** The registration settings every command starts from: the library's, with the CT's table
 *  chosen by the X-rays (--choose-table; --keep-table and --remove-table decide it instead). */
inline StereoRegistrationSettings CommandSettings()
{
  StereoRegistrationSettings settings;
  settings.chooseTable = true;
  return settings;
}

struct BenchOptions
{
  std::string ct;
  std::string series;
  std::string geometry;
  std::vector<std::string> sizes{ "256x192", "512x384", "1024x768" };
  std::vector<std::string> methods{ "trilinear", "siddon" };
  std::string maskSize = "1024x768";
  std::vector<double> validFractions{ 0.10, 0.25, 0.50 };
  int repetitions = 3;
  std::string device = "cpu";       ///< --device: auto | cpu | cuda (xpRayCaster.h, ChooseComputeDevice)
};

/** `xpose bench register`: registrations of simulated misalignments, timed per stage, once per
 *  optimiser on the same trials. */
struct BenchRegisterOptions
{
  std::string ct;
  std::string series;
  std::string geometry;
  std::string scenario = "clinical";
  std::string detector;             ///< empty: the scenario's own X-rays
  /** Clinical effects switched off, as evaluate's: "truncation" registers against a CT that
   *  covers the X-rays' whole field, as most users' CTs do (twice the valid pixels here). */
  std::vector<std::string> without;
  bool chooseTable = true;          ///< as register's --choose-table, --keep-table, --remove-table
  bool removeTable = false;
  int trials = 5;
  std::string size = "512x384";
  /** One name for every 6-DOF stage, or SEARCH/REFINEMENT: the default's against the paper's. */
  std::vector<std::string> optimizers{ DefaultOptimizers(), "nelder-mead" };
  /** Render strides compared, SEARCH/FINE (StereoRegistrationSettings::searchRenderStride,
   *  fineRenderStride), each with every optimiser. */
  std::vector<std::string> renderStrides{ "1/0" };
  /** The coarse searches' travel compared: "half" (the default) and/or "quarter"
   *  (StereoRegistrationSettings::quarterSizeTravel), each with every other variant. */
  std::vector<std::string> travels{ "half" };
  /** The schedules compared: "standard" and/or "economy" (StereoRegistrationSettings::schedule),
   *  each with every other variant. */
  std::vector<std::string> schedules{ "economy" };
  unsigned seed = 11;
  double minTranslation = 1.0, maxTranslation = 20.0, maxRotation = 5.0;
  int threads = 0;
  std::string device = "cpu";       ///< --device: auto | cpu | cuda (xpRayCaster.h, ChooseComputeDevice)
};

struct MaskOptions
{
  std::string xray;           ///< 16-bit PNG with 12-bit values
  std::string roi;            ///< optional PNG, non-zero = allowed
  int window = 7;             ///< block size at half resolution
  int binWidth = 32;          ///< grey levels per bin
  std::string outputDirectory;
};

struct SimulateOptions
{
  std::string ct;
  std::string series;
  std::string geometry;
  std::string pose = "0,0,0,0,0,0"; ///< the true misalignment
  std::string size;
  std::string isocenterInCT;
  double noise = 0.0;               ///< quantum noise, 12-bit grey levels (sd) at full transmission
  bool kvContrast = false;          ///< a different attenuation model than the DRR's
  bool addObjects = false;          ///< a couch rail and a frame corner only the X-ray shows
  std::string preset = "model";     ///< model (the DRR's own image model) | clinical (physics simulator)
  std::vector<std::string> without; ///< clinical: effects turned off (xp::PhysicsEffects())
  unsigned seed = 1;
  int threads = 0;
  std::string outputDirectory;
};

/** `xpose register`: the session's sources (--ct, --geometry, --xray, ...), then the options of the
 *  method, the gate and the outputs. */
struct RegisterOptions : RegistrationSources
{
  std::string initialPose;          ///< "tx,ty,tz,pitch,roll,yaw"; empty = the planned set-up
  std::string optimizer = DefaultOptimizers(); ///< of the 6-DOF stages: one name, or SEARCH/REFINEMENT
  bool globalSearch = false;        ///< find the start (xpGlobalSearch.h); always for a TIFF volume without initialPose
  StereoRegistrationSettings settings = CommandSettings(); ///< the method and its quality gate, as the options set them
  int threads = 0;
  std::string device = "cpu";       ///< --device: auto | cpu | cuda (xpRayCaster.h, ChooseComputeDevice)
  std::string outputDirectory;
  std::string reportDirectory;      ///< when set, the visual report is written there too
  /** When set, an `ok` result is also written there as a DICOM Spatial Registration (reg.dcm)
   *  from the CT's Frame of Reference; the CT must be a DICOM series. */
  std::string dicomOutputDirectory;
  /** The archive to take the CT and X-rays from, by UID, and to store the DICOM results in: a
   *  DICOMweb service root (http(s)://HOST:PORT/PATH) or a DIMSE node (dicom://CALLED_AET@HOST:PORT);
   *  `ct` and `xrays` are then left empty. */
  std::string pacs;
  std::string aet = "XPOSE";        ///< with a dicom:// pacs: xpose's own (calling) AE title
  /** With pacs: a private file holding user:password or token:VALUE; empty: the environment's
   *  XPOSE_PACS_USER/XPOSE_PACS_PASSWORD or XPOSE_PACS_TOKEN, if any. */
  std::string pacsCredentials;
  std::string caFile;               ///< with an https pacs: the CAs to trust (PEM); empty: the system's
  std::string study;                ///< with pacs: the study whose one CT series is registered
  std::string ctSeries;             ///< with pacs: or the CT series by UID
  std::vector<std::string> xrayInstances; ///< with pacs: the X-rays' SOP Instance UIDs, in imager order
};

/** `xpose track`: the registration's options, one stereo pair per frame. */
struct TrackOptions
{
  RegisterOptions registration;     ///< all but xrays, rois, outputDirectory, reportDirectory and DICOM/PACS
  std::vector<std::string> frames;  ///< per frame "A.tif,B.tif": one X-ray per imager, in the geometry's order
  std::string outputDirectory;      ///< poses.csv, poses.json, frame-NNNN/result.json
  std::string reportDirectory;      ///< when set, each frame's report in DIR/frame-NNNN/
};

/** `xpose listen`: a DICOM storage node that registers each study's CT and X-ray pair. */
struct ListenOptions
{
  RegisterOptions registration;     ///< geometry, registration and gate options; inputs and outputs are per study
  int port = 104;
  std::string aet = "XPOSE";        ///< the node's AE title
  std::vector<std::string> allowAET; ///< calling AE titles admitted; empty: any
  std::string forward;              ///< dicom://AET@HOST:PORT: where an ok result's REG is sent
  double settle = 10.0;             ///< seconds without a new instance before a study is registered
  std::string outputDirectory;      ///< DIR/STUDY_UID/ per study
};

struct ReportOptions
{
  std::string result;               ///< result.json of `xpose register`
  std::string outputDirectory;      ///< default: "report" beside result.json
};

/** Two volumes registered apart to the same X-rays (two bones of one frame), frame by frame. */
struct RelativeOptions
{
  std::vector<std::string> reference; ///< result.json per frame: the bone the other is given in
  std::vector<std::string> moving;    ///< result.json per frame, as many
};

struct EvaluateOptions
{
  std::string ct;
  std::string series;
  std::string geometry;
  int trials = 50;
  double minTranslation = 1.0;      ///< initial translation error drawn in [min, max] mm
  double maxTranslation = 30.0;
  double maxRotation = 5.0;         ///< each angle drawn in [-max, max] degrees
  unsigned seed = 1;
  std::string size;                 ///< registration resolution COLSxROWS (default: the panel's)
  std::string scenario = "noisy";   ///< clean | noisy | objects | truncated | clinical
  std::vector<std::string> without; ///< clinical: effects turned off (physics effects, "truncation")
  bool removeTable = false;         ///< --remove-table: register against the body alone
  /** Registration steps switched off, to measure what each does: levels, high-pass, coverage. */
  std::vector<std::string> registrationOff;
  std::string optimizer = DefaultOptimizers(); ///< as register's --optimizer: SEARCH or SEARCH/REFINEMENT
  StereoRegistrationSettings settings = CommandSettings(); ///< each approach's, but for the entropy mask
  std::vector<std::string> approaches{ "A", "B" };
  double noise = 30.0;              ///< quantum noise of the noisy scenarios, grey levels
  std::string detector;             ///< clinical, plastimatch: linear12 | linear16 | log | processed
  double dose = 20000.0;            ///< with a detector: Poisson quanta per pixel at full transmission
  double electronicNoise = 0.001;   ///< with a detector: read-out noise, fraction of the open field
  std::string xrayCT;               ///< the X-rays show this CT instead (another patient)
  std::string xrayStretch;          ///< "AXIS,FACTOR": the X-rays show the CT stretched (near anatomy)
  bool writeXRays = false;          ///< also write each trial's X-rays as PNG
  double successMTRE = 1.0;         ///< mm
  int threads = 0;
  std::string device = "cpu";       ///< --device: auto | cpu | cuda (xpRayCaster.h, ChooseComputeDevice)
  std::string outputDirectory;
};

/** Runs `body`, turning xp::InputError into exit code 2 and other exceptions into 1, with one
 *  line on stderr: "xpose <command>: error: <message>". */
int GuardedRun(const std::string& command, const std::function<int()>& body);

/** `xpose geometry`: a geometry file from the imagers' 3x4 projection matrices or pinhole
 *  calibrations (xpProjectionMatrix.h). */
struct GeometryOptions
{
  std::vector<std::string> projectionMatrices; ///< one text file per imager
  std::vector<std::string> intrinsics;         ///< or K files, one per imager
  std::vector<std::string> extrinsics;         ///< with [R | t] files, one per imager
  std::vector<std::string> dicom;              ///< or DICOM X-rays (RT Image, DX, CR, XA), one per imager
  std::vector<std::string> cameraCalibrations; ///< or XMALab camera calibrations, one per imager
  std::string patientPosition;                 ///< for a DX/CR/XA without Patient Position (0018,5100)
  std::string check;                           ///< with `dicom`: compare them with this geometry file instead
  std::vector<std::string> names;              ///< the imagers' names; empty = A, B, ...
  std::string pixelSpacing;                    ///< "MM" or "COLUMN_MM,ROW_MM"
  std::string size;                            ///< "COLSxROWS"
  /** Room mm; empty = 0,0,0, or with camera calibrations the central rays' closest approach. */
  std::string isocenter;
  std::string output;                          ///< the geometry JSON to write
};

int RunPhantom(const PhantomOptions& options);
int RunGeometry(const GeometryOptions& options);
int RunDRR(const DRROptions& options);
int RunBenchDRR(const BenchOptions& options);
/** What the benches print of the machine: the CPU's model (Linux's /proc/cpuinfo; "an unnamed
 *  CPU" elsewhere), its hardware threads and the ray caster's path (RayCasterPathDescription). */
std::string BenchMachineDescription();
int RunBenchRegister(const BenchRegisterOptions& options);
int RunMask(const MaskOptions& options);
int RunSimulate(const SimulateOptions& options);
int RunRegister(const RegisterOptions& options);
/** RunRegister on local files (options.ct and options.xrays): reads, registers, writes every
 *  output asked for and prints the result; returns the record written as result.json. */
RegistrationRecord RegisterFiles(const RegisterOptions& options);
/** The same with a session kept between calls (track's frames): when `session` holds one, its CT
 *  (options.ct, as read for an earlier call) is kept and only options.xrays are read; else a new
 *  one is read and left there. */
RegistrationRecord RegisterFiles(const RegisterOptions& options, std::unique_ptr<RegistrationSession>& session);
int RunEvaluate(const EvaluateOptions& options);
int RunReport(const ReportOptions& options);
/** The visual report of a registration whose result.json and masks are in `resultFolder`, from
 *  its record and the inputs it read (register passes its own; report reads them again). */
void WriteReportOf(
  const RegistrationRecord& result, const RegistrationInputs& inputs, const std::string& resultFolder, const std::string& directory);
/** Prints, per frame, the moving volume's pose in the reference volume's coordinates (both
 *  from their result.json's volume_to_room) and its change from the first frame. */
int RunRelative(const RelativeOptions& options);
/** Registers frame after frame, each from the previous frame's result (the first from
 *  --initial-pose, the global search or the planned set-up); writes poses.csv and poses.json.
 *  ExitOk when every frame is ok, ExitRegistrationFailed when one is not. */
int RunTrack(const TrackOptions& options);
/** Serves until SIGTERM or SIGINT; each study that holds one CT series and one X-ray per imager
 *  (assigned by their geometry tags) is registered when it goes quiet, again for each new pair. */
int RunListen(const ListenOptions& options);

/** {"translation_mm": [...], "rotation_deg": {"pitch": .., "roll": .., "yaw": ..}} */
std::string JsonPose(const Pose& pose);

/** Routes VTK's warnings and errors to stderr as single plain lines (no colour, no pipeline
 *  dump); the "returned failure" messages that follow an error xpose reports itself are dropped. */
void RouteVTKMessages();

/** Sets the number of threads used by every parallel kernel (0 = all cores). */
void UseThreads(int threads);

/** Resolves --device (auto | cpu | cuda: ChooseComputeDevice) before any work: cuda without a
 *  usable GPU is refused naming the option; auto without one prints why it runs on the CPU. */
ComputeDevice UseDevice(const std::string& device);

} // namespace xp

#endif
