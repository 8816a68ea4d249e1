//! The golden file: its records, how it is written, and how it is read back with every line
//! checked, so that a truncated or damaged file is an error naming the line, never a pass.

use super::error::RegressionError;
use super::options::{Level, MAX_GOLDEN_BYTES, MAX_GOLDEN_LINE_BYTES};
use serde::{Deserialize, Serialize};
use std::io::{BufRead, Read, Write};
use std::path::Path;

/// The format's version, the header's `kinechain_golden`.
pub(super) const FORMAT: u32 = 1;

/// A robot's link kinematics at a set of configurations.
#[derive(Clone, Debug, PartialEq)]
pub struct Golden {
    /// What was recorded, and from what.
    pub header: Header,
    /// One record per configuration.
    pub samples: Vec<Sample>,
}

/// The first line of a golden file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Header {
    /// The format's version (1).
    pub kinechain_golden: u32,
    /// The robot's name.
    pub robot: String,
    /// Entries of `q`.
    pub dof: usize,
    /// The name of each entry of `q`, in the order the samples list them
    /// ([`super::variable_names`]).
    pub joints: Vec<String>,
    /// The name of each entry of `q̇` and `q̈` ([`super::velocity_names`]) when they are not
    /// `joints` (a robot with a floating joint); empty otherwise.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub rates: Vec<String>,
    /// The links recorded, in the order each sample lists them.
    pub links: Vec<String>,
    /// The kinechain version that wrote the file.
    pub kinechain: String,
    /// The seed of the configurations.
    pub seed: u64,
    /// Number of samples that follow.
    pub samples: usize,
    /// What each link's record holds.
    pub level: Level,
}

impl Header {
    /// The names of the entries of `q̇` and `q̈`: [`Header::rates`], or the joints' when it is
    /// empty.
    #[must_use]
    pub fn rate_names(&self) -> &[String] {
        if self.rates.is_empty() {
            &self.joints
        } else {
            &self.rates
        }
    }
}

/// One configuration and the links' kinematics there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sample {
    /// Its index, from 0.
    pub sample: usize,
    /// Joint positions, in the header's joint order.
    pub q: Vec<f64>,
    /// Joint velocities (levels `vel` and `acc`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qd: Option<Vec<f64>>,
    /// Joint accelerations (level `acc`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qdd: Option<Vec<f64>>,
    /// Each recorded link, in the header's link order.
    pub links: Vec<LinkState>,
}

/// One link's kinematics, world frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkState {
    /// The first three rows of the 4×4 pose `world_from_link`, row by row:
    /// `r00 r01 r02 x r10 r11 r12 y r20 r21 r22 z`.
    pub pose: [f64; 12],
    /// Angular velocity (levels `vel`, `acc`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub omega: Option<[f64; 3]>,
    /// Velocity of the link origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub v: Option<[f64; 3]>,
    /// Angular acceleration (level `acc`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha: Option<[f64; 3]>,
    /// Classical acceleration of the link origin.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub a: Option<[f64; 3]>,
}

impl LinkState {
    /// A pose alone.
    #[must_use]
    pub fn pose(pose: [f64; 12]) -> Self {
        LinkState {
            pose,
            omega: None,
            v: None,
            alpha: None,
            a: None,
        }
    }
}

/// Writes `golden` as JSON lines: the header, then a line per sample, each ended by a line end.
///
/// # Errors
/// Writing fails.
pub fn write_golden(golden: &Golden, out: &mut dyn Write) -> std::io::Result<()> {
    serde_json::to_writer(&mut *out, &golden.header)?;
    out.write_all(b"\n")?;
    for s in &golden.samples {
        serde_json::to_writer(&mut *out, s)?;
        out.write_all(b"\n")?;
    }
    Ok(())
}

