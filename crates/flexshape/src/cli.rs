//! Command-line arguments.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

/// Real-time 3-D shape sensing of flexible manipulators from calibrated cameras.
#[derive(Debug, Parser)]
#[command(name = "flexshape", version, about)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run flexshape on the built-in simulated rig and report what it measures.
    Demo(DemoArgs),
    /// Write a simulated recording (calibration, backgrounds, frames, ground truth).
    Simulate(Box<SimulateArgs>),
    /// Capture frame sets from live cameras into one folder per camera (OUT/NAME/000000.png …,
    /// the images of one instant sharing a file name, and OUT/timestamps.csv): chessboard
    /// views for `calibrate`, the empty scene for `background`, frames to `track` later.
    Capture(CaptureArgs),
    /// Build a background model (per-pixel mean and spread) from frames of the empty scene.
    Background(BackgroundArgs),
    /// Compute one recorded frame's silhouettes with the rig's settings, report them (against
    /// ground truth when the recording has it) and optionally write debug images.
    Silhouettes(SilhouettesArgs),
    /// Track a recording: silhouettes → carving → shape for every frame, written as JSON Lines
    /// (one record per frame, then a summary).
    Track(TrackArgs),
    /// The visual hull alone, for any object (not only tubes): silhouettes → carving, written
    /// per frame as a PLY point cloud and a PLY surface mesh, with volume figures; no bands,
    /// no shape.
    Carve(CarveArgs),
    /// Measure per-stage throughput on the simulated rig (1 and 2 threads) and print a table,
    /// or JSON with `--json`.
    Bench(BenchArgs),
    /// The tendon-driven manipulator model: forward and inverse kinematics.
    Model {
        #[command(subcommand)]
        command: ModelCommand,
    },
    /// Validation experiments (paper, Section III): `points`, `shape`, or `--simulate` to run
    /// both on the simulated rig and compare with the paper's figures.
    Validate(ValidateArgs),
    /// Play a tracking output (JSON Lines), or a recording (each frame tracked as it is shown),
    /// back in the viewer at its recorded pace, with pause, step and seek on the page; Ctrl-C
    /// ends.
    View(ViewArgs),
    /// Figures of a tracking output (PNG + SVG): all shapes in three views with bands and
    /// tips, the circular-arc fits against the curves, and per-stage time histograms.
    Report(ReportArgs),
    /// Calibrate cameras from chessboard images: intrinsics with distortion per camera and,
    /// for several cameras, their poses in one world frame from views they share (images with
    /// the same file name in different camera folders were taken at the same instant).
    Calibrate(CalibrateArgs),
    /// Inspect rig files.
    Rig {
        #[command(subcommand)]
        command: RigCommand,
    },
}

#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The records: a `flexshape track` JSON Lines file (shapes and figures), or a recording
    /// folder (its images too).
    pub records: PathBuf,
    /// Serve the viewer at ADDR (port 0 picks a free port).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8080")]
    pub viewer: String,
    /// Allow the viewer on a non-loopback address (anyone who can reach it sees the records).
    #[arg(long)]
    pub allow_remote: bool,
    /// Playback speed: 1 is the recorded pace, 2 twice as fast.
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
}

#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct ValidateArgs {
    /// Run the accuracy (stylus) and precision (machined S-bend) experiments on the simulated
    /// rig and print them beside the paper's figures.
    #[arg(long)]
    pub simulate: bool,
    /// Seed of the simulated experiments.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stylus poses of the accuracy experiment (the paper: 25).
    #[arg(long, default_value_t = 25, value_parser = clap::value_parser!(u64).range(3..=10_000))]
    pub probe_poses: u64,
    /// Poses of the S-bent object in the precision experiment (the paper: 4).
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u64).range(1..=10_000))]
    pub object_poses: u64,
    /// Write the experiments' figures (PNG + SVG) to this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    #[command(subcommand)]
    pub command: Option<ValidateCommand>,
}

#[derive(Debug, Subcommand)]
pub enum ValidateCommand {
    /// Accuracy against a reference instrument: register sensed points to reference points
    /// (paired by line) and report per-axis RMS, 3-D RMS, max error and the transform.
    Points(ValidatePointsArgs),
    /// Precision against a known shape: pair each tracked shape with the object's known
    /// centerline along the length, register per pose, and report per-axis RMS along the
    /// length and at the marked points.
    Shape(ValidateShapeArgs),
}

#[derive(Debug, Args)]
pub struct ValidatePointsArgs {
    /// Sensed points, CSV `x,y,z` per line (mm, world frame; `#` lines and a header are skipped).
    #[arg(
        long,
        required_unless_present = "sensed_from",
        conflicts_with = "sensed_from"
    )]
    pub sensed: Option<PathBuf>,
    /// Or: a tracking output (JSON Lines), one sensed point per frame picked by `--extract`.
    #[arg(long)]
    pub sensed_from: Option<PathBuf>,
    /// Which point of each tracked frame: `tip`, `band:K` (0 = most proximal) or
    /// `extreme:X,Y,Z` (the centerline point furthest along that direction).
    #[arg(long, default_value = "tip", requires = "sensed_from")]
    pub extract: String,
    /// Reference points in the instrument's frame, same format, same order.
    #[arg(long)]
    pub reference: PathBuf,
    /// Write a figure of both point sets after registration (PNG + SVG) to this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct ValidateShapeArgs {
    /// Tracking output (JSON Lines): every record with status `ok` is one pose of the object.
    #[arg(long)]
    pub records: PathBuf,
    /// The object's known centerline, CSV `x,y,z` (mm, its own frame, proximal to distal,
    /// e.g. sampled from its CAD file).
    #[arg(long)]
    pub known: PathBuf,
    /// Its marked points (band centres), CSV `x,y,z`, proximal to distal.
    #[arg(long)]
    pub marks: Option<PathBuf>,
    /// Write figures (PNG + SVG) to this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// The board: inner corners of a chessboard, COLSxROWS (e.g. 9x6), or the squares of a
    /// ChArUco board, charuco:SXxSY (e.g. charuco:11x8; give --marker too).
    #[arg(long)]
    pub board: String,
    /// Square size, mm.
    #[arg(long, allow_negative_numbers = true)]
    pub square: f64,
    /// Marker size of a ChArUco board, mm.
    #[arg(long, allow_negative_numbers = true)]
    pub marker: Option<f64>,
    /// ArUco dictionary of a ChArUco board's markers, by OpenCV's name.
    #[arg(long, default_value = "DICT_4X4_50")]
    pub dictionary: String,
    /// A camera and its image folder, NAME=DIR, or its images by a file-name pattern in one,
    /// NAME=DIR/PATTERN with `*` and `?` (quote it: 'left=imgs/left*.jpg'); repeat for every
    /// camera (the first is the reference). Images taken together share a file name (folders)
    /// or what the wildcards match (patterns: left07.jpg and right07.jpg).
    #[arg(long = "images", value_name = "NAME=DIR|NAME=DIR/PATTERN", required = true, value_parser = parse_named_path)]
    pub images: Vec<(String, PathBuf)>,
    /// Output folder: NAME.yml per camera (OpenCV FileStorage), rig.toml, calibration.json,
    /// residuals.png/svg.
    #[arg(long)]
    pub out: PathBuf,
    /// The world frame: the first camera's name (the default), `board:IMAGE` for the board in
    /// that image of the first camera (file name without extension), or `points:FILE` for
    /// measured points: CSV lines `IMAGE,COL,ROW,X,Y,Z` saying board corner (COL, ROW) in the
    /// first camera's IMAGE is at world (X, Y, Z) mm (at least 3, not on one line).
    #[arg(long)]
    pub world: Option<String>,
    /// Drop views whose RMS exceeds 3× the median view's and solve again.
    #[arg(long)]
    pub drop_outliers: bool,
    /// Keep k3 at zero.
    #[arg(long)]
    pub fix_k3: bool,
    /// Also refine every camera's intrinsics in the joint adjustment of the rig (by default
    /// they stay as calibrated per camera, as OpenCV's stereo calibration does).
    #[arg(long)]
    pub joint_intrinsics: bool,
}

