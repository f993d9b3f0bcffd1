// xpose: stereo X-ray 2D/3D registration. main() only parses; the work is in xpCommands.
#include "xpCommands.h"
#include "xpError.h"
#include "xpValueText.h"
#include "xpVolumeIO.h"

#include <CLI/CLI.hpp>

namespace
{

constexpr const char* VoxelSizeHelp = "A TIFF stack's voxel size x,y,z (mm): columns along x, rows along y, pages along z "
                                      "(first page lowest); values proportional to attenuation, 0 air, 1000 water";

constexpr const char* DeviceHelp = "Where the DRRs' rays are cast: cpu, cuda (an NVIDIA GPU; refused without one) or "
                                   "auto (the GPU where one is usable, else the CPU)";

/** An option whose text is parsed here, once, into a typed value: `parse` throws xp::InputError
 *  naming the option, which the parser reports as bad input (exit 2). */
template <typename T, typename Parse>
CLI::Option* AddParsedOption(CLI::App* command, const std::string& name, std::optional<T>& value, Parse parse, const std::string& help)
{
  return command->add_option_function<std::string>(name,
    [&value, parse, name](const std::string& text)
    {
      try
      {
        value = parse(text, name);
      }
      catch (const xp::InputError& error)
      {
        throw CLI::ValidationError(error.what());
      }
    },
    help);
}

CLI::Option* AddPointOption(CLI::App* command, const std::string& name, std::optional<Eigen::Vector3d>& point, const std::string& help)
{
  return AddParsedOption(command, name, point, xp::ParsePoint, help);
}

CLI::Option* AddSizeOption(CLI::App* command, const std::string& name, std::optional<Eigen::Vector2i>& size, const std::string& help)
{
  return AddParsedOption(command, name, size, xp::ParseImageSize, help);
}

CLI::Option* AddVoxelSizeOption(CLI::App* command, std::optional<Eigen::Vector3d>& voxelSize)
{
  return AddParsedOption(command, "--voxel-size", voxelSize,
    [](const std::string& text, const std::string& name)
    {
      const std::array<double, 3> size = xp::ParseVoxelSize(text, name);
      return Eigen::Vector3d(size[0], size[1], size[2]);
    },
    VoxelSizeHelp);
}

/** The registration method's options, bound to the settings the registration filter takes. */
void AddMethodOptions(CLI::App* command, xp::StereoRegistrationSettings& settings)
{
  command->add_option("--bins", settings.bins, "MI histogram bins")->capture_default_str();
  command->add_option("--max-evaluations", settings.maxEvaluations, "Evaluation limit of each 6-DOF stage")
    ->capture_default_str();
  command->add_option("--high-pass-mm", settings.fineHighPassMM,
    "The refinement removes shading wider than this (sd, mm on the panel; 0: off)")->capture_default_str();
  command->add_option("--xray-smoothing", settings.xraySmoothingPerVoxel,
    "Each X-ray is smoothed by a Gaussian of this sd at the isocentre, in the CT's finest voxel spacings "
    "(0.41: the detail a DRR of that CT holds; 0: off)")->capture_default_str();
  command->add_option("--xray-noise-levels", settings.xrayNoiseLevels,
    "... and a noisy X-ray more, up to twice that sd, until the noise of its ranks would be this many of their 4096 levels "
    "(result.json xray_rank_noise; 0: the CT's sd alone)")->capture_default_str();
  command->add_option("--fine-render-stride", settings.fineRenderStride,
    "The refinement casts the DRR's rays on every N-th pixel of each row and column and interpolates the rest "
    "(0: per panel axis, 2 where two pixels at the isocentre span at most the CT's voxel spacing along that axis, else 1)")
    ->capture_default_str();
  command->add_option("--fine-plane-step", settings.finePlaneStep,
    "The refinement's rays sample every N-th voxel plane along their dominant axis (1: every plane; 0: per CT axis, 2 where "
    "the half-size stages halve the CT, voxels of at most 1.25 mm, else 1: faster on such CTs; the GPU samples every plane)")
    ->capture_default_str();
  command->add_option("--search-render-stride", settings.searchRenderStride,
    "The same for the coarse searches' half-size DRRs (0: as for the refinement, for the CT they render; 1: every ray)")->capture_default_str();
  command->add_option("--quarter-size-travel", settings.quarterSizeTravel,
    "The coarse searches travel on quarter-size images first, then end at half size (when the quarter is at least 128x96; "
    "faster searches, less accurate on the standard schedule's own stops: Algorithms.md, \"The economy schedule\")")
    ->capture_default_str();
  command
    ->add_option_function<std::string>(
      "--schedule", [&settings](const std::string& name) { settings.schedule = xp::ParseScheduleChoice(name, "--schedule"); },
      "The registration's schedule of searches and refinement: economy (searches travel on quarter-size images first, "
      "stop looser, restart once) or standard (the earlier schedule: more and larger DRRs; Algorithms.md, \"The schedule\")")
    ->check(CLI::IsMember({ "standard", "economy" }))
    ->default_str("economy");
  command->add_option("--second-search-joins", settings.secondSearchJoins,
    "When the second search's quarter-size travel meets the first one's end, or one of its runs ends within twice its "
    "stops of it (2 mm, 1 degree), it ends there, without a restart; false: it goes on at half size until it meets "
    "the first one's half-size end (Algorithms.md, \"Where the evaluations go\")")->capture_default_str();
  command->add_option("--vertex-polish", settings.vertexPolishRounds,
    "Rounds at most of moving the refinement's end to the vertex of the objective's parabola along each axis, through its "
    "values 1.5 mm and 1 degree either side, until one moves less than the refinement's stop (0: off)")->capture_default_str();
  command->add_option("--half-size-refinement", settings.halfSizeRefinement,
    "Before the full-size refinement, one on half-size images of the same high-passed objective (steps and stops twice "
    "the refinement's): the full-size refinement starts near its end (Algorithms.md, \"The schedule\")")->capture_default_str();
  command->add_option("--linearized-refinement", settings.linearizedRefinement,
    "The full-size refinement climbs a first-order model of the DRRs, their slopes along the six pose parameters "
    "rendered once a round (13 evaluations a round; false: a simplex that renders every evaluation; Algorithms.md, "
    "\"The linearized refinement\")")->capture_default_str();
  command->add_option("--high-pass-after-travel", settings.highPassAfterTravel,
    "After the quarter-size travel, the half-size searches maximise the refinement's high-passed objective (--high-pass-mm) "
    "instead of the shaded one (Algorithms.md, \"The schedule\")")->capture_default_str();
  command->add_option("--coverage-margin-mm", settings.coverageMarginMM,
    "Margin of the mask of rays that cross the body beyond the CT's end slices, mm")->capture_default_str();
  command->add_option("--held-out-high-pass-mm", settings.heldOutHighPassMM,
    "The gate's held-out peak check removes shading wider than this (sd, mm on the panel)")->capture_default_str();
  command->add_option("--held-out-turns", settings.heldOutTurns,
    "The held-out peak check also measures the neighbours turned either side along pitch, roll and yaw (6 half-size "
    "evaluations; recorded in result.json held_out_leads, not judged); false: the translated neighbours only, which the "
    "gate judges")->capture_default_str();
  command->add_option("--coverage-min-excess", settings.coverageMinExcess,
    "Those rays are left out beyond an end face where their upper quarter is more attenuated than the DRR "
    "predicts by this fraction of the X-ray's range (0: always)")->capture_default_str();
}

/** The CT's table: chosen by the X-rays (the default), kept, or removed; one of the three. */
void AddTableOptions(CLI::App* command, bool& chooseTable, bool& removeTable)
{
  CLI::Option* choose = command->add_flag("--choose-table", chooseTable,
    "The default: pre-align the CT with its table and its body alone, and register the one whose DRRs' edges match the "
    "X-rays' better there (the CT's table shows in a renderer's X-rays, never in a room's; result.json `table`)");
  CLI::Option* keep = command->add_flag_callback("--keep-table", [&chooseTable] { chooseTable = false; },
    "Render DRRs from the CT as it is, its table included");
  CLI::Option* remove = command->add_flag_callback(
    "--remove-table",
    [&chooseTable, &removeTable]
    {
      chooseTable = false;
      removeTable = true;
    },
    "Render DRRs from the body alone: the CT's table (and anything else apart from the body) set to air");
  choose->excludes(keep)->excludes(remove);
  keep->excludes(remove);
}

/** The quality gate's limits (Algorithms.md, "A verdict that does not depend on how the X-ray was formed"). */
void AddGateOptions(CLI::App* command, xp::StereoRegistrationSettings& settings)
{
  command->add_option("--min-explained", settings.minExplained,
    "Gate: MI / H(X-ray) each view's final DRR must reach")->capture_default_str();
  command->add_option("--max-view-residual", settings.maxViewResidual,
    "Gate: mm (at the isocentre) a view's own 2D registration may still move")->capture_default_str();
  command->add_option("--max-halves-apart-mm", settings.maxHalvesApartMM,
    "Gate: mm (at the isocentre) that a view's two halves may end apart, registered each on its own and both at once (the larger)")->capture_default_str();
  command->add_option("--max-halves-apart-clear-peak-mm", settings.maxHalvesApartClearPeakMM,
    "Gate: ... and where the result leads its held-out neighbours by at least --clear-peak-margin")->capture_default_str();
  command->add_option("--clear-peak-margin", settings.clearPeakMargin,
    "Gate: the held-out lead (see --min-peak-margin) at which the halves may end --max-halves-apart-clear-peak-mm apart")
    ->capture_default_str();
  command->add_option("--max-uncovered", settings.maxUncovered,
    "Gate: fraction of a view's valid pixels that may show anatomy the CT does not cover")->capture_default_str();
  command->add_option("--max-search-apart-mm", settings.maxSearchDisagreementMM,
    "Gate: two searches ending farther apart (and as good) fail the result; 0: one search")->capture_default_str();
  command->add_option("--max-search-apart-deg", settings.maxSearchDisagreementDegrees,
    "Coarse ends farther apart than this (degrees) or --max-search-apart-mm are both refined")->capture_default_str();
  command->add_option("--max-refined-apart-deg", settings.maxRefinedApartDegrees,
    "Gate: refined ends farther apart than this (degrees) or --max-search-apart-mm, and as good, fail the result")
    ->capture_default_str();
  command->add_option("--min-peak-margin", settings.minPeakMargin,
    "Gate: least relative lead of the result over the poses 3 mm away along x, y and z, on a similarity the optimiser did not use")
    ->capture_default_str();
  command->add_option("--bone-min-peak-margin", settings.boneMinPeakMargin,
    "Gate: the same for a bone cut out of a CT, over the poses moved and turned (its similarity is a correlation)")
    ->capture_default_str();
  command->add_option("--max-uncertainty-mm", settings.maxUncertaintyMM,
    "Gate: largest uncertainty of each translation (mm): where the similarity falls by 5 % of its peak")->capture_default_str();
  command->add_option("--max-uncertainty-deg", settings.maxUncertaintyDegrees, "Gate: and of each rotation (degrees)")
    ->capture_default_str();
}

CLI::App* AddPhantomCommand(CLI::App& app, xp::PhantomOptions& options)
{
  CLI::App* phantomCommand = app.add_subcommand("phantom", "Write the built-in head phantom as a DICOM CT series");
  phantomCommand->add_option("--out", options.outputDirectory, "Output folder (new or empty)")->required();
  phantomCommand->add_option("--spacing", options.spacing, "Voxel size in mm")->capture_default_str();
  return phantomCommand;
}

CLI::App* AddGeometryCommand(CLI::App& app, xp::GeometryOptions& options)
{
  CLI::App* geometryCommand = app.add_subcommand("geometry",
    "Write a geometry file from the imagers' DICOM X-rays, 3x4 projection matrices or pinhole calibrations");
  geometryCommand->add_option("--dicom", options.dicom,
    "One DICOM X-ray per imager, the geometry from its tags: RT Image (gantry angle and pitch, SAD, SID, receptor) "
    "or DX/CR/XA (positioner angles, source distances, imager pixel spacing, patient orientation)");
  geometryCommand->add_option("--patient-position", options.patientPosition,
    "How the patient lay (HFS, HFP, FFS, FFP) for DX/CR/XA files without Patient Position (0018,5100)");
  geometryCommand->add_option("--projection-matrix", options.projectionMatrices,
    "One text file per imager: 3 rows of 4 numbers, Room mm to (col, row) pixel-centre indices, row 0 at the top");
  geometryCommand->add_option("--intrinsics", options.intrinsics, "Or pinhole calibrations: K per imager (3 rows of 3, pixels)");
  geometryCommand->add_option("--extrinsics", options.extrinsics, "with [R | t] per imager (3 rows of 4, Room mm to camera)");
  geometryCommand->add_option("--names", options.names, "The imagers' names (default A, B, ...)")->delimiter(',');
  geometryCommand->add_option("--pixel-spacing", options.pixelSpacing,
    "Detector pixel spacing, MM or COLUMN_MM,ROW_MM (with matrices)");
  geometryCommand->add_option("--size", options.size, "Detector COLSxROWS (with matrices)");
  geometryCommand->add_option("--camera-calibration", options.cameraCalibrations,
    "Or camera calibrations as XMALab exports them (image size, camera matrix K, rotation R, translation t; "
    "x_camera = R X + t), one per imager; with --pixel-spacing MM");
  geometryCommand->add_option("--isocenter", options.isocenter,
    "Room isocentre x,y,z (mm); default 0,0,0, or with --camera-calibration where the central rays pass closest");
  geometryCommand->add_option("--check", options.check,
    "With --dicom: report how far the X-rays' tags are from this geometry file (exit 2 beyond 0.5 mm / 0.1 deg)");
  geometryCommand->add_option("--out", options.output, "The geometry JSON to write");
  return geometryCommand;
}

CLI::App* AddDRRCommand(CLI::App& app, xp::DRROptions& options)
{
  CLI::App* drrCommand = app.add_subcommand("drr", "Render a DRR per imager of the geometry");
  drrCommand->add_option("--ct", options.ct, "CT: DICOM folder, .mha/.mhd, .nii/.nii.gz or a TIFF stack")->required();
  drrCommand->add_option("--series", options.series, "Series Instance UID when the folder holds several");
  drrCommand->add_option("--voxel-size", options.voxelSize, VoxelSizeHelp);
  drrCommand->add_option("--geometry", options.geometry, "Stereo geometry JSON (Coordinates.md)")->required();
  drrCommand->add_option("--size", options.size, "Output COLSxROWS on the same panel (default: the panel's)");
  drrCommand->add_option("--pose", options.pose, "Patient misalignment tx,ty,tz,pitch,roll,yaw (mm, degrees, room)")
    ->capture_default_str();
  drrCommand->add_option("--iso-ct", options.isocenterInCT, "CT point x,y,z (LPS mm) at the isocentre (default: CT centre)");
  drrCommand->add_option("--mask-dir", options.maskDirectory, "Folder with mask_NAME.png per imager (non-zero = render)");
  drrCommand->add_option("--method", options.method, "trilinear or siddon")->capture_default_str();
  drrCommand->add_option("--step", options.stepSize, "Trilinear sampling step in mm (0: smallest voxel spacing)")
    ->capture_default_str();
  drrCommand->add_option("--mu-water", options.muWater, "Attenuation of water, 1/mm")->capture_default_str();
  drrCommand->add_option("--threads", options.threads, "Threads (0: all cores)")->capture_default_str();
  drrCommand->add_option("--device", options.device, DeviceHelp)->capture_default_str();
  drrCommand->add_option("--out-dir", options.outputDirectory, "Output folder")->required();
  drrCommand->add_option("--dicom-out", options.dicomOutputDirectory,
    "Also write the DRRs as DICOM RT Images (drr_NAME.dcm) here; needs a DICOM CT");
  return drrCommand;
}

CLI::App* AddBenchCommand(CLI::App& app, xp::BenchOptions& options, xp::BenchRegisterOptions& reg, CLI::App*& benchRegister)
{
  CLI::App* benchCommand = app.add_subcommand("bench", "Measure and print performance figures");
  benchCommand->require_subcommand(1);
  CLI::App* benchDRR = benchCommand->add_subcommand("drr", "DRR rays per second: sizes, threads, masks");
  benchDRR->add_option("--ct", options.ct, "CT: DICOM folder, .mha/.mhd or .nii/.nii.gz")->required();
  benchDRR->add_option("--series", options.series, "Series Instance UID when the folder holds several");
  benchDRR->add_option("--geometry", options.geometry, "Stereo geometry JSON")->required();
  benchDRR->add_option("--sizes", options.sizes, "Output sizes COLSxROWS")->capture_default_str();
  benchDRR->add_option("--mask-size", options.maskSize, "Size for the masked runs")->capture_default_str();
  benchDRR->add_option("--valid", options.validFractions, "Valid fractions for the masked runs")->capture_default_str();
  benchDRR->add_option("--methods", options.methods, "Ray casting methods of the unmasked table")
    ->check(CLI::IsMember({ "trilinear", "siddon" }))
    ->capture_default_str();
  benchDRR->add_option("--repetitions", options.repetitions, "Runs per figure (the median is printed)")
    ->capture_default_str();
  benchDRR->add_option("--device", options.device, DeviceHelp)->capture_default_str();
  benchRegister = benchCommand->add_subcommand(
    "register", "Registrations of simulated misalignments: time, DRRs, rays and CPU use per stage, per optimiser on the same trials");
  benchRegister->add_option("--ct", reg.ct, "CT: DICOM folder, .mha/.mhd or .nii/.nii.gz")->required();
  benchRegister->add_option("--series", reg.series, "Series Instance UID when the folder holds several");
  benchRegister->add_option("--geometry", reg.geometry, "Stereo geometry JSON")->required();
  benchRegister->add_option("--scenario", reg.scenario, "X-rays: clinical (the physics simulator), plastimatch, noisy, ... (as evaluate)")
    ->capture_default_str();
  benchRegister->add_option("--detector", reg.detector, "Image format of the clinical and plastimatch scenarios (as evaluate)");
  benchRegister->add_option("--without", reg.without,
    "Clinical effects to switch off (as evaluate): truncation registers against a CT as long as the X-rays' field")
    ->delimiter(',');
  AddTableOptions(benchRegister, reg.chooseTable, reg.removeTable);
  benchRegister->add_option("--trials", reg.trials, "Misalignments per optimiser (the same for each)")->capture_default_str();
  benchRegister->add_option("--size", reg.size, "Registration resolution COLSxROWS")->capture_default_str();
  std::string optimizerNames;
  for (const std::string& name : xp::PoseOptimizerMethodNames())
    optimizerNames += (optimizerNames.empty() ? "" : ", ") + name;
  benchRegister->add_option("--optimizers", reg.optimizers,
      "6-DOF optimisers compared: one of " + optimizerNames + " for every stage, or SEARCH/REFINEMENT (nelder-mead/cobyla)")
    ->capture_default_str();
  benchRegister->add_option("--render-strides", reg.renderStrides,
      "Render strides compared, SEARCH/FINE (register's --search-render-stride and --fine-render-stride), each with every "
      "optimiser")
    ->capture_default_str();
  benchRegister->add_option("--travels", reg.travels,
      "The coarse searches' travel compared: half (the default) and/or quarter (register's --quarter-size-travel true), "
      "each with every other variant")
    ->capture_default_str();
  benchRegister->add_option("--schedules", reg.schedules,
      "The schedules compared: standard and/or economy (register's --schedule), each with every other variant")
    ->capture_default_str();
  benchRegister->add_option("--seed", reg.seed, "Seed of the trials and the noise")->capture_default_str();
  benchRegister->add_option("--min-start-translation", reg.minTranslation, "Smallest start error drawn: translation, mm (not the gate's --max-translation)")->capture_default_str();
  benchRegister->add_option("--max-start-translation", reg.maxTranslation, "Largest start error drawn: translation, mm")->capture_default_str();
  benchRegister->add_option("--max-start-rotation", reg.maxRotation, "Largest start error drawn per angle, degrees")->capture_default_str();
  benchRegister->add_option("--threads", reg.threads, "Threads (0: all cores)")->capture_default_str();
  benchRegister->add_option("--device", reg.device, DeviceHelp)->capture_default_str();
  return benchCommand;
}

CLI::App* AddMaskCommand(CLI::App& app, xp::MaskOptions& options)
{
  CLI::App* maskCommand = app.add_subcommand("mask", "Block-entropy validity mask of an X-ray (Method.md, stage 2)");
  maskCommand->add_option("--xray", options.xray, "X-ray: 16-bit PNG with 12-bit values")->required();
  maskCommand->add_option("--roi", options.roi, "User ROI PNG of the same size (non-zero = allowed)");
  maskCommand->add_option("--window", options.window, "Block size at half resolution")->capture_default_str();
  maskCommand->add_option("--bin-width", options.binWidth, "Grey levels per bin")->capture_default_str();
  maskCommand->add_option("--out-dir", options.outputDirectory, "Output folder")->required();
  return maskCommand;
}

CLI::App* AddSimulateCommand(CLI::App& app, xp::SimulateOptions& options)
{
  CLI::App* simulateCommand = app.add_subcommand("simulate", "Simulate the stereo X-rays of a misaligned patient");
  simulateCommand->add_option("--ct", options.ct, "CT: DICOM folder, .mha/.mhd or .nii/.nii.gz")->required();
  simulateCommand->add_option("--series", options.series, "Series Instance UID when the folder holds several");
  simulateCommand->add_option("--geometry", options.geometry, "Stereo geometry JSON")->required();
  simulateCommand->add_option("--pose", options.pose, "True misalignment tx,ty,tz,pitch,roll,yaw")->required();
  simulateCommand->add_option("--size", options.size, "Output COLSxROWS on the same panel");
  simulateCommand->add_option("--iso-ct", options.isocenterInCT, "CT point x,y,z (LPS mm) at the isocentre");
  simulateCommand->add_option("--noise", options.noise, "Quantum noise sd in grey levels at full transmission");
  simulateCommand->add_flag("--kv-contrast", options.kvContrast, "Bone attenuates more than in the DRR model");
  simulateCommand->add_flag("--add-objects", options.addObjects, "Add a couch rail and a frame only the X-ray shows");
  simulateCommand->add_option("--preset", options.preset,
    "model: the DRR's own image model; clinical: the physics simulator, every effect on")->capture_default_str();
  simulateCommand->add_option("--without", options.without,
    "Clinical effects to switch off: spectrum, pixel-area, table, couch, scatter, blur, quantum-noise, "
    "electronic-noise, heel, log")->delimiter(',');
  simulateCommand->add_option("--seed", options.seed, "Noise seed")->capture_default_str();
  simulateCommand->add_option("--threads", options.threads, "Threads (0: all cores)");
  simulateCommand->add_option("--out-dir", options.outputDirectory, "Output folder")->required();
  return simulateCommand;
}

/** The couch that carries out an ok result, the target and the clinic's action levels
 *  (Coordinates.md, "The couch"): each overrides the geometry file's couch. */
void AddCouchOptions(CLI::App* command, xp::CouchOptions& couch)
{
  command->add_option("--couch", couch.motions,
    "The couch's motions: 6dof or 4dof (translations and yaw); default: the geometry file's couch, else 6dof");
  command->add_option("--couch-rotation-limit", couch.rotationLimit,
    "The largest pitch and roll the couch turns, each way, degrees (default: the geometry file's, else none)");
  AddPointOption(command, "--target", couch.target,
    "The CT point x,y,z (LPS mm) the couch motion puts back exactly (default: the planned isocentre)");
  command->add_option("--action-level-mm", couch.levels.actionMM,
    "No move is needed when the couch motion is within this translation and --action-level-deg (0: every motion is a move)")
    ->capture_default_str();
  command->add_option("--action-level-deg", couch.levels.actionDegrees, "No move is needed within this rotation and --action-level-mm")
    ->capture_default_str();
  command->add_option("--max-uncorrected-mm", couch.levels.maxUncorrectedMM,
    "Set the patient up again when what the couch cannot correct moves a point 100 mm from the target farther (default: none)");
  command->add_option("--max-uncorrected-deg", couch.levels.maxUncorrectedDegrees,
    "Set the patient up again when the couch leaves a larger rotation uncorrected, degrees (default: none)");
}

/** What register and track share: the volume, the geometry, where to start, the method and the gate. */
void AddRegistrationOptions(CLI::App* command, xp::RegisterOptions& options)
{
  command->add_option("--ct", options.ct, "CT: DICOM folder, .mha/.mhd, .nii/.nii.gz or a TIFF stack (or --pacs)");
  command->add_option("--series", options.series, "Series Instance UID when the folder holds several");
  AddVoxelSizeOption(command, options.voxelSize);
  command->add_option("--geometry", options.geometry, "Stereo geometry JSON")->required();
  command->add_flag("!--no-entropy-mask", options.settings.entropyMask, "Register the whole image (no entropy mask)");
  AddSizeOption(command, "--size", options.size, "Registration resolution COLSxROWS (divides the panel)");
  AddPointOption(command, "--iso-ct", options.isocenterInCT, "CT point x,y,z (LPS mm) at the isocentre");
  command->add_option("--initial-pose", options.initialPose,
    "Start the search here: tx,ty,tz,pitch,roll,yaw (mm, degrees), the terms of result.json's misalignment; "
    "--max-translation and --max-rotation then bound the change from it");
  command->add_option("--optimizer", options.optimizer,
    "Optimiser of the 6-DOF stages: nelder-mead (the paper's), sbplx, bobyqa or cobyla, or SEARCH/REFINEMENT "
    "(nelder-mead/bobyqa); xpose bench register compares them")->capture_default_str();
  command->add_flag("--global-search", options.globalSearch,
    "Find the start over all orientations and places in both views (always for a TIFF volume without --initial-pose)");
  AddTableOptions(command, options.settings.chooseTable, options.removeTable);
  AddMethodOptions(command, options.settings);
  command->add_option("--max-translation", options.settings.maxTranslation, "Gate: largest accepted correction, mm")
    ->capture_default_str();
  command->add_option("--max-rotation", options.settings.maxRotation, "Gate: largest accepted correction, degrees")
    ->capture_default_str();
  AddGateOptions(command, options.settings);
  AddCouchOptions(command, options.couch);
  command->add_option("--threads", options.threads, "Threads (0: all cores)");
  command->add_option("--device", options.device, DeviceHelp)->capture_default_str();
}

CLI::App* AddTrackCommand(CLI::App& app, xp::TrackOptions& options)
{
  CLI::App* track = app.add_subcommand("track", "Register a sequence of stereo frames, each from the previous result");
  AddRegistrationOptions(track, options.registration);
  track->add_option("--frames", options.frames, "One A.tif,B.tif (one X-ray per imager, comma-separated) per frame, in order")
    ->required();
  track->add_option("--out-dir", options.outputDirectory, "Output folder: poses.csv, poses.json and frame-NNNN/result.json")
    ->required();
  track->add_option("--report", options.reportDirectory, "Also write each frame's visual report to DIR/frame-NNNN/");
  return track;
}

CLI::App* AddListenCommand(CLI::App& app, xp::ListenOptions& options)
{
  CLI::App* listen = app.add_subcommand("listen",
    "A DICOM storage node: register each study's CT and X-ray pair as they arrive, send the REG on");
  AddRegistrationOptions(listen, options.registration);
  // Its inputs arrive over the network; a volume's own options make no sense here.
  for (const char* name : { "--ct", "--series", "--voxel-size", "--global-search", "--initial-pose", "--target" })
    listen->remove_option(listen->get_option(name));
  listen->add_option("--port", options.port, "TCP port to serve DICOM on")->required();
  listen->add_option("--aet", options.aet, "The node's AE title (the called AE title senders use)")->capture_default_str();
  listen->add_option("--allow-aet", options.allowAET, "Calling AE titles admitted (default: any)");
  listen->add_option("--forward", options.forward, "Send an ok result's REG to dicom://AET@HOST:PORT");
  listen->add_option("--settle", options.settle, "Seconds without a new instance before a study is registered")
    ->capture_default_str();
  listen->add_option("--out-dir", options.outputDirectory, "DIR/STUDY_UID/: received/, result.json, report/, dicom/")->required();
  return listen;
}

CLI::App* AddRegisterCommand(CLI::App& app, xp::RegisterOptions& options)
{
  CLI::App* registerCommand = app.add_subcommand("register", "Find the patient's 6-DOF misalignment from the stereo X-rays");
  AddRegistrationOptions(registerCommand, options);
  registerCommand->add_option("--xray", options.xrays, "X-ray: grey PNG or TIFF (8 or 16 bits) or DICOM, one per imager in order (or --pacs)");
  registerCommand->add_option("--roi", options.rois, "User ROI PNG per X-ray (non-zero = use)");
  registerCommand->add_option("--out-dir", options.outputDirectory, "Output folder")->required();
  registerCommand->add_option("--report", options.reportDirectory, "Also write the visual report (index.html, summary.png) here");
  registerCommand->add_option("--dicom-out", options.dicomOutputDirectory,
    "Also write an ok result as a DICOM Spatial Registration (reg.dcm) here; needs a DICOM CT");
  registerCommand->add_option("--pacs", options.pacs,
    "Archive: DICOMweb http(s)://HOST:PORT/PATH (e.g. Orthanc's .../dicom-web) or DIMSE dicom://CALLED_AET@HOST:PORT; "
    "take the CT and X-rays from it by UID, store the DICOM results in it");
  registerCommand->add_option("--aet", options.aet, "With a dicom:// --pacs: xpose's own AE title")->capture_default_str();
  registerCommand->add_option("--pacs-credentials", options.pacsCredentials,
    "With --pacs: a file only its owner can read, one line user:password or token:VALUE (default: the environment's "
    "XPOSE_PACS_USER and XPOSE_PACS_PASSWORD, or XPOSE_PACS_TOKEN)");
  registerCommand->add_option("--ca-file", options.caFile, "With an https --pacs: the certificate authorities to trust (PEM; "
    "default: the system's)");
  registerCommand->add_option("--study", options.study, "With --pacs: the study whose one CT series is registered");
  registerCommand->add_option("--ct-series", options.ctSeries, "With --pacs: the CT series (Series Instance UID)");
  registerCommand->add_option("--xray-instance", options.xrayInstances,
    "With --pacs: an X-ray's SOP Instance UID, one per imager in order");
  return registerCommand;
}

CLI::App* AddReportCommand(CLI::App& app, xp::ReportOptions& options)
{
  CLI::App* reportCommand = app.add_subcommand("report", "Rebuild the visual report of a finished registration");
  reportCommand->add_option("--result", options.result, "result.json written by xpose register")->required();
  reportCommand->add_option("--out-dir", options.outputDirectory, "Report folder (default: report/ beside result.json)");
  return reportCommand;
}

CLI::App* AddEvaluateCommand(CLI::App& app, xp::EvaluateOptions& options)
{
  CLI::App* evaluateCommand = app.add_subcommand("evaluate",
    "Register many simulated misalignments with and without entropy masks (A: whole image, B: masks)");
  evaluateCommand->add_option("--ct", options.ct, "CT: DICOM folder, .mha/.mhd or .nii/.nii.gz")->required();
  evaluateCommand->add_option("--series", options.series, "Series Instance UID when the folder holds several");
  evaluateCommand->add_option("--geometry", options.geometry, "Stereo geometry JSON")->required();
  evaluateCommand->add_option("--trials", options.trials, "Misalignments drawn")->capture_default_str();
  evaluateCommand->add_option("--min-start-translation", options.minTranslation, "Smallest start error drawn: translation, mm (not the gate's --max-translation)")
    ->capture_default_str();
  evaluateCommand->add_option("--max-start-translation", options.maxTranslation, "Largest start error drawn: translation, mm")
    ->capture_default_str();
  evaluateCommand->add_option("--max-start-rotation", options.maxRotation, "Largest start error drawn per angle, degrees")
    ->capture_default_str();
  evaluateCommand->add_option("--seed", options.seed, "Seed of the trials and the noise")->capture_default_str();
  evaluateCommand->add_option("--size", options.size, "Registration resolution COLSxROWS (divides the panel)");
  evaluateCommand->add_option("--scenario", options.scenario,
    "clean, noisy, objects, truncated (the DRR model's X-rays), clinical (the physics simulator) or plastimatch "
    "(plastimatch drr's line integrals)")->capture_default_str();
  evaluateCommand->add_option("--without", options.without,
    "Clinical effects to switch off: truncation and those of simulate --without")->delimiter(',');
  AddTableOptions(evaluateCommand, options.settings.chooseTable, options.removeTable);
  evaluateCommand->add_option("--optimizer", options.optimizer,
    "Optimiser of the 6-DOF stages, as register's: nelder-mead, sbplx, bobyqa, cobyla or SEARCH/REFINEMENT")
    ->capture_default_str();
  evaluateCommand->add_option("--registration-off", options.registrationOff,
    "Registration steps to switch off, to measure them: levels (MI on 12-bit values), high-pass, coverage, median, smoothing, "
    "bone-cuts (a cut bone's ends kept in its masks)")
    ->delimiter(',');
  AddMethodOptions(evaluateCommand, options.settings);
  AddGateOptions(evaluateCommand, options.settings);
  evaluateCommand->add_option("--approaches", options.approaches, "A (whole image) and/or B (entropy masks)")
    ->capture_default_str();
  evaluateCommand->add_option("--noise", options.noise, "Quantum noise of the noisy scenarios")->capture_default_str();
  evaluateCommand->add_option("--detector", options.detector,
    "Image format of the clinical and plastimatch scenarios: linear12, linear16, log or processed (plastimatch: linear12)");
  evaluateCommand->add_option("--dose", options.dose, "With a detector: Poisson quanta per pixel at full transmission (0: none)")
    ->capture_default_str();
  evaluateCommand->add_option("--electronic-noise", options.electronicNoise,
    "With a detector: read-out noise, sd as a fraction of the open field")->capture_default_str();
  evaluateCommand->add_option("--xray-ct", options.xrayCT,
    "The X-rays show this CT instead of --ct (another patient): every trial should end failed");
  evaluateCommand->add_option("--xray-stretch", options.xrayStretch,
    "AXIS,FACTOR: the X-rays show --ct stretched along its index axis 0, 1 or 2 about its centre (near anatomy)");
  evaluateCommand->add_flag("--write-xrays", options.writeXRays, "Also write each trial's X-rays to OUT/xrays/trial_N_VIEW.png, with the geometry at their size (geometry.json)");
  evaluateCommand->add_option("--success-mtre", options.successMTRE, "Success: final mTRE below this, mm")
    ->capture_default_str();
  evaluateCommand->add_option("--threads", options.threads, "Threads (0: all cores)");
  evaluateCommand->add_option("--device", options.device, DeviceHelp)->capture_default_str();
  evaluateCommand->add_option("--out-dir", options.outputDirectory,
    "Output folder; an interrupted evaluation resumes in it with the same options")->required();
  return evaluateCommand;
}

} // namespace

