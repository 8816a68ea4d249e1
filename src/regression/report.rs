//! The report of a verification or comparison: per link, the largest differences and where they
//! occur, and the verdict.

use super::golden::LinkState;
use super::options::{Level, Tolerances};
use crate::eval::Chain;
use crate::model::error::escape_controls;
use serde::Serialize;
use std::fmt;

/// A largest difference and the sample where it occurs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Worst {
    /// The difference (m, rad, or the rates' units).
    pub max: f64,
    /// The sample, from 0.
    pub sample: usize,
}

impl Worst {
    fn add(&mut self, x: f64, sample: usize) {
        // A NaN difference is the worst there is.
        if x > self.max || (x.is_nan() && !self.max.is_nan()) {
            *self = Worst { max: x, sample };
        }
    }
}

/// One link's differences over every sample.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinkReport {
    /// The link.
    pub link: String,
    /// The joint above it (its parent joint), if any.
    pub joint: Option<String>,
    /// Joints between the base and the link.
    pub depth: usize,
    /// Distance between the positions of the link origin (m).
    pub position: Worst,
    /// [`LinkReport::position`] in ulps of the robot's reach (`max / (reach · 2⁻⁵²)`).
    pub position_ulps: f64,
    /// Angle of the rotation between the two orientations (rad).
    pub rotation: Worst,
    /// Largest norm of the difference of ω, v, α or a (levels `vel` and `acc`).
    pub rates: Option<Worst>,
    /// Whether every difference is within the tolerances.
    pub within: bool,
}

/// Joints and links by name.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Names {
    /// Joint entries (`NAME`, or `NAME.theta` / `NAME.d`).
    pub joints: Vec<String>,
    /// Links.
    pub links: Vec<String>,
}

/// The result of [`super::verify`] or [`super::compare`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// The robot evaluated (the second one of a comparison).
    pub robot: String,
    /// `"pass"` or `"fail"` (also [`Report::passed`]).
    pub verdict: &'static str,
    /// What was compared.
    pub level: Level,
    /// Samples compared.
    pub samples: usize,
    /// The tolerances applied.
    pub tolerances: Tolerances,
    /// The evaluated robot's reach (m), the unit of [`LinkReport::position_ulps`].
    pub reach: f64,
    /// Samples outside the evaluated robot's limits (evaluated anyway).
    pub outside_limits: usize,
    /// The link that moved beyond the tolerances nearest the base (fewest joints; of equally
    /// near ones, the first in the chain's order), if any.
    pub first_moved: Option<LinkReport>,
    /// Every link compared, in the chain's order.
    pub links: Vec<LinkReport>,
    /// Of a comparison, what only the first robot has.
    pub only_in_first: Names,
    /// Of a comparison, what only the second robot has.
    pub only_in_second: Names,
}

impl Report {
    /// An empty report over the links `names` of `chain`.
    pub(super) fn new(
        chain: &Chain,
        names: &[String],
        level: Level,
        tolerances: &Tolerances,
    ) -> Self {
        let links = names
            .iter()
            .map(|name| {
                let (mut depth, mut joint) = (0, None);
                if let Ok(id) = chain.link_id(name) {
                    let mut above = chain.link(id).parent_joint();
                    joint = above.map(|j| chain.joint(j).name().to_string());
                    while let Some(j) = above {
                        depth += 1;
                        above = chain.link(chain.joint(j).parent()).parent_joint();
                    }
                }
                LinkReport {
                    link: name.clone(),
                    joint,
                    depth,
                    position: Worst {
                        max: 0.0,
                        sample: 0,
                    },
                    position_ulps: 0.0,
                    rotation: Worst {
                        max: 0.0,
                        sample: 0,
                    },
                    rates: (level != Level::Pose).then_some(Worst {
                        max: 0.0,
                        sample: 0,
                    }),
                    within: true,
                }
            })
            .collect();
        Report {
            robot: chain.name().to_string(),
            verdict: "pass",
            level,
            samples: 0,
            tolerances: *tolerances,
            reach: chain.reach(),
            outside_limits: 0,
            first_moved: None,
            links,
            only_in_first: Names::default(),
            only_in_second: Names::default(),
        }
    }

    /// Adds one sample's differences between the recorded and the evaluated states.
    pub(super) fn add(&mut self, sample: usize, recorded: &[LinkState], now: &[LinkState]) {
        let unit = if self.reach > 0.0 { self.reach } else { 1.0 } * f64::EPSILON;
        let tol = self.tolerances;
        for ((r, a), b) in self.links.iter_mut().zip(recorded).zip(now) {
            r.position
                .add(position_difference(&a.pose, &b.pose), sample);
            r.rotation
                .add(rotation_difference(&a.pose, &b.pose), sample);
            if let Some(rates) = &mut r.rates {
                for (x, y) in [
                    (a.omega, b.omega),
                    (a.v, b.v),
                    (a.alpha, b.alpha),
                    (a.a, b.a),
                ] {
                    if let (Some(x), Some(y)) = (x, y) {
                        rates.add(norm3(x, y), sample);
                    }
                }
            }
            r.position_ulps = r.position.max / unit;
            r.within = r.position.max <= tol.position
                && r.rotation.max <= tol.rotation
                && r.rates.is_none_or(|w| w.max <= tol.rates);
        }
        self.first_moved = self
            .links
            .iter()
            .filter(|l| !l.within)
            .min_by_key(|l| l.depth)
            .cloned();
        self.verdict = if self.first_moved.is_none() {
            "pass"
        } else {
            "fail"
        };
    }