#[derive(Debug, Args)]
pub struct ReportArgs {
    /// Tracking output (JSON Lines).
    #[arg(long)]
    pub data: PathBuf,
    /// Folder for the figures.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Debug, Subcommand)]
pub enum ModelCommand {
    /// Print a parameter file to start from (the paper's catheter: 4 tendons, L1 = 160 mm).
    Template,
    /// Tendon displacements → configuration [κx, κz, ε0, ε1], tensions and slack tendons.
    Forward(ModelArgs),
    /// Configuration [κx, κz, ε0] → minimum-norm tendon displacements.
    Inverse(ModelArgs),
    /// Tensionless stiffness estimation (paper, Section V): register the model frame, turn the
    /// tracked shapes into configurations and fit Km; prints a Table-I-style report.
    Fit(ModelFitArgs),
    /// Experiment design: the intervals the paper's experiment would give this catheter at
    /// each preload, with a sensing accuracy, and the preload that determines every stiffness.
    Plan(ModelPlanArgs),
    /// Closed loop on the simulated rig: the catheter (its true stiffnesses off the parameter
    /// file's by `--stiffness-error`) is rendered, sensed and steered to targets by a
    /// controller that learns its stiffnesses online; prints the tip error per frame.
    Steer(ModelSteerArgs),
}

#[derive(Debug, Args)]
pub struct ModelSteerArgs {
    /// Model parameters (TOML): what the controller believes at the start.
    #[arg(long)]
    pub params: PathBuf,
    /// How far the simulated catheter's Kx and Kz are from the file's, percent.
    #[arg(
        long,
        value_name = "KX,KZ",
        default_value = "25,-20",
        allow_negative_numbers = true
    )]
    pub stiffness_error: String,
    /// Targets (tips the catheter can reach, in turning directions).
    #[arg(long, default_value_t = 4)]
    pub targets: usize,
    /// Frames per target.
    #[arg(long, default_value_t = 8)]
    pub steps: usize,
    /// Print one JSON line per frame and a summary line instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Write the tip error over time and the convergence of the stiffnesses in use (PNG + SVG)
    /// to this folder.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// The loop live in the viewer (cameras, shape, the target, the tip's error and the
    /// curvatures over the frames); it keeps serving after the last frame until Ctrl-C.
    #[command(flatten)]
    pub viewer: ViewerArgs,
    #[command(flatten)]
    pub live: LiveArgs,
}

#[derive(Debug, Args)]
pub struct ModelPlanArgs {
    /// Model parameters (TOML): the catheter to plan for, at its nominal stiffnesses.
    #[arg(long)]
    pub params: PathBuf,
    /// Workspace poses of the experiment.
    #[arg(long, default_value_t = 26)]
    pub poses: usize,
    /// Largest bending angle of the workspace poses, degrees.
    #[arg(long, default_value_t = 150.0, value_name = "DEG")]
    pub max_bend: f64,
    /// Largest proximal compression ε0 the catheter may take; preloads from 0.002 doubling up
    /// to it are compared.
    #[arg(long, default_value_t = 0.02, value_name = "STRAIN")]
    pub max_strain: f64,
    /// The sensing's biases the intervals are predicted from.
    #[command(flatten)]
    pub bias: SensingBiasArgs,
    /// Print the plan as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, Args)]
pub struct ModelFitArgs {
    /// Model parameters (TOML); its stiffnesses are the nominal values the estimate is
    /// compared with (and used to predict the registration poses' bending directions).
    #[arg(long)]
    pub params: PathBuf,
    /// Tracking output (`flexshape track` JSON Lines) whose records carry
    /// `tendon_displacements` (and optionally `role`), or a recording folder, which is then
    /// tracked first (with its `commands/`, or `--displacements`).
    #[arg(long)]
    pub data: PathBuf,
    /// Also estimate where the tendons are (the paper's future work): their `(dx, dz)` by
    /// non-linear least squares with Km fixed at the estimate; reported, or why the data do
    /// not determine them.
    #[arg(long)]
    pub tendons: bool,
    /// Write the sensed shapes against the fitted model's (PNG + SVG, the paper's Fig. 10)
    /// to this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the registered model frame to FILE (JSON), for `flexshape track --model-frame`.
    #[arg(long, value_name = "FILE")]
    pub save_frame: Option<PathBuf>,
    /// Tendon displacements per frame from a CSV file (`frame,y0,y1,…` in mm, one line per
    /// frame; a header line is allowed), for records that do not carry them (a lab's
    /// recording with the actuators' log beside it).
    #[arg(long, value_name = "CSV")]
    pub displacements: Option<PathBuf>,
    /// A known sensor ↔ model frame (JSON, as `--save-frame` writes: from an earlier fit or
    /// the rig's drawings) instead of registering from the poses: no registration poses are
    /// needed. Its `reference_base` places ε0's origin (else a relaxed pose does).
    #[arg(long, value_name = "FILE")]
    pub frame: Option<PathBuf>,
    /// The sensing's biases, which widen each stiffness's interval.
    #[command(flatten)]
    pub bias: SensingBiasArgs,
    /// How well the sensed tips and bending bases are placed beyond their scatter (a bias),
    /// mm (0.1: the image fit's tips and bands on the simulator). Widens the joint
    /// identification's intervals.
    #[arg(
        long,
        value_name = "MM",
        default_value_t = 0.1,
        allow_negative_numbers = true
    )]
    pub position_accuracy: f64,
}