/// The bytes [`write_golden`] writes, refused when the file would be larger than
/// [`MAX_GOLDEN_BYTES`] or hold a line longer than [`MAX_GOLDEN_LINE_BYTES`], which
/// [`read_golden_file`] would not read back.
///
/// # Errors
/// [`RegressionError::TooLarge`].
pub fn golden_bytes(golden: &Golden) -> Result<Vec<u8>, RegressionError> {
    let mut text = Vec::new();
    // Writing to a vector cannot fail.
    let _ = write_golden(golden, &mut text);
    let longest = text
        .split(|&b| b == b'\n')
        .map(<[u8]>::len)
        .max()
        .unwrap_or(0);
    if text.len() as u64 > MAX_GOLDEN_BYTES || longest as u64 > MAX_GOLDEN_LINE_BYTES {
        return Err(RegressionError::TooLarge {
            size: text.len(),
            longest_line: longest,
        });
    }
    Ok(text)
}

/// Writes `golden` to the file `path` by the rules of [`crate::io::output`] (never over one of
/// `inputs`; FIFOs and devices in place; regular files replaced whole, links followed).
///
/// # Errors
/// [`RegressionError::TooLarge`] (nothing written) or [`RegressionError::Output`].
pub fn write_golden_file(
    golden: &Golden,
    path: &Path,
    inputs: &[&Path],
) -> Result<(), RegressionError> {
    let bytes = golden_bytes(golden)?;
    Ok(crate::io::output::write_file(path, &bytes, inputs)?)
}

/// Reads and checks the golden file `path` ([`read_golden`]), reading no more than
/// [`MAX_GOLDEN_BYTES`] in all and [`MAX_GOLDEN_LINE_BYTES`] for one line, so that a huge file or
/// an endless stream is an error after a bounded read.
///
/// # Errors
/// [`RegressionError::Read`] when the file cannot be read or is over a limit,
/// [`RegressionError::Golden`] naming the line of a damaged file.
pub fn read_golden_file(path: &Path) -> Result<Golden, RegressionError> {
    let file = path.display().to_string();
    let fail = |source| RegressionError::Read {
        file: file.clone(),
        source,
    };
    let over = |what: String| fail(std::io::Error::other(what));
    let opened = std::fs::File::open(path).map_err(fail)?;
    if let Ok(m) = opened.metadata()
        && m.is_file()
        && m.len() > MAX_GOLDEN_BYTES
    {
        return Err(over(format!(
            "{} bytes, larger than the {MAX_GOLDEN_BYTES} bytes a golden file may be",
            m.len()
        )));
    }
    let mut reader = std::io::BufReader::new(opened).take(MAX_GOLDEN_BYTES + 1);
    let mut bytes = Vec::new();
    for line in 1.. {
        let start = bytes.len();
        let read = (&mut reader)
            .take(MAX_GOLDEN_LINE_BYTES + 1)
            .read_until(b'\n', &mut bytes)
            .map_err(fail)?;
        if read == 0 {
            break;
        }
        if bytes.len() as u64 > MAX_GOLDEN_BYTES {
            return Err(over(format!(
                "larger than the {MAX_GOLDEN_BYTES} bytes a golden file may be"
            )));
        }
        let length = bytes[start..]
            .strip_suffix(b"\n")
            .unwrap_or(&bytes[start..])
            .len();
        if length as u64 > MAX_GOLDEN_LINE_BYTES {
            return Err(over(format!(
                "line {line} is longer than the {MAX_GOLDEN_LINE_BYTES} bytes a golden file's line may be"
            )));
        }
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        over(format!(
            "byte {} is not UTF-8 text",
            e.utf8_error().valid_up_to() + 1
        ))
    })?;
    read_golden(&text, &file)
}