    /// Whether every link is within the tolerances.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.first_moved.is_none()
    }

    /// The links, the worst first: by the largest of their differences, each divided by its
    /// tolerance.
    #[must_use]
    pub fn worst_first(&self) -> Vec<&LinkReport> {
        let t = self.tolerances;
        let score = |l: &LinkReport| {
            let rates = l.rates.map_or(0.0, |w| w.max / t.rates);
            (l.position.max / t.position)
                .max(l.rotation.max / t.rotation)
                .max(rates)
        };
        let mut links: Vec<&LinkReport> = self.links.iter().collect();
        links.sort_by(|a, b| score(b).total_cmp(&score(a)));
        links
    }
}

fn norm3(a: [f64; 3], b: [f64; 3]) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// Distance between the origins of two poses (entries 3, 7, 11).
fn position_difference(a: &[f64; 12], b: &[f64; 12]) -> f64 {
    norm3([a[3], a[7], a[11]], [b[3], b[7], b[11]])
}

/// Angle of the rotation between two orientations: `‖A − B‖_F = 2√2 sin(θ/2)` for rotations,
/// so `θ = 2 asin(‖A − B‖_F / 2√2)`, accurate for the small angles that matter here (where
/// `acos` of the trace loses half the digits).
fn rotation_difference(a: &[f64; 12], b: &[f64; 12]) -> f64 {
    let mut sum = 0.0;
    for row in 0..3 {
        for col in 0..3 {
            let d = a[4 * row + col] - b[4 * row + col];
            sum += d * d;
        }
    }
    2.0 * (sum.sqrt() / (2.0 * std::f64::consts::SQRT_2))
        .min(1.0)
        .asin()
}

impl fmt::Display for Report {
    /// The table for people: the links, worst first, then the verdict.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = &self.tolerances;
        writeln!(
            f,
            "{}: {} links, {} samples, level {}; tolerances {:e} m, {:e} rad{}",
            escape_controls(&self.robot),
            self.links.len(),
            self.samples,
            self.level,
            t.position,
            t.rotation,
            if self.level == Level::Pose {
                String::new()
            } else {
                format!(", rates {:e}", t.rates)
            }
        )?;
        write!(
            f,
            "{:<24} {:<24} {:>12} {:>12} {:>7} {:>12} {:>7}",
            "link", "joint above", "position (m)", "ulp of reach", "sample", "rotation", "sample"
        )?;
        if self.level != Level::Pose {
            write!(f, " {:>12} {:>7}", "rates", "sample")?;
        }
        writeln!(f)?;
        for l in self.worst_first() {
            write!(
                f,
                "{:<24} {:<24} {:>12.3e} {:>12} {:>7} {:>12.3e} {:>7}",
                escape_controls(&l.link),
                escape_controls(l.joint.as_deref().unwrap_or("-")),
                l.position.max,
                if l.position_ulps < 1e5 {
                    format!("{:.1}", l.position_ulps)
                } else {
                    format!("{:.2e}", l.position_ulps)
                },
                l.position.sample,
                l.rotation.max,
                l.rotation.sample
            )?;
            if let Some(r) = l.rates {
                write!(f, " {:>12.3e} {:>7}", r.max, r.sample)?;
            }
            writeln!(f, "{}", if l.within { "" } else { "  moved" })?;
        }
        for (which, names) in [
            ("first", &self.only_in_first),
            ("second", &self.only_in_second),
        ] {
            for (what, list) in [("joints", &names.joints), ("links", &names.links)] {
                if !list.is_empty() {
                    let list: Vec<String> = list
                        .iter()
                        .map(|n| escape_controls(n).into_owned())
                        .collect();
                    writeln!(f, "only in the {which} robot, {what}: {}", list.join(", "))?;
                }
            }
        }
        if self.outside_limits > 0 {
            writeln!(
                f,
                "{} samples are outside this robot's limits (evaluated anyway)",
                self.outside_limits
            )?;
        }
        match &self.first_moved {
            None => write!(f, "pass: every link within the tolerances"),
            Some(l) => {
                let moved = self.links.iter().filter(|l| !l.within).count();
                write!(
                    f,
                    "fail: {moved} link(s) moved beyond the tolerances; the first along the chain is '{}' below joint '{}' ({:.3e} m at sample {}, {:.3e} rad at sample {})",
                    escape_controls(&l.link),
                    escape_controls(l.joint.as_deref().unwrap_or("-")),
                    l.position.max,
                    l.position.sample,
                    l.rotation.max,
                    l.rotation.sample
                )
            }
        }
    }
}