/// How well sensed configurations are known beyond their scatter (`model fit`, `model plan`).
#[derive(Debug, Args)]
pub struct SensingBiasArgs {
    /// How well the sensed curvatures are known beyond their scatter (a bias), percent: it
    /// widens each stiffness's interval by what the tendons make of it.
    #[arg(
        long,
        value_name = "PERCENT",
        default_value_t = 0.1,
        allow_negative_numbers = true
    )]
    pub curvature_accuracy: f64,
    /// How well the sensed axial strains are known beyond their scatter (a bias), as a strain
    /// (3e-4: band spacing off by 0.05 mm over 155 mm).
    #[arg(
        long,
        value_name = "STRAIN",
        default_value_t = 3e-4,
        allow_negative_numbers = true
    )]
    pub strain_accuracy: f64,
}

#[derive(Debug, Args)]
pub struct ModelArgs {
    /// Model parameters (TOML; see `flexshape model template`).
    #[arg(long)]
    pub params: PathBuf,
    /// Input values, comma-separated: forward: one displacement per tendon (mm); inverse:
    /// κx, κz (1/mm), ε0 [, ε1 (ignored)].
    #[arg(long, allow_hyphen_values = true, conflicts_with = "csv")]
    pub values: Option<String>,
    /// A CSV file with one input per line (same columns as --values; `#` lines are comments);
    /// the output is CSV too.
    #[arg(long)]
    pub csv: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
pub enum RigCommand {
    /// Load and validate a rig (a rig TOML or a folder of OpenCV camera files) and show what
    /// every camera sees of the working volume.
    Check(RigCheckArgs),
    /// Turn another tool's calibration into a rig: OpenCV camera files (NAME.yml) and
    /// rig.toml in --out, ready for `track --rig`.
    Import(RigImportArgs),
    /// Write a rig's cameras in another tool's format.
    Export(RigExportArgs),
    /// Refine the camera poses from tracked frames: each camera is moved until the tubes fitted
    /// in many frames lie on the outlines it sees (a calibration a few pixels off makes frames
    /// `inconsistent`). Writes a rig with the refined poses to --out and prints each camera's
    /// outline residuals before and after.
    Refine(Box<RigRefineArgs>),
}

#[derive(Debug, Args)]
pub struct RigCheckArgs {
    /// Rig TOML file, or a folder of camera files (*.yml, *.yaml, *.json).
    pub path: PathBuf,
    /// Check this volume instead of the rig's (world mm, min and max corners).
    #[arg(long, allow_hyphen_values = true, value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", value_parser = parse_box)]
    pub volume: Option<[f64; 6]>,
    /// Voxel size for --volume, mm (default: the rig's).
    #[arg(long, allow_negative_numbers = true, value_name = "MM")]
    pub voxel: Option<f64>,
}

#[derive(Debug, Args)]
pub struct RigRefineArgs {
    /// Where the frames come from (frames of the tube in varied shapes serve best).
    #[command(flatten)]
    pub frames: FramesArgs,
    /// Output folder: rig.toml and calibration/NAME.yml with the refined poses (intrinsics,
    /// volume and processing settings as the rig's). Existing files are not replaced without
    /// --overwrite.
    #[arg(long, short = 'o', value_name = "DIR")]
    pub out: PathBuf,
    /// A camera known to be right: it is never moved, and the world frame stays attached to
    /// it. Without it, as few cameras move as explain the frames, and where the images cannot
    /// tell which moved (two cameras, or two of three knocked) the report says so and the
    /// rig's first camera stays.
    #[arg(long, value_name = "NAME")]
    pub hold: Option<String>,
    /// Frames used at most, spread evenly over the input.
    #[arg(long = "use", value_name = "N", default_value_t = 40, value_parser = clap::value_parser!(u32).range(3..=1000))]
    pub use_frames: u32,
    /// Replace existing files in --out.
    #[arg(long)]
    pub overwrite: bool,
}

#[derive(Debug, Args)]
pub struct RigImportArgs {
    /// The format: projection (3×4 P = K[R|t] as text, KITTI `NAME:` lines or NumPy .npy),
    /// middlebury (*_par.txt), camera-info (ROS CameraInfo YAML, one per camera), kalibr
    /// (camchain.yaml), colmap (the folder of cameras.txt and images.txt) or opencv-stereo
    /// (`cv2.stereoCalibrate`'s K1, D1, K2, D2, R, T saved by FileStorage or `np.savez`).
    #[arg(value_enum)]
    pub format: ImportFormatArg,
    /// The files (or the COLMAP folder).
    #[arg(required = true, value_name = "FILE")]
    pub inputs: Vec<PathBuf>,
    /// Output folder for NAME.yml per camera and rig.toml.
    #[arg(long, short = 'o', value_name = "DIR")]
    pub out: PathBuf,
    /// Image size where the format lacks it (projection; middlebury without its images;
    /// opencv-stereo files without imageSize).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
    /// Length unit of the files: mm, cm or m. Needed for projection, colmap and opencv-stereo
    /// (their files do not say); the others default to metres, as their tools write them.
    #[arg(long, value_parser = parse_unit)]
    pub unit: Option<flexshape_rig::import::Unit>,
    /// The working volume written into rig.toml, world mm (default: 256 mm cube at the
    /// origin). World = the tool's frame (cam0's for kalibr, the left camera's rectified frame
    /// for camera-info).
    #[arg(long, allow_hyphen_values = true, value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", value_parser = parse_box)]
    pub volume: Option<[f64; 6]>,
    /// Voxel edge for --volume, mm.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "MM",
        default_value = "1"
    )]
    pub voxel: f64,
    /// Replace files already in --out.
    #[arg(long)]
    pub overwrite: bool,
}

#[derive(Debug, Args)]
pub struct RigExportArgs {
    /// The rig: a rig TOML or a folder of OpenCV camera files.
    pub rig: PathBuf,
    /// camera-info (ROS CameraInfo YAML per camera: intrinsics only) or colmap (text model:
    /// cameras and poses).
    #[arg(long, value_enum)]
    pub format: ExportFormatArg,
    /// Output folder.
    #[arg(long, short = 'o', value_name = "DIR")]
    pub out: PathBuf,
    /// Length unit of the written poses: mm, cm or m.
    #[arg(long, value_parser = parse_unit, default_value = "mm")]
    pub unit: flexshape_rig::import::Unit,
    /// Replace files already in --out.
    #[arg(long)]
    pub overwrite: bool,
}

