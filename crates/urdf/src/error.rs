//! Typed errors of the URDF conversion: each names the file and the URDF element.

use std::path::PathBuf;

/// Everything that can go wrong converting between URDF and robot files.
#[derive(Debug, thiserror::Error)]
pub enum UrdfError {
    /// A file could not be read.
    #[error("{file}: cannot read: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The text is not well-formed URDF XML (what the parser said).
    #[error("{source_name}: not a readable URDF: {message}")]
    Xml {
        /// File path or label of the text.
        source_name: String,
        /// The parser's message.
        message: String,
    },
    /// `--base` or `--tip` names no `<link>` of the description.
    #[error("{source_name}: no <link name=\"{link}\"> (the {role} link); links: {known}")]
    UnknownLink {
        /// File path or label.
        source_name: String,
        /// The link asked for.
        link: String,
        /// `base` or `tip`.
        role: &'static str,
        /// The links the description has, comma-separated.
        known: String,
    },
    /// Walking up from the tip never reaches the base.
    #[error(
        "{source_name}: <link name=\"{tip}\"> is not below <link name=\"{base}\">: its chain of parents is {path}"
    )]
    TipNotBelowBase {
        /// File path or label.
        source_name: String,
        /// The base link.
        base: String,
        /// The tip link.
        tip: String,
        /// The tip's ancestors, tip first, ` ← `-separated.
        path: String,
    },
    /// A link is the child of two joints: not a tree, so the chain is ambiguous.
    #[error(
        "{source_name}: <link name=\"{link}\"> is the child of two joints, <joint name=\"{first}\"> and <joint name=\"{second}\">: a branching (closed) chain, not a serial one"
    )]
    Branching {
        /// File path or label.
        source_name: String,
        /// The link with two parents.
        link: String,
        /// The first joint naming it as child.
        first: String,
        /// The second.
        second: String,
    },
    /// The joints close a loop: a joint whose parent and child are the same link, or a chain
    /// of joints leading from a link back to itself (e.g. a fixed joint from the tip back to
    /// the base). A robot file describes an open serial chain only.
    #[error(
        "{source_name}: <joint name=\"{joint}\"> closes a loop ({cycle}): a closed structure, not a serial chain"
    )]
    ClosedLoop {
        /// File path or label.
        source_name: String,
        /// The joint closing the loop: of the loop's joints, the last in the file.
        joint: String,
        /// The loop as links, child to parent, ` ← `-separated, starting and ending at the
        /// same link (`l2 ← l2` for a joint from a link to itself).
        cycle: String,
    },
    /// A joint type a revolute serial robot file cannot hold, on the chain between base and tip.
    #[error(
        "{source_name}: <joint name=\"{joint}\" type=\"{kind}\"> lies on the chain {chain}: only revolute and prismatic (with limits) and fixed joints can be converted{hint}"
    )]
    UnsupportedJoint {
        /// File path or label.
        source_name: String,
        /// The joint.
        joint: String,
        /// Its type attribute.
        kind: &'static str,
        /// `from "base" to "tip"`.
        chain: String,
        /// A suggestion (e.g. for continuous joints).
        hint: &'static str,
    },
    /// A revolute joint without usable `<limit lower upper>`.
    #[error(
        "{source_name}: <joint name=\"{joint}\" type=\"revolute\">: <limit> is missing or empty (lower {lower}, upper {upper}); the robot file needs lower < upper"
    )]
    MissingLimits {
        /// File path or label.
        source_name: String,
        /// The joint.
        joint: String,
        /// The lower limit read (0 when absent).
        lower: f64,
        /// The upper limit read.
        upper: f64,
    },
    /// A joint whose `<axis xyz>` is the zero vector or not finite.
    #[error("{source_name}: <joint name=\"{joint}\">: <axis xyz=\"{xyz}\"> is not a direction")]
    BadAxis {
        /// File path or label.
        source_name: String,
        /// The joint.
        joint: String,
        /// The axis as read.
        xyz: String,
    },
    /// A number of the description is not finite.
    #[error("{source_name}: <joint name=\"{joint}\">: <origin> has a value that is not finite")]
    NotFinite {
        /// File path or label.
        source_name: String,
        /// The joint.
        joint: String,
    },
    /// The chain holds no revolute joint, or more than the robot file allows.
    #[error(
        "{source_name}: the chain from \"{base}\" to \"{tip}\" has {found} revolute joints; a robot file needs 1 to {max}"
    )]
    JointCount {
        /// File path or label.
        source_name: String,
        /// The base link.
        base: String,
        /// The tip link.
        tip: String,
        /// Revolute joints found.
        found: usize,
        /// The most a robot file can hold.
        max: usize,
    },
    /// A robot too large or too small for a robot arm: lengths in the wrong unit
    /// ([`crate::check_reach`]).
    #[error(
        "{source_name}: the imported robot reaches {reach_mm:.1} mm from its base (the measured point at q = 0 or mid-limits), outside the {min} … {max} mm of robot arms: {looks_like}; convert the file, or import it as it is with the override (allow_implausible_size)",
        min = crate::MIN_REACH_MM,
        max = crate::MAX_REACH_MM
    )]
    ImplausibleSize {
        /// File path or label.
        source_name: String,
        /// The reach, mm.
        reach_mm: f64,
        /// What the size suggests.
        looks_like: &'static str,
    },
    /// Export options that do not fit the robot (e.g. a joint-name list of another length).
    #[error("{0}")]
    Options(String),
    /// The robot file produced or read was rejected by the kinematics crate.
    #[error(transparent)]
    Model(#[from] kinematics::ModelError),
}