/// Reads a golden file's text (`file` names it in errors), checking every line: the header's
/// format and counts, each sample's index, lengths and the fields its level needs, and that the
/// file holds every sample the header announces and ends with a line end.
///
/// # Errors
/// [`RegressionError::Golden`] naming the line.
pub fn read_golden(text: &str, file: &str) -> Result<Golden, RegressionError> {
    let fail = |line: usize, problem: String| RegressionError::Golden {
        file: file.to_string(),
        line,
        problem,
    };
    let mut lines = text.split('\n').enumerate().map(|(i, l)| (i + 1, l));
    let (_, first) = lines.next().unwrap_or((1, ""));
    let header: Header = serde_json::from_str(first)
        .map_err(|e| fail(1, format!("not a kinechain golden header: {e}")))?;
    if header.kinechain_golden != FORMAT {
        return Err(fail(
            1,
            format!(
                "golden format {} (this kinechain reads {FORMAT})",
                header.kinechain_golden
            ),
        ));
    }
    if header.joints.len() != header.dof {
        return Err(fail(
            1,
            format!(
                "{} joint names for {} degrees of freedom",
                header.joints.len(),
                header.dof
            ),
        ));
    }
    let count = text.split('\n').count();
    let mut samples = Vec::with_capacity(header.samples.min(1 << 20));
    let mut last = 1;
    for (n, line) in lines {
        if line.is_empty() {
            // Only the line end of the last line may leave an empty remainder.
            if n == count {
                break;
            }
            return Err(fail(n, "an empty line".into()));
        }
        last = n;
        let s: Sample = serde_json::from_str(line).map_err(|e| {
            if n == count && !text.ends_with('\n') {
                fail(
                    n,
                    format!("the last line has no line end: the file is cut short ({e})"),
                )
            } else {
                fail(n, format!("not a sample: {e}"))
            }
        })?;
        check_sample(&header, &s, samples.len()).map_err(|p| fail(n, p))?;
        samples.push(s);
    }
    if !text.ends_with('\n') {
        return Err(fail(
            last,
            "the last line has no line end: the file is cut short".into(),
        ));
    }
    if samples.len() != header.samples {
        return Err(fail(
            last + 1,
            format!(
                "the file ends after {} of the {} samples its header announces",
                samples.len(),
                header.samples
            ),
        ));
    }
    Ok(Golden { header, samples })
}

/// What is wrong with sample `s`, expected to be number `index`.
fn check_sample(header: &Header, s: &Sample, index: usize) -> Result<(), String> {
    if s.sample != index {
        return Err(format!("sample {} where sample {index} belongs", s.sample));
    }
    let sized = |what: &str, v: Option<&Vec<f64>>, needed: bool| {
        let n = if what == "q" {
            header.dof
        } else {
            header.rate_names().len()
        };
        match (v, needed) {
            (Some(v), true) if v.len() == n => Ok(()),
            (Some(v), true) => Err(format!("{what} has {} entries, not {n}", v.len())),
            (None, true) => Err(format!("{what} is missing (level {})", header.level)),
            (Some(_), false) => Err(format!("{what} does not belong to level {}", header.level)),
            (None, false) => Ok(()),
        }
    };
    sized("q", Some(&s.q), true)?;
    sized("qd", s.qd.as_ref(), header.level != Level::Pose)?;
    sized("qdd", s.qdd.as_ref(), header.level == Level::Acc)?;
    if s.links.len() != header.links.len() {
        return Err(format!(
            "{} links, not the header's {}",
            s.links.len(),
            header.links.len()
        ));
    }
    let vel = header.level != Level::Pose;
    let acc = header.level == Level::Acc;
    for (l, name) in s.links.iter().zip(&header.links) {
        let fields = [
            ("omega", l.omega.is_some(), vel),
            ("v", l.v.is_some(), vel),
            ("alpha", l.alpha.is_some(), acc),
            ("a", l.a.is_some(), acc),
        ];
        for (what, has, needed) in fields {
            if has != needed {
                return Err(format!(
                    "link '{}': {what} {} at level {}",
                    crate::model::error::escape_controls(name),
                    if has { "does not belong" } else { "is missing" },
                    header.level
                ));
            }
        }
    }
    Ok(())
}