/// `rig import FORMAT`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ImportFormatArg {
    /// 3×4 projection matrices.
    Projection,
    /// Middlebury *_par.txt.
    Middlebury,
    /// ROS CameraInfo YAML.
    CameraInfo,
    /// Kalibr camchain.yaml.
    Kalibr,
    /// COLMAP text model folder.
    Colmap,
    /// OpenCV stereo calibration (`cv2.stereoCalibrate`'s K1, D1, K2, D2, R, T) as a
    /// FileStorage .yml/.json or a NumPy .npz.
    OpencvStereo,
}

impl From<ImportFormatArg> for flexshape_rig::import::Format {
    fn from(f: ImportFormatArg) -> Self {
        use flexshape_rig::import::Format;
        match f {
            ImportFormatArg::Projection => Format::Projection,
            ImportFormatArg::Middlebury => Format::Middlebury,
            ImportFormatArg::CameraInfo => Format::CameraInfo,
            ImportFormatArg::Kalibr => Format::Kalibr,
            ImportFormatArg::Colmap => Format::Colmap,
            ImportFormatArg::OpencvStereo => Format::OpencvStereo,
        }
    }
}

/// `rig export --format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ExportFormatArg {
    /// ROS CameraInfo YAML per camera.
    CameraInfo,
    /// COLMAP text model.
    Colmap,
}

impl From<ExportFormatArg> for flexshape_rig::import::ExportFormat {
    fn from(f: ExportFormatArg) -> Self {
        use flexshape_rig::import::ExportFormat;
        match f {
            ExportFormatArg::CameraInfo => ExportFormat::CameraInfo,
            ExportFormatArg::Colmap => ExportFormat::Colmap,
        }
    }
}

fn parse_unit(s: &str) -> Result<flexshape_rig::import::Unit, String> {
    s.parse()
}

/// Where frames come from (`track`, `carve`): a recording, or frames with the rig and
/// backgrounds; the volume to carve.
#[derive(Debug, Args)]
pub struct FramesArgs {
    /// Recording folder (the layout `flexshape simulate` writes: rig.toml, calibration/,
    /// background/, frames/). Or give the frames with `--images`, `--video` or `--camera`.
    #[arg(required_unless_present_any = ["images", "masks", "video", "camera"])]
    pub recording: Option<PathBuf>,
    /// Plain image folder of one camera, NAME=DIR (repeat per camera): images with the same
    /// file name in every folder make one frame, in natural order of the names. Or one image
    /// file per camera, NAME=FILE: a single frame (views named differently).
    #[arg(long, value_name = "NAME=DIR", value_parser = parse_named_path, conflicts_with_all = ["recording", "masks", "video", "camera"])]
    pub images: Vec<(String, PathBuf)>,
    /// Mask folder of one camera, NAME=DIR (repeat per camera), or one mask file per camera,
    /// NAME=FILE: the object white (or light) on black, binary or 8-bit PNG/JPEG, from the
    /// lab's own segmentation — used as the silhouettes (a pixel of level 128 or more is
    /// object); paired like `--images`; no backgrounds needed; no marker bands.
    #[arg(long, value_name = "NAME=DIR", value_parser = parse_named_path, conflicts_with_all = ["recording", "images", "video", "camera", "backgrounds"])]
    pub masks: Vec<(String, PathBuf)>,
    /// Video file of one camera, NAME=FILE (repeat per camera), decoded by ffmpeg; the n-th
    /// frames of all videos make frame n.
    #[arg(long, value_name = "NAME=FILE", value_parser = parse_named_path, conflicts_with_all = ["recording", "images", "masks", "camera"])]
    pub video: Vec<(String, PathBuf)>,
    /// Live camera, NAME=INPUT (repeat per camera): a V4L2 device (/dev/video0), a stream URL,
    /// or a video file played in real time; read by ffmpeg. Each set is the cameras' frames
    /// nearest one capture instant — by the devices' driver timestamps or the videos' own
    /// timelines (records: camera_captured_s, each camera's fitted at its own capture), by
    /// arrival for network streams — the newest all cameras have reached; frames passed over
    /// are counted as dropped.
    #[arg(long, value_name = "NAME=INPUT", value_parser = parse_named_path, conflicts_with_all = ["recording", "images", "masks", "video"])]
    pub camera: Vec<(String, PathBuf)>,
    /// With `--camera`: pair the cameras' frames only within this many ms of one capture
    /// instant (default 0.6 of the slowest camera's frame period, the median of its recent
    /// frame intervals); sets that cannot be paired are counted (summary: unpaired) and not
    /// tracked.
    #[arg(long, value_name = "MS", requires = "camera")]
    pub pair_within: Option<f64>,
    /// The rig: a rig TOML or a folder of OpenCV camera files (NAME.yml). Default: the
    /// recording's rig.toml; needed with `--images`, `--video` and `--camera`.
    #[arg(long, value_name = "FILE|DIR")]
    pub rig: Option<PathBuf>,
    /// Folder of background images, NAME.png per camera (`flexshape background` makes them).
    /// Default: the recording's background/; needed with `--images`, `--video`, `--camera`.
    #[arg(long, value_name = "DIR")]
    pub backgrounds: Option<PathBuf>,
    /// Carving volume as XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX in world mm (default: the rig's volume;
    /// a rig without one has the 256 mm cube centred on the origin).
    #[arg(long, allow_hyphen_values = true, value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", value_parser = parse_box)]
    pub volume: Option<[f64; 6]>,
    /// Voxel edge in mm (default: the rig volume's).
    #[arg(long, allow_negative_numbers = true, value_name = "MM")]
    pub voxel: Option<f64>,
    /// The silhouette classifier and its thresholds, as the rig file's
    /// `[processing.silhouette] classifier` table (which it overrides), e.g.
    /// '{ kind = "difference", min_difference = 40 }' or '{ kind = "green_matte" }'
    /// (`flexshape silhouettes` tries every kind on a frame and suggests one).
    #[arg(long, value_name = "TOML", value_parser = parse_classifier)]
    pub classifier: Option<toml::Value>,
}

#[derive(Debug, Args)]
pub struct CarveArgs {
    /// Where the frames come from.
    #[command(flatten)]
    pub frames: FramesArgs,
    /// Output folder: per frame NNNNNN.ply (voxel centres) and NNNNNN.surface.ply (the hull's
    /// surface as a closed quad mesh), binary PLY, and hull.jsonl (one record per frame:
    /// voxels, volume, surface area, bounding box).
    #[arg(long, short = 'o', value_name = "DIR")]
    pub out: PathBuf,
    /// Write the PLY files as text (one line per element) instead of binary.
    #[arg(long)]
    pub ascii_ply: bool,
    /// Replace what an earlier run wrote in --out.
    #[arg(long)]
    pub overwrite: bool,
}