int main(int argc, char** argv)
{
  xp::RouteVTKMessages();
  CLI::App app{ "xpose: 6-DOF patient pose from two stereoscopic X-ray images and the planning CT" };
  app.require_subcommand(1);

  xp::PhantomOptions phantom;
  CLI::App* phantomCommand = AddPhantomCommand(app, phantom);
  xp::GeometryOptions geometry;
  CLI::App* geometryCommand = AddGeometryCommand(app, geometry);
  xp::DRROptions drr;
  CLI::App* drrCommand = AddDRRCommand(app, drr);
  xp::BenchOptions bench;
  xp::BenchRegisterOptions benchRegister;
  CLI::App* benchRegisterCommand = nullptr;
  AddBenchCommand(app, bench, benchRegister, benchRegisterCommand); // bench drr runs when no other command does
  xp::MaskOptions mask;
  CLI::App* maskCommand = AddMaskCommand(app, mask);
  xp::SimulateOptions simulate;
  CLI::App* simulateCommand = AddSimulateCommand(app, simulate);
  xp::RegisterOptions reg;
  CLI::App* registerCommand = AddRegisterCommand(app, reg);
  xp::TrackOptions track;
  CLI::App* trackCommand = AddTrackCommand(app, track);
  xp::ListenOptions listen;
  CLI::App* listenCommand = AddListenCommand(app, listen);
  xp::ReportOptions report;
  CLI::App* reportCommand = AddReportCommand(app, report);
  xp::RelativeOptions relative;
  CLI::App* relativeCommand = app.add_subcommand("relative",
    "One volume's pose in another's coordinates, frame by frame, from two registrations to the same X-rays (two bones)");
  relativeCommand->add_option("--reference", relative.reference, "result.json per frame of the reference volume (the radius)")
    ->required();
  relativeCommand->add_option("--moving", relative.moving, "result.json per frame of the other volume (the ulna), as many")
    ->required();
  xp::EvaluateOptions evaluate;
  CLI::App* evaluateCommand = AddEvaluateCommand(app, evaluate);
  try
  {
    app.parse(argc, argv);
  }
  catch (const CLI::ParseError& e)
  {
    // --help and --version end here too (code 0); every real parse error is bad input.
    return app.exit(e) == 0 ? xp::ExitOk : xp::ExitBadInput;
  }
  if (reportCommand->parsed())
    return xp::GuardedRun("report", [&] { return xp::RunReport(report); });
  if (listenCommand->parsed())
    return xp::GuardedRun("listen", [&] { return xp::RunListen(listen); });
  if (relativeCommand->parsed())
    return xp::GuardedRun("relative", [&] { return xp::RunRelative(relative); });
  if (evaluateCommand->parsed())
    return xp::GuardedRun("evaluate", [&] { return xp::RunEvaluate(evaluate); });
  if (registerCommand->parsed())
    return xp::GuardedRun("register", [&] { return xp::RunRegister(reg); });
  if (trackCommand->parsed())
    return xp::GuardedRun("track", [&] { return xp::RunTrack(track); });
  if (simulateCommand->parsed())
    return xp::GuardedRun("simulate", [&] { return xp::RunSimulate(simulate); });
  if (maskCommand->parsed())
    return xp::GuardedRun("mask", [&] { return xp::RunMask(mask); });
  if (geometryCommand->parsed())
    return xp::GuardedRun("geometry", [&] { return xp::RunGeometry(geometry); });
  if (phantomCommand->parsed())
    return xp::GuardedRun("phantom", [&] { return xp::RunPhantom(phantom); });
  if (drrCommand->parsed())
    return xp::GuardedRun("drr", [&] { return xp::RunDRR(drr); });
  if (benchRegisterCommand->parsed())
    return xp::GuardedRun("bench register", [&] { return xp::RunBenchRegister(benchRegister); });
  return xp::GuardedRun("bench drr", [&] { return xp::RunBenchDRR(bench); });
}
