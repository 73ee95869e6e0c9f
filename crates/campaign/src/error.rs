//! Why a campaign, a sweep, a shard merge, a check or one trial failed: [`CampaignError`],
//! the one error type of the crate, with one variant per situation. Every message names
//! the file, field, trial, shard or point it is about; none names a command-line option
//! (the front ends add those in their context).

use std::ops::Range;
use std::path::PathBuf;

/// Why a campaign or one of its trials failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CampaignError {
    /// The scenario is unusable.
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// The virtual robot could not be built or simulated.
    #[error("trial {trial}: virtual robot: {source}")]
    Sim {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: virtual_robot::SimError,
    },
    /// Identification failed.
    #[error("trial {trial}: identification: {source}")]
    Identify {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: identify::IdentifyError,
    },
    /// The learned residual model (scenario `residual_model`) could not be cross-validated
    /// or fitted.
    #[error("trial {trial}: residual model: {source}")]
    Residual {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: calibrate::residual::ResidualError,
    },
    /// The design of the identification poses failed.
    #[error("trial {trial}: design: {source}")]
    Design {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: design::DesignError,
    },
    /// Evaluation failed (e.g. no validation pose could be measured).
    #[error("trial {trial}: evaluation: {source}")]
    Evaluate {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: evaluate::EvalError,
    },
    /// The scenario's extended parameters (`identification.extended`) do not fit the robot.
    #[error("identification.extended: {source}")]
    ExtendedModel {
        /// Cause.
        #[source]
        source: kinematics::ModelError,
    },
    /// The truth of a trial could not be expressed in the extended parameter families.
    #[error("trial {trial}: the extended truth: {source}")]
    ExtendedTruth {
        /// Trial index.
        trial: u64,
        /// Cause.
        #[source]
        source: kinematics::ModelError,
    },
    /// The calibration of a proof ([`crate::CartesianProof`]) failed.
    #[error("{what}: {source}")]
    Calibrate {
        /// What was being done.
        what: String,
        /// Cause (boxed: a calibration error would set the size of every `Result` of this
        /// crate).
        #[source]
        source: Box<calibrate::CalibrateError>,
    },
    /// A step of a proof ([`crate::CartesianProof`]) failed.
    #[error("{what}: {reason}")]
    Proof {
        /// What was being done.
        what: String,
        /// Why.
        reason: String,
    },
    /// The ISO 9283 test could not be set up: the tracker of the scenario is unusable.
    #[error("ISO 9283 setup: {source}")]
    IsoTracker {
        /// Cause.
        #[source]
        source: virtual_robot::ConfigError,
    },
    /// The ISO 9283 test could not be set up: no admissible cube.
    #[error("ISO 9283 setup: {source}")]
    IsoCube {
        /// Cause.
        #[source]
        source: evaluate::EvalError,
    },
    /// The ISO 9283 test could not be set up: a test point of the cube is not reachable.
    #[error("ISO 9283 setup: test point {point_mm:?} of the cube is not reachable")]
    IsoUnreachable {
        /// The test point, mm.
        point_mm: [f64; 3],
    },
    /// An ISO 9283 test point could not be measured in a trial.
    #[error("trial {trial}: ISO point P{point}: {source}")]
    IsoMeasurement {
        /// Trial index.
        trial: u64,
        /// The point, 1 to 5.
        point: usize,
        /// Cause.
        #[source]
        source: virtual_robot::NotMeasurable,
    },
    /// A sweep, shard or check file that does not parse: malformed JSON, an unknown or
    /// missing field, a wrong type.
    #[error("{file}: field `{field}`: {message}")]
    Parse {
        /// The file.
        file: String,
        /// Path of the field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A file could not be read, written or removed.
    #[error("{path}: {source}")]
    Io {
        /// File.
        path: String,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// An output file, or the set of a run's outputs, could not be written (`path` is the
    /// file or the output directory; the cause names the file).
    #[error("writing {}", .path.display())]
    Write {
        /// The file or directory written.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The files of a simulated trial could not be written.
    #[error("writing into {}", .dir.display())]
    WriteSimulation {
        /// The output directory.
        dir: PathBuf,
        /// Cause.
        #[source]
        source: virtual_robot::SimError,
    },
    /// The output directory could not be created.
    #[error("{}: creating the directory", .path.display())]
    CreateDir {
        /// The directory.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The output directory names an existing file.
    #[error("{}: a file of that name exists; the output must be a directory", .path.display())]
    OutputIsAFile {
        /// The path given as the output directory.
        path: PathBuf,
    },
    /// A state file (checkpoint, shard) could not be serialised.
    #[error("{path}: serialising: {source}")]
    Serialise {
        /// The file.
        path: String,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// A shard file's content does not match its digest, or is inconsistent.
    #[error("{file}: field `{field}`: not the shard file as written: {problem}")]
    ShardContent {
        /// The file.
        file: String,
        /// The field at fault (`digest`, `aggregate.trials`).
        field: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// A file is not valid UTF-8.
    #[error("{path}:{line}: not valid UTF-8")]
    NotUtf8 {
        /// The file.
        path: String,
        /// 1-based line of the first invalid byte.
        line: usize,
    },
    /// The worker threads could not be started.
    #[error("building the thread pool")]
    ThreadPool(#[source] rayon::ThreadPoolBuildError),
    /// A trial count override of 0.
    #[error("trials must be at least 1")]
    ZeroTrials,
    /// A checkpoint interval of 0 trials.
    #[error("the checkpoint interval must be at least 1 trial")]
    ZeroCheckpointInterval,
    /// A thread count of 0 (leaving the count out means all cores).
    #[error("the thread count must be at least 1 (leave it out to use all cores)")]
    ZeroThreads,
    /// The caller asked the run to stop ([`crate::Observer::stop_requested`]): the trials in
    /// progress finished, the others did not start, and nothing was written (a checkpoint
    /// written before stays, and `--resume` continues from it).
    #[error("stopped on request after {done} trials")]
    Stopped {
        /// Trials finished before the run stopped (a checkpoint's included).
        done: u64,
    },
    /// A trial count beyond what the run can count or hold.
    #[error("{what} {count}: more than the limit of {limit} ({why})")]
    TooLarge {
        /// What was counted, e.g. "trials per sweep point".
        what: &'static str,
        /// The count asked for.
        count: u64,
        /// The limit.
        limit: u64,
        /// Why the limit, and what to do.
        why: String,
    },
    /// The output directory cannot be used (not a directory, another run holds it, …) or its
    /// set could not be written; the directory keeps its previous set.
    #[error(transparent)]
    Output(#[from] measurements::OutputError),
    /// Every trial failed: the outputs (all `n/a`, with the causes) were written, but the
    /// run produced no figure.
    #[error(
        "no trial succeeded ({trials} of {trials} failed; most often: {cause}); the outputs in {out} list the causes"
    )]
    NoSuccessfulTrial {
        /// Trials run.
        trials: u64,
        /// The most frequent failure.
        cause: String,
        /// The output directory (or shard file).
        out: PathBuf,
    },
    /// A shard index outside the shard count (or a count of 0).
    #[error("shard {shard}/{shards}: need 0 <= k < K")]
    InvalidShard {
        /// The shard index k.
        shard: u64,
        /// The shard count K.
        shards: u64,
    },
    /// A checkpoint file that does not parse.
    #[error(
        "{path}: not a checkpoint file (line {}, column {}: {source}); delete it to start afresh",
        .source.line(),
        .source.column()
    )]
    NotACheckpoint {
        /// The file.
        path: String,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// A sweep checkpoint file that does not parse.
    #[error(
        "{path}: not a sweep checkpoint (line {}, column {}: {source}); delete it to start afresh",
        .source.line(),
        .source.column()
    )]
    NotASweepCheckpoint {
        /// The file.
        path: String,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// A checkpoint whose fields contradict each other.
    #[error(
        "{path}: inconsistent checkpoint: field `{field}`: {problem}; delete it to start afresh"
    )]
    InconsistentCheckpoint {
        /// The file.
        path: String,
        /// The field.
        field: &'static str,
        /// What is wrong with it.
        problem: String,
    },
    /// A checkpoint of an unfinished run is there and the run was not asked to resume.
    #[error(
        "{}: a checkpoint of an unfinished {what} is there; resume to continue it, or delete \
         it to start afresh",
        .path.display()
    )]
    UnfinishedCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// `run` or `sweep`.
        what: &'static str,
    },
    /// The checkpoint to resume belongs to another run or sweep.
    #[error(
        "{}: cannot resume, the checkpoint belongs to another {what}: {}; delete it to start \
         afresh",
        .path.display(),
        .differences.join("; ")
    )]
    CheckpointMismatch {
        /// The checkpoint file.
        path: PathBuf,
        /// `run` or `sweep`.
        what: &'static str,
        /// What differs, one item each.
        differences: Vec<String>,
    },
    /// The current point of a sweep checkpoint belongs to another run of that point.
    #[error(
        "{}: cannot resume point {point}: {}; delete it to start afresh",
        .path.display(),
        .differences.join("; ")
    )]
    SweepPointMismatch {
        /// The checkpoint file.
        path: PathBuf,
        /// The point (0-based).
        point: usize,
        /// What differs, one item each.
        differences: Vec<String>,
    },
    /// The current point of a sweep checkpoint holds a malformed aggregate.
    #[error("{}: point {point}: field `current.aggregate`: {problem}", .path.display())]
    SweepPointAggregate {
        /// The checkpoint file.
        path: PathBuf,
        /// The point (0-based).
        point: usize,
        /// What is wrong.
        problem: String,
    },
    /// `merge` was given no shard file.
    #[error("no shard files to merge")]
    NoShards,
    /// Fewer shard files than the campaign has shards (or a count of 0).
    #[error("{files} shard file(s) given for a campaign of {shards} shards")]
    ShardCount {
        /// Files given.
        files: usize,
        /// Shards of the campaign, as the first file says.
        shards: u64,
    },
    /// A shard file of another campaign.
    #[error("shard {shard} belongs to another campaign (scenario, version or shard count differ)")]
    ForeignShard {
        /// The shard index.
        shard: u64,
    },
    /// A shard whose trial range is not its share.
    #[error("shard {shard} of {shards} has trials {}..{}, expected {expected:?}", .trials.start, .trials.end)]
    ShardRange {
        /// The shard index.
        shard: u64,
        /// The shard count.
        shards: u64,
        /// The range it has.
        trials: Range<u64>,
        /// The range it should have.
        expected: Range<u64>,
    },
    /// A shard other than shard 0, or of a scenario without a budget, carries a residual
    /// budget.
    #[error(
        "shard {shard} of {shards}: carries a residual budget, which only shard 0 of a \
         budgeted scenario may"
    )]
    UnexpectedShardBudget {
        /// The shard index.
        shard: u64,
        /// The shard count.
        shards: u64,
    },
    /// Shard 0 of a budgeted scenario has no residual budget.
    #[error(
        "shard {shard} of {shards}: the scenario asks for a residual budget and shard 0 has none"
    )]
    MissingShardBudget {
        /// The shard index.
        shard: u64,
        /// The shard count.
        shards: u64,
    },
    /// The same shard given twice.
    #[error("shard {shard} appears twice")]
    DuplicateShard {
        /// The shard index.
        shard: u64,
    },
    /// A shard is missing from the files given.
    #[error("shard {shard} of {shards} is missing")]
    MissingShard {
        /// The shard index.
        shard: u64,
        /// The shard count.
        shards: u64,
    },
    /// A shard's aggregate is malformed (the problem names the statistic).
    #[error("shard {shard} of {shards}: {problem}")]
    ShardAggregate {
        /// The shard index.
        shard: u64,
        /// The shard count.
        shards: u64,
        /// What is wrong.
        problem: String,
    },
    /// A campaign plot could not be drawn.
    #[error("plot: {0}")]
    Plot(#[source] report::PlotError),
    /// A sweep plot could not be drawn.
    #[error("plot {plot}: {source}")]
    SweepPlot {
        /// The plot, 1-based, in the sweep file's order.
        plot: usize,
        /// Cause.
        #[source]
        source: SweepPlotError,
    },
    /// A sweep file without axes, or with an axis without values.
    #[error("{}: field `axes`: needs at least one axis, each with values", .file.display())]
    SweepWithoutAxes {
        /// The sweep file.
        file: PathBuf,
    },
    /// A sweep file with 0 trials per point.
    #[error("{}: field `trials`: must be at least 1", .file.display())]
    SweepWithoutTrials {
        /// The sweep file.
        file: PathBuf,
    },
    /// The base scenario of a sweep or check is not JSON.
    #[error("{}: {source}", .file.display())]
    BaseScenarioJson {
        /// The scenario file.
        file: PathBuf,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// The base scenario of a sweep or check is not a JSON object.
    #[error("{}: the scenario is not a JSON object", .file.display())]
    ScenarioNotAnObject {
        /// The scenario file.
        file: PathBuf,
    },
    /// An override of a sweep or check cannot be set.
    #[error("{what} override `{path}`: {source}")]
    Override {
        /// `sweep` or `check`.
        what: String,
        /// The dotted field path.
        path: String,
        /// Cause.
        #[source]
        source: FieldPathError,
    },
    /// A sweep axis cannot be set.
    #[error("sweep axis `{axis}`: {source}")]
    SweepAxis {
        /// The axis' dotted field path.
        axis: String,
        /// Cause.
        #[source]
        source: FieldPathError,
    },
    /// A check file that does not parse.
    #[error("{}: {source}", .file.display())]
    CheckFileJson {
        /// The check file.
        file: PathBuf,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// A tolerance of a check file that is negative or not finite.
    #[error("{}: tolerances.{name} = {value}: must be a finite number ≥ 0", .file.display())]
    Tolerance {
        /// The check file.
        file: PathBuf,
        /// The tolerance.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// A check with 0 trials.
    #[error("{}: check `{check}`: trials must be ≥ 1", .file.display())]
    CheckTrials {
        /// The check file.
        file: PathBuf,
        /// The check.
        check: String,
    },
    /// A check name that is empty, has a path separator or is repeated.
    #[error(
        "{}: check name `{check}` is empty, has a path separator or is repeated",
        .file.display()
    )]
    CheckName {
        /// The check file.
        file: PathBuf,
        /// The name.
        check: String,
    },
}

/// Why a dotted field path (`poses.identification`) cannot be set in a scenario's JSON.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FieldPathError {
    /// A part of the path before the last names a value that is not an object.
    #[error("`{prefix}` is not an object")]
    NotAnObject {
        /// The path up to that value.
        prefix: String,
    },
}

/// Why a sweep plot cannot be drawn.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SweepPlotError {
    /// `plot.x` names no axis of the sweep.
    #[error("plot x `{x}` is not an axis")]
    NotAnAxis {
        /// The path given.
        x: String,
    },
    /// The x axis has a value that is not a number.
    #[error("plot x axis `{axis}` has a non-numeric value")]
    NotNumeric {
        /// The axis' path.
        axis: String,
    },
    /// `plot.y` names no metric of a campaign.
    #[error("plot y `{y}` is not a metric; the metrics are: {known}")]
    UnknownMetric {
        /// The name given.
        y: String,
        /// Every metric name, comma-separated.
        known: String,
    },
    /// The plotting layer refused the figure.
    #[error(transparent)]
    Draw(#[from] report::PlotError),
}