#[derive(Debug, Args)]
pub struct TrackArgs {
    /// Where the frames come from.
    #[command(flatten)]
    pub frames: FramesArgs,
    /// Output file for the JSON Lines records; `-` for standard output. An existing file is
    /// not replaced without --overwrite; none of the inputs ever is.
    #[arg(long, short = 'o', default_value = "-")]
    pub out: PathBuf,
    /// Also write a CSV summary, one row per frame (tip, arc length, curvature, …).
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Also write each frame's carved voxels as a PLY point cloud, DIR/NNNNNN.ply (every frame
    /// is then carved, whatever `--follow` says).
    #[arg(long, value_name = "DIR")]
    pub ply: Option<PathBuf>,
    /// Write the PLY clouds as text (one line per point) instead of binary.
    #[arg(long, requires = "ply")]
    pub ascii_ply: bool,
    /// Also write an MCAP file for Foxglove and ROS 2 tools: the centerline (nav_msgs/Path),
    /// tube, bands and tip (MarkerArray), hull (PointCloud2), each camera's CameraInfo and
    /// pose (/tf_static) and the record (JSON); lengths in metres (docs/formats.md).
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    /// Put every camera's image and silhouette in the MCAP file too: `raw` (the default when
    /// no format is given; `sensor_msgs/Image`, about 0.9 MB per 640×480 image), `jpeg`
    /// (`CompressedImage`, about 45 kB; silhouettes as PNG) or `png` (lossless).
    #[arg(
        long,
        value_enum,
        value_name = "FORMAT",
        num_args = 0..=1,
        default_missing_value = "raw",
        requires = "mcap"
    )]
    pub mcap_images: Option<ImageFormatArg>,
    /// The MCAP file's chunk compression: zstd (every MCAP reader reads it; raw images about
    /// 43 % smaller, compressed on a thread of its own) or none.
    #[arg(
        long,
        value_enum,
        value_name = "KIND",
        default_value = "zstd",
        requires = "mcap"
    )]
    pub mcap_compression: CompressionArg,
    #[command(flatten)]
    pub live: LiveArgs,
    /// Replace existing --out, --csv and --mcap files and PLY clouds.
    #[arg(long)]
    pub overwrite: bool,
    /// Start each frame's fit from the previous frame's shape when that one was right (carried
    /// on as it moved since the right frame before), and carve only when it does not explain
    /// the images (tracking, `[processing.fit] track`):
    /// faster for slow, smooth motion; such records have `start` = `previous`, `voxels` 0 and
    /// no `ghost_mm`. Needs two cameras or more. With N threads a recording's frame k starts
    /// from frame k − N, the same on every run; live cameras start from the newest.
    #[arg(long)]
    pub follow: bool,
    /// Frames processed at once (default: the number of cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// The manipulator model's frame (`flexshape model fit --save-frame` writes it): arc fits
    /// then also give `kappa_x`, `kappa_z` as the model defines them.
    #[arg(long, value_name = "FILE")]
    pub model_frame: Option<PathBuf>,
    /// How the centerline is found: `fit` (the tube fitted to every camera's outline and
    /// checked against the images; the default) or `hull` (the visual hull's centerline alone,
    /// unchecked). Overrides the rig's `[processing.fit] method`.
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    #[command(flatten)]
    pub viewer: ViewerArgs,
}

/// The live web viewer.
#[derive(Debug, Args)]
pub struct ViewerArgs {
    /// Serve the live viewer at ADDR (default 127.0.0.1:8080; port 0 picks a free port).
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = "127.0.0.1:8080")]
    pub viewer: Option<String>,
    /// Allow the viewer or the Foxglove server on a non-loopback address (anyone who can
    /// reach it sees the cameras).
    #[arg(long)]
    pub allow_remote: bool,
    /// End when the input ends instead of keeping the last frame on the viewer until Ctrl-C.
    #[arg(long, requires = "viewer")]
    pub viewer_exit: bool,
}

/// The run served live to the tools labs run (beside `--viewer`).
#[derive(Debug, Args)]
pub struct LiveArgs {
    /// Serve the run live to Foxglove at ADDR (default 127.0.0.1:8765, Foxglove's own; port 0
    /// picks a free one): in Foxglove, Open connection → Foxglove WebSocket. The MCAP file's
    /// topics, with the cameras' images as JPEG at most 10 frames a second; the server ends
    /// with the run.
    #[arg(
        long,
        value_name = "ADDR",
        num_args = 0..=1,
        default_missing_value = flexshape_foxglove::DEFAULT_ADDRESS
    )]
    pub foxglove: Option<String>,
    /// Publish the run live as ROS 2 topics (the MCAP file's, under ROS 2's DDS names; no ROS
    /// installation needed) on domain DOMAIN (default: ROS_DOMAIN_ID, else 0). Any node on the
    /// domain and network sees them: `ros2 topic echo /flexshape/centerline`.
    #[arg(long, value_name = "DOMAIN", num_args = 0..=1)]
    pub ros2: Option<Option<u16>>,
}

