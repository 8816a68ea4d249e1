//! What a regression run evaluates and how it judges: the [`Level`] of rates recorded, the
//! sampling [`Options`], the [`Tolerances`] of a verdict, and the largest golden file read back.

/// What a record holds for each link: poses, poses and velocities (ω, v), or poses, velocities
/// and accelerations (α, classical a).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Level {
    /// Poses.
    Pose,
    /// Poses, ω and v.
    Vel,
    /// Poses, ω, v, α and a.
    Acc,
}

impl Level {
    /// `pose`, `vel` or `acc`, as written in a golden file and on the command line.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Level::Pose => "pose",
            Level::Vel => "vel",
            Level::Acc => "acc",
        }
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How configurations are drawn and which links are recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Random configurations, drawn uniformly within the limits (entries without limits from
    /// `[−π, π]`), besides the zero configuration and the two limit corners where the limits
    /// admit them.
    pub samples: usize,
    /// Seed of the draw: the same seed gives the same configurations.
    pub seed: u64,
    /// What is recorded.
    pub level: Level,
    /// The links recorded, by name; empty: every link.
    pub links: Vec<String>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            samples: 100,
            seed: 1,
            level: Level::Pose,
            links: Vec::new(),
        }
    }
}

/// The largest differences a link may show and still pass.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Tolerances {
    /// Distance between the two positions of a link origin (m).
    pub position: f64,
    /// Angle of the rotation between the two orientations of a link (rad).
    pub rotation: f64,
    /// Norm of the difference of ω, v, α or a (rad/s, m/s, rad/s², m/s²).
    pub rates: f64,
}

impl Default for Tolerances {
    /// 1e-9 m, 1e-9 rad, 1e-9 for the rates.
    fn default() -> Self {
        Tolerances {
            position: 1e-9,
            rotation: 1e-9,
            rates: 1e-9,
        }
    }
}

/// Largest golden file read or written, in bytes (a record of 100 000 samples of a 13-link arm's
/// poses is about 350 MB; a regression record is usually a few hundred kB).
pub const MAX_GOLDEN_BYTES: u64 = 256 << 20;

/// Longest line of a golden file, in bytes: a header naming every joint and link, or one sample
/// of every link's pose and rates, of robots up to the largest file a robot may be
/// ([`MAX_FILE_BYTES`](crate::io::MAX_FILE_BYTES)). A stream without line ends (`/dev/zero`) is
/// refused once this much of it has been read.
pub const MAX_GOLDEN_LINE_BYTES: u64 = 32 << 20;