/// Settings of the simulated rig shared by `demo` and `simulate`.
#[derive(Debug, Args)]
pub struct SimArgs {
    /// Seed of the pose sequence, texture and noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Number of cameras.
    #[arg(long, default_value_t = 3)]
    pub cams: usize,
    /// Image width and height in pixels.
    #[arg(long, value_name = "WxH", default_value = "640x480", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Focal length in pixels (default: 800 px at 640 px width, scaled with the width).
    #[arg(long, allow_negative_numbers = true)]
    pub focal: Option<f64>,
    /// Cast soft shadows on the backdrops.
    #[arg(long)]
    pub shadows: bool,
    /// The catheter body's diffuse reflectance, R,G,B in 0–1 (default a blue plastic,
    /// 0.14,0.20,0.40; e.g. 0.35,0.35,0.35 for a grey tube).
    #[arg(long, value_name = "R,G,B", value_parser = parse_albedo)]
    pub body_albedo: Option<[f64; 3]>,
    /// The body's specular highlight, STRENGTH,SHININESS (default 0.15,30, a faint sheen on
    /// plastic; e.g. 0.9,20 for a silvery coating).
    #[arg(long, value_name = "STRENGTH,SHININESS", value_parser = parse_gloss)]
    pub gloss: Option<[f64; 2]>,
    /// The backdrops' diffuse reflectance, R,G,B in 0–1 (default a green cloth, 0.70,0.88,0.66;
    /// e.g. 0.9,0.9,0.9 for white paper).
    #[arg(long, value_name = "R,G,B", value_parser = parse_albedo)]
    pub backdrop_albedo: Option<[f64; 3]>,
    /// Folds in the backdrop cloth: the share of the light their valleys lose, 0–1 (default 0,
    /// a flat backdrop).
    #[arg(
        long,
        value_name = "SHARE",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub fold_depth: f64,
    /// How far the folds moved between the background capture and the frames, mm (cloth that
    /// slid or sagged; default 0).
    #[arg(
        long,
        value_name = "MM",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub fold_shift: f64,
    /// Sensor noise, standard deviation in grey levels.
    #[arg(
        long,
        allow_negative_numbers = true,
        value_name = "SIGMA",
        default_value_t = 2.0
    )]
    pub noise: f64,
    /// Number of spherical occluders between cameras and volume (one before each camera in
    /// turn); each camera's occlusion mask is written beside its calibration and named in the
    /// rig (`occluded`), as a lab masks its fixtures: remove the line to see the rig without.
    #[arg(long, default_value_t = 0)]
    pub occluders: usize,
    /// Catheter radius in mm (the tip section's with --radius-steps).
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0)]
    pub radius: f64,
    /// A catheter that steps up in radius going back from its tip (concentric tubes):
    /// FROM_TIP:RADIUS pairs in mm, comma-separated, e.g. `70:3` (3 mm from 70 mm behind the
    /// tip on). The recording's rig then gives the radii (`[processing.shape] radius_steps`).
    #[arg(long, value_name = "FROM_TIP:RADIUS,…", value_parser = parse_radius_steps)]
    pub radius_steps: Option<RadiusSteps>,
    /// With --radius-steps: the outer tube's diffuse reflectance, R,G,B in 0–1, when it is of
    /// another material than the inner one (e.g. 0.08,0.08,0.09 for a dark sheath around a
    /// silvery wire; default: the body's).
    #[arg(long, value_name = "R,G,B", value_parser = parse_albedo, requires = "radius_steps")]
    pub outer_albedo: Option<[f64; 3]>,
    /// With --radius-steps: the outer tube's highlight, STRENGTH,SHININESS (default: the
    /// body's).
    #[arg(long, value_name = "STRENGTH,SHININESS", value_parser = parse_gloss, requires = "radius_steps")]
    pub outer_gloss: Option<[f64; 2]>,
    /// A printed plate on the backdrop under the tube: `dots` (a grid of black dots 8 mm
    /// across at a 20 mm pitch on white) or `chessboard` (20 mm squares), about two thirds
    /// of the image wide.
    #[arg(long, value_enum, value_name = "PATTERN")]
    pub plate: Option<PlateArg>,
    /// Calibration off by about this many pixels: each camera's written orientation is turned
    /// by this many pixels' angle about a seeded axis; the images stay the true cameras'.
    #[arg(
        long,
        value_name = "PX",
        allow_negative_numbers = true,
        default_value_t = 0.0
    )]
    pub calibration_error: f64,
    /// With --calibration-error: only these cameras are off (indices from 0, comma-separated;
    /// default every camera), e.g. `2` for one camera knocked after calibration.
    #[arg(long, value_name = "K,…", value_delimiter = ',')]
    pub miscalibrated: Vec<usize>,
    /// Rays per pixel side when rendering (default 4: 16 rays per pixel). 2 renders about
    /// twice as fast with softer edges.
    #[arg(long, value_name = "N")]
    pub supersampling: Option<u32>,
}

/// `--plate`: what is printed on the plate under the tube.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum PlateArg {
    /// A grid of black dots on white.
    Dots,
    /// Black and white squares.
    Chessboard,
}

impl From<PlateArg> for flexshape_sim::PlatePattern {
    fn from(p: PlateArg) -> Self {
        match p {
            PlateArg::Dots => flexshape_sim::PlatePattern::Dots,
            PlateArg::Chessboard => flexshape_sim::PlatePattern::Chessboard,
        }
    }
}

#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct SimulateArgs {
    /// What else to simulate instead of a tracking recording.
    #[command(subcommand)]
    pub what: Option<SimulateWhat>,
    /// Folder to write the recording to (required).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Number of frames.
    #[arg(long, default_value_t = 20)]
    pub frames: usize,
    /// Write into a non-empty folder, replacing files of the same names.
    #[arg(long)]
    pub overwrite: bool,
    /// Pose the catheter by this manipulator model (TOML; see `flexshape model template`)
    /// instead of the default sweep: the paper's experiment of a relaxed reference pose, one
    /// pose toward each tendon and `--poses` poses filling the workspace, each commanded by
    /// tendon displacements (written to `commands/`); `--frames` is then ignored.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Workspace poses of the model experiment.
    #[arg(long, default_value_t = 26, requires = "model")]
    pub poses: usize,
    /// Proximal compression ε0 asked of every loaded pose of the model experiment (raised where
    /// a tendon would go slack): larger preloads let the axial stiffnesses be determined (see
    /// `flexshape model plan`).
    #[arg(
        long,
        default_value_t = 0.004,
        requires = "model",
        value_name = "STRAIN"
    )]
    pub preload: f64,
    /// Instead of the sweep's scattered poses, a smooth motion filmed at this many frames per
    /// second (bending, turning and inserting; at 30 the tip moves up to about 5 mm a frame):
    /// what `track --follow` sees from a real camera.
    #[arg(
        long,
        value_name = "HZ",
        allow_negative_numbers = true,
        conflicts_with = "model"
    )]
    pub motion: Option<f64>,
    /// With `--motion`: the share of each frame interval the shutter is open (0–1; 0 films
    /// each frame at its instant). What moves meanwhile is blurred along its path, as a real
    /// camera's exposure blurs it; the truth is the middle of the exposure.
    #[arg(long, default_value_t = 0.0, requires = "motion")]
    pub shutter: f64,
    /// With `--motion`: cameras that are not triggered together. Each camera's capture delay
    /// after the frame's instant, ms, comma-separated in rig order (e.g. `0,12.5,-7`; cameras
    /// left out capture at the instant). Each camera's capture times are written to
    /// `timestamps/<cam>.csv`; the truth stays at the frame's instant.
    #[arg(
        long,
        value_name = "MS,…",
        value_delimiter = ',',
        allow_negative_numbers = true,
        requires = "motion"
    )]
    pub phases: Vec<f64>,
    /// With `--motion`: every capture moreover early or late by up to this, ms (uniformly, each
    /// camera and frame on its own), as free-running cameras' frames are.
    #[arg(long, value_name = "MS", default_value_t = 0.0, requires = "motion")]
    pub jitter: f64,
    /// With `--motion`: the motion's speed against the default (1). 0.2 at `--motion 30` moves
    /// the tip up to about 1 mm a frame: an instrument slower (or faster) than the default
    /// motion, at the frame rate of your cameras.
    #[arg(long, default_value_t = 1.0, requires = "motion")]
    pub pace: f64,
    /// Instead of camera frames, masks as another tool draws them: the catheter's whole
    /// centerline stroked this many pixels wide with round ends, whatever its radius and depth
    /// (a reconstruction tool's fixed-width masks, a line drawn by hand), written to `masks/`
    /// with no backgrounds; the rig then claims no marker bands. Track them as any masks
    /// (`flexshape track DIR`)
    #[arg(
        long,
        value_name = "WIDTH_PX",
        conflicts_with_all = ["model", "shutter", "phases", "jitter"]
    )]
    pub drawn_masks: Option<f64>,
    #[command(flatten)]
    pub sim: SimArgs,
}

#[derive(Debug, Subcommand)]
pub enum SimulateWhat {
    /// Chessboard images through the simulated rig's cameras with the true rig beside them,
    /// to try `flexshape calibrate` against known truth: per camera its own views, and views
    /// each camera shares with the first (same file names).
    Chessboards(ChessboardsArgs),
}

#[derive(Debug, Args)]
pub struct ChessboardsArgs {
    /// Output folder: images/camK/NAME.png and truth/rig.toml (+ camK.yml).
    #[arg(long)]
    pub out: PathBuf,
    /// Inner corners, COLSxROWS, or a ChArUco board's squares, charuco:SXxSY (give --marker
    /// too).
    #[arg(long, default_value = "9x6")]
    pub board: String,
    /// Square size, mm.
    #[arg(long, allow_negative_numbers = true, default_value_t = 30.0)]
    pub square: f64,
    /// Marker size of a ChArUco board, mm.
    #[arg(long, allow_negative_numbers = true)]
    pub marker: Option<f64>,
    /// ArUco dictionary of a ChArUco board's markers, by OpenCV's name.
    #[arg(long, default_value = "DICT_4X4_50")]
    pub dictionary: String,
    /// Views per camera facing it.
    #[arg(long, default_value_t = 10)]
    pub own: usize,
    /// Views each camera shares with the first.
    #[arg(long, default_value_t = 5)]
    pub shared: usize,
    #[command(flatten)]
    pub sim: SimArgs,
}

#[derive(Debug, Args)]
pub struct CaptureArgs {
    /// Live camera, NAME=INPUT (repeat per camera): a V4L2 device (/dev/video0), a stream URL,
    /// or a video file played in real time; read by ffmpeg.
    #[arg(long, value_name = "NAME=INPUT", value_parser = parse_named_path, required = true)]
    pub camera: Vec<(String, PathBuf)>,
    /// Output folder (NAME/ per camera and timestamps.csv are created in it; existing camera
    /// folders are never overwritten).
    #[arg(short, long)]
    pub out: PathBuf,
    /// Frame sets to capture.
    #[arg(long, default_value_t = 20)]
    pub sets: u64,
    /// Least time between two sets, seconds (e.g. 2 to move a chessboard between views; 0
    /// takes every set the cameras deliver).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = parse_interval)]
    pub interval: f64,
    /// Image size of V4L2 devices, WxH (default: what the device gives; files and streams are
    /// probed).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
}

#[derive(Debug, Args)]
pub struct BackgroundArgs {
    /// Folder of background frames of one camera (PNG or JPEG, all the same size).
    #[arg(long)]
    pub images: PathBuf,
    /// Output image (e.g. REC/background/cam0.png); the spread goes beside it as
    /// cam0.spread.png.
    #[arg(long)]
    pub out: PathBuf,
}

/// `--method`: how the centerline is found.
/// An MCAP file's chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CompressionArg {
    /// zstd.
    Zstd,
    /// None.
    None,
}

impl From<CompressionArg> for flexshape_mcap::Compression {
    fn from(c: CompressionArg) -> Self {
        match c {
            CompressionArg::Zstd => flexshape_mcap::Compression::Zstd,
            CompressionArg::None => flexshape_mcap::Compression::None,
        }
    }
}

/// How images go into an MCAP file or a live connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ImageFormatArg {
    /// `sensor_msgs/Image`: `rgb8` images, `mono8` silhouettes, as captured.
    Raw,
    /// `sensor_msgs/CompressedImage`: JPEG images, PNG silhouettes.
    Jpeg,
    /// `sensor_msgs/CompressedImage`: PNG images and silhouettes, lossless.
    Png,
}

impl From<ImageFormatArg> for flexshape_mcap::ImageFormat {
    fn from(f: ImageFormatArg) -> Self {
        match f {
            ImageFormatArg::Raw => flexshape_mcap::ImageFormat::Raw,
            ImageFormatArg::Jpeg => flexshape_mcap::ImageFormat::Jpeg,
            ImageFormatArg::Png => flexshape_mcap::ImageFormat::Png,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// The tube fitted to the sub-pixel outlines in every camera, checked against them.
    Fit,
    /// The visual hull's centerline alone.
    Hull,
}

impl From<MethodArg> for flexshape_fit::Method {
    fn from(m: MethodArg) -> Self {
        match m {
            MethodArg::Fit => flexshape_fit::Method::Fit,
            MethodArg::Hull => flexshape_fit::Method::Hull,
        }
    }
}

#[derive(Debug, Args)]
pub struct SilhouettesArgs {
    /// Where the frame comes from (a recording, or image/mask folders, videos, cameras with
    /// --rig and --backgrounds, as for track).
    #[command(flatten)]
    pub frames: FramesArgs,
    /// Frame number (a recording's NNNNNN), or the frame's position in the input counted from
    /// 0 (folders, videos).
    #[arg(long, default_value_t = 0)]
    pub frame: u64,
    /// Write masks and debug overlays (camK_object.png, camK_markers.png, camK_debug.png, and
    /// camK_fit.png: the fitted tube's outline and what it leaves unexplained) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Stop after this many frames (default: run until Ctrl-C).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Run headless: no viewer, frames rendered as fast as tracking takes them, one table
    /// row per frame against truth.
    #[arg(long)]
    pub no_viewer: bool,
    /// Serve the live viewer here (default 127.0.0.1:8080, or any free port if that is taken).
    #[arg(long, value_name = "ADDR", conflicts_with = "no_viewer")]
    pub viewer: Option<String>,
    /// Allow the viewer or the Foxglove server on a non-loopback address.
    #[arg(long)]
    pub allow_remote: bool,
    /// Frame rate of the simulated cameras in the live demo (rendering three 640×480 views
    /// takes about 45 ms of two cores; faster rates than the machine renders just run flat out).
    #[arg(long, allow_negative_numbers = true, default_value_t = 12.0)]
    pub fps: f64,
    /// The manipulator model that drives the catheter (default: `flexshape model template`).
    #[arg(long, value_name = "PARAMS.toml")]
    pub model: Option<PathBuf>,
    /// Frames processed at once (default: the number of cores).
    #[arg(long, value_name = "N", value_parser = parse_threads)]
    pub threads: Option<usize>,
    /// Also write the simulated recording to this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also write the tracked shapes and the cameras' images as an MCAP file (as `track
    /// --mcap --mcap-images` does; replaces an existing one).
    #[arg(long, value_name = "FILE")]
    pub mcap: Option<PathBuf>,
    #[command(flatten)]
    pub live: LiveArgs,
    #[command(flatten)]
    pub sim: SimArgs,
}

#[derive(Debug, Args)]
pub struct BenchArgs {
    /// Distinct simulated frames (each is processed `--rounds` times).
    #[arg(long, default_value_t = 10)]
    pub frames: usize,
    /// Passes over the frames per thread count.
    #[arg(long, default_value_t = 5)]
    pub rounds: usize,
    /// Frames of the smooth motion the tracking figures are measured on (filmed at `--rate`).
    #[arg(long, default_value_t = 60)]
    pub track_frames: usize,
    /// Frame rate of that motion, frames per second (at 120 the tip moves up to about 1 mm a
    /// frame, at 30 up to 5).
    #[arg(long, allow_negative_numbers = true, default_value_t = 120.0)]
    pub rate: f64,
    /// Print the figures as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Instead of the figures above: the demo left running for N frames, each through the
    /// whole chain, reported per window (ok share, ok but wrong, right but refused, what the
    /// backgrounds learned, memory); Ctrl-C ends it with the windows so far.
    #[arg(long, value_name = "N")]
    pub soak: Option<u64>,
    /// Frames per window of --soak.
    #[arg(long, value_name = "FRAMES", default_value_t = 1000, requires = "soak")]
    pub window: u64,
    /// The simulated cameras' frame rate in --soak, frames per second (the demo's 12; lower
    /// plays the sweep faster).
    #[arg(long, value_name = "HZ", default_value_t = 12.0, requires = "soak")]
    pub soak_fps: f64,
    /// Frames tracked at once in --soak, and the simulator's render threads (the default 1 is
    /// `flexshape demo --no-viewer`'s; the number of cores plays a long run sooner).
    #[arg(long, value_name = "N", default_value_t = 1, requires = "soak")]
    pub threads: usize,
    #[command(flatten)]
    pub sim: SimArgs,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT, e.g. 640x480"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{v}` is not a pixel count"))
    };
    Ok((n(w)?, n(h)?))
}

/// The numbers of a comma-separated list.
fn comma_numbers(s: &str) -> Result<Vec<f64>, std::num::ParseFloatError> {
    s.split(',').map(|p| p.trim().parse::<f64>()).collect()
}

/// Parses `XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX`.
fn parse_box(s: &str) -> Result<[f64; 6], String> {
    let v = comma_numbers(s)
        .map_err(|e| format!("expected six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm): {e}"))?;
    let b: [f64; 6] = v.try_into().map_err(|v: Vec<f64>| {
        format!(
            "expected six numbers XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX (mm), got {}",
            v.len()
        )
    })?;
    if (0..3).any(|a| b[a].is_nan() || b[a + 3].is_nan() || b[a] >= b[a + 3]) {
        return Err(format!("each minimum must be below its maximum: {s}"));
    }
    Ok(b)
}

/// `NAME=PATH` → (NAME, PATH).
fn parse_named_path(s: &str) -> Result<(String, PathBuf), String> {
    match s.split_once('=') {
        Some((name, _)) if !name.is_empty() && !flexshape_rig::valid_name(name) => Err(format!(
            "camera name `{name}`: use letters, digits, `_` and `-` only (it names files and folders)"
        )),
        Some((name, path)) if !name.is_empty() && !path.is_empty() => {
            Ok((name.to_string(), PathBuf::from(path)))
        }
        _ => Err(format!(
            "`{s}` is not NAME=PATH (a camera name from the rig, then its input)"
        )),
    }
}

/// The steps of `--radius-steps` (one value holding them all).
#[derive(Debug, Clone)]
pub struct RadiusSteps(pub Vec<flexshape_curve::RadiusStep>);

/// `--radius-steps`: `FROM_TIP:RADIUS` pairs, comma-separated (checked by the simulator).
fn parse_radius_steps(s: &str) -> Result<RadiusSteps, String> {
    s.split(',')
        .map(|pair| {
            let (at, r) = pair
                .split_once(':')
                .ok_or_else(|| format!("`{pair}` is not FROM_TIP:RADIUS (mm, e.g. 70:3)"))?;
            let number = |v: &str| {
                v.trim()
                    .parse::<f64>()
                    .map_err(|_| format!("`{v}` in `{pair}` is not a number of mm"))
            };
            Ok(flexshape_curve::RadiusStep {
                from_tip_mm: number(at)?,
                radius_mm: number(r)?,
            })
        })
        .collect::<Result<_, String>>()
        .map(RadiusSteps)
}

/// `--classifier`: a TOML inline table with a `kind`.
fn parse_classifier(s: &str) -> Result<toml::Value, String> {
    let doc: toml::Table = toml::from_str(&format!("classifier = {s}")).map_err(|e| {
        format!(
            "`{s}` is not a TOML table like '{{ kind = \"difference\", min_difference = 40 }}': {}",
            e.message()
        )
    })?;
    match doc.get("classifier") {
        Some(v @ toml::Value::Table(t)) if t.contains_key("kind") => Ok(v.clone()),
        _ => Err(format!(
            "`{s}` needs a kind: colour_shadow, green_matte or difference, e.g. '{{ kind = \"difference\" }}'"
        )),
    }
}

/// `--interval`: seconds, finite and not negative.
fn parse_interval(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=86_400.0).contains(&v) => Ok(v),
        _ => Err(format!("`{s}` is not a time between 0 and 86400 seconds")),
    }
}

/// `--threads`: at least one.
fn parse_threads(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(0) => Err("at least 1 frame must be processed at once".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("`{s}` is not a number of threads")),
    }
}

/// `STRENGTH,SHININESS` of a specular highlight.
fn parse_gloss(s: &str) -> Result<[f64; 2], String> {
    let v = comma_numbers(s)
        .map_err(|_| format!("`{s}`: give two numbers STRENGTH,SHININESS, e.g. 0.9,20"))?;
    match v[..] {
        [k, n] if (0.0..=10.0).contains(&k) && (1.0..=1e4).contains(&n) => Ok([k, n]),
        _ => Err(format!(
            "`{s}`: give a strength from 0 to 10 and a shininess from 1 to 10000"
        )),
    }
}

/// `R,G,B` reflectances in 0–1.
fn parse_albedo(s: &str) -> Result<[f64; 3], String> {
    let v = comma_numbers(s)
        .map_err(|_| format!("`{s}`: give three numbers R,G,B, e.g. 0.35,0.35,0.35"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|x| (0.0..=1.0).contains(x)) => Ok([r, g, b]),
        _ => Err(format!(
            "`{s}`: give three reflectances R,G,B, each from 0 to 1"
        )),
    }
}
