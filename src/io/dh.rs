//! Denavit–Hartenberg YAML: standard and modified (Craig, eq. 2.129) tables and the axis form
//! (eq. 2.119). The serde structs of this file never leave it.
//!
//! ```yaml
//! name: puma560
//! convention: standard        # standard | modified | axis   (required)
//! angle_unit: rad             # rad (default) | deg
//! base: {name: base, xyz: [0, 0, 0], rpy: [0, 0, 0]}   # or {name: base, matrix: [[..4 rows..]]}
//! tool: {name: tool, xyz: [0, 0, 0.1]}
//! joints:
//!   - {name: j1, link: link1, type: revolute, a: 0, alpha: 1.5708, d: 0.6718, theta: 0, limits: [-2.79, 2.79]}
//! ```

use crate::io::error::{FieldProblem, LoadErrorKind};
use crate::model::builder::{ChainBuilder, JointSpec};
use crate::model::joint::{JointKind, Limits};
use crate::model::transform::Transform;
use serde::Deserialize;
use serde::de::{self, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde_saphyr::{Location, Spanned, Tagged};
use std::f64::consts::TAU;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRobot {
    name: Option<String>,
    convention: Convention,
    #[serde(default)]
    angle_unit: AngleUnit,
    base: Option<RawFrame>,
    tool: Option<RawFrame>,
    joints: Vec<RawJoint>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum Convention {
    Standard,
    Modified,
    Axis,
}

impl Convention {
    fn context(self) -> &'static str {
        match self {
            Convention::Standard => "for convention standard",
            Convention::Modified => "for convention modified",
            Convention::Axis => "for convention axis",
        }
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum AngleUnit {
    #[default]
    Rad,
    Deg,
}

/// A frame: a name and either `xyz`/`rpy` or a 4×4 `matrix`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    name: Option<String>,
    xyz: Option<[Plain; 3]>,
    rpy: Option<[Angle; 3]>,
    matrix: Option<[[Plain; 4]; 4]>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
enum RawKind {
    Revolute,
    Continuous,
    Prismatic,
    Cylindrical,
    Fixed,
    Floating,
    Ball,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawJoint {
    name: String,
    link: Option<String>,
    #[serde(rename = "type")]
    kind: RawKind,
    a: Option<Plain>,
    alpha: Option<Angle>,
    d: Option<Plain>,
    theta: Option<Angle>,
    /// Boxed: a frame's spanned numbers take about 2 kB, which every row of a DH table (no
    /// `origin`) would otherwise hold while the file is read.
    origin: Option<Box<RawFrame>>,
    axis: Option<[Plain; 3]>,
    limits: Option<RawLimits>,
}

/// A number that is not an angle: unit tags and `deg(..)`/`rad(..)` conversions are refused.
#[derive(Debug, Deserialize)]
#[serde(transparent)]
struct Plain(Spanned<Tagged<f64>>);

/// An angle: a number in `angle_unit`, a `!degrees`/`!radians` tagged value, or an expression.
#[derive(Debug, Deserialize)]
#[serde(transparent)]
struct Angle(Spanned<Tagged<f64>>);

/// `[lo, hi]`, or `{theta: [lo, hi], d: [lo, hi]}` for a cylindrical joint.
#[derive(Debug)]
enum RawLimits {
    Pair([Angle; 2]),
    Cylindrical { theta: [Angle; 2], d: [Angle; 2] },
}

impl<'de> Deserialize<'de> for RawLimits {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct LimitsVisitor;
        impl<'de> Visitor<'de> for LimitsVisitor {
            type Value = RawLimits;

            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("[lower, upper] or {theta: [lower, upper], d: [lower, upper]}")
            }

            fn visit_seq<S: SeqAccess<'de>>(self, mut seq: S) -> Result<RawLimits, S::Error> {
                let lo = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(0, &self))?;
                let hi = seq
                    .next_element()?
                    .ok_or_else(|| de::Error::invalid_length(1, &self))?;
                if seq.next_element::<IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_length(3, &self));
                }
                Ok(RawLimits::Pair([lo, hi]))
            }

            fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<RawLimits, M::Error> {
                let (mut theta, mut d) = (None, None);
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "theta" if theta.is_none() => theta = Some(map.next_value()?),
                        "d" if d.is_none() => d = Some(map.next_value()?),
                        "theta" | "d" => return Err(de::Error::duplicate_field("limits key")),
                        other => return Err(de::Error::unknown_field(other, &["theta", "d"])),
                    }
                }
                Ok(RawLimits::Cylindrical {
                    theta: theta.ok_or_else(|| de::Error::missing_field("theta"))?,
                    d: d.ok_or_else(|| de::Error::missing_field("d"))?,
                })
            }
        }
        deserializer.deserialize_any(LimitsVisitor)
    }
}

/// A YAML document read leniently (any shape, any scalar) with the location of every key and
/// value: enough to find the joint entry and the field a parser error falls in.
enum Node {
    Map(Vec<(Spanned<Node>, Spanned<Node>)>),
    Seq(Vec<Spanned<Node>>),
    /// A scalar's text (numbers and booleans as written by `Display`).
    Scalar(String),
}

impl<'de> Deserialize<'de> for Node {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct NodeVisitor;
        impl<'de> Visitor<'de> for NodeVisitor {
            type Value = Node;

            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("any YAML value")
            }

            fn visit_bool<E: de::Error>(self, v: bool) -> Result<Node, E> {
                Ok(Node::Scalar(v.to_string()))
            }

            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Node, E> {
                Ok(Node::Scalar(v.to_string()))
            }

            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Node, E> {
                Ok(Node::Scalar(v.to_string()))
            }

            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Node, E> {
                Ok(Node::Scalar(v.to_string()))
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<Node, E> {
                Ok(Node::Scalar(v.to_string()))
            }

            fn visit_unit<E: de::Error>(self) -> Result<Node, E> {
                Ok(Node::Scalar(String::new()))
            }

            fn visit_none<E: de::Error>(self) -> Result<Node, E> {
                Ok(Node::Scalar(String::new()))
            }

            fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Node, D::Error> {
                Node::deserialize(d)
            }

            fn visit_seq<S: SeqAccess<'de>>(self, mut seq: S) -> Result<Node, S::Error> {
                let mut items = Vec::new();
                while let Some(item) = seq.next_element()? {
                    items.push(item);
                }
                Ok(Node::Seq(items))
            }

            fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<Node, M::Error> {
                let mut entries = Vec::new();
                while let Some(entry) = map.next_entry()? {
                    entries.push(entry);
                }
                Ok(Node::Map(entries))
            }
        }
        deserializer.deserialize_any(NodeVisitor)
    }
}

const UNIT_TAGS: [&str; 2] = ["!degrees", "!radians"];

/// Reads the fields of one file with the file's angle unit, collecting typed errors.
struct Reader<'s> {
    source: &'s str,
    unit: AngleUnit,
    /// Joint whose entry is being read (for messages).
    joint: Option<String>,
}

impl Reader<'_> {
    fn problem(&self, field: impl Into<String>, problem: FieldProblem) -> LoadErrorKind {
        LoadErrorKind::Field {
            line: None,
            column: None,
            joint: self.joint.clone(),
            field: field.into(),
            problem,
        }
    }

    fn finite(&self, field: &str, value: f64) -> Result<f64, LoadErrorKind> {
        if value.is_finite() {
            Ok(value)
        } else {
            Err(self.problem(field, FieldProblem::NonFinite { value }))
        }
    }

    /// The source text of a scalar value (empty if its span is unknown).
    fn text(&self, at: &Location) -> &str {
        let span = at.span();
        span.byte_offset()
            .zip(span.byte_len())
            .and_then(|(o, l)| self.source.get(o as usize..(o + l) as usize))
            .unwrap_or("")
            .trim()
    }

    fn plain(&self, field: &str, x: &Plain) -> Result<f64, LoadErrorKind> {
        let Tagged(value, tag) = &x.0.value;
        let text = self.text(&x.0.referenced);
        if tag.as_deref().is_some_and(|t| UNIT_TAGS.contains(&t))
            || text.contains("deg(")
            || text.contains("rad(")
        {
            return Err(self.problem(
                field,
                FieldProblem::Shape {
                    expected: "a length or plain number (angle units, a !degrees/!radians tag or a deg(..)/rad(..) conversion, do not belong here)",
                },
            ));
        }
        self.finite(field, *value)
    }

    /// An angle in radians. A `!degrees`/`!radians` tag or a `deg(..)`/`rad(..)` expression
    /// says its unit; a plain number is in the file's `angle_unit`.
    fn angle(&self, field: &str, x: &Angle) -> Result<f64, LoadErrorKind> {
        let Tagged(value, tag) = &x.0.value;
        let value = self.finite(field, *value)?;
        if tag.as_deref().is_some_and(|t| UNIT_TAGS.contains(&t)) {
            return Ok(value);
        }
        let text = self.text(&x.0.referenced);
        let plain = !text.is_empty()
            && text
                .chars()
                .all(|c| c.is_ascii_digit() || matches!(c, '+' | '-' | '.' | 'e' | 'E' | '_'));
        if plain {
            return Ok(match self.unit {
                AngleUnit::Rad => value,
                AngleUnit::Deg => value.to_radians(),
            });
        }
        if text.contains("deg(") || text.contains("rad(") || self.unit == AngleUnit::Rad {
            return Ok(value);
        }
        Err(self.problem(
            field,
            FieldProblem::AmbiguousAngle {
                text: text.to_string(),
            },
        ))
    }

    fn limits(&self, values: &[Angle; 2], angular: bool) -> Result<Limits, LoadErrorKind> {
        let read = |x: &Angle| {
            if angular {
                self.angle("limits", x)
            } else {
                self.plain("limits", &Plain(x.0.clone()))
            }
        };
        let (lower, upper) = (read(&values[0])?, read(&values[1])?);
        if lower > upper {
            return Err(self.problem("limits", FieldProblem::ReversedLimits { lower, upper }));
        }
        Ok(Limits { lower, upper })
    }

    fn frame(&self, field: &str, f: &RawFrame) -> Result<Transform, LoadErrorKind> {
        let sub = |k: &str| format!("{field}.{k}");
        match (&f.matrix, &f.xyz, &f.rpy) {
            (Some(m), None, None) => {
                let mut rows = [[0.0; 4]; 4];
                for (i, row) in m.iter().enumerate() {
                    for (j, x) in row.iter().enumerate() {
                        rows[i][j] = self.plain(&sub("matrix"), x)?;
                    }
                }
                Transform::try_from_rows(&rows)
                    .map_err(|e| self.problem(sub("matrix"), FieldProblem::NotRigid(e)))
            }
            (Some(_), _, _) => Err(self.problem(
                sub("xyz"),
                FieldProblem::NotAllowed {
                    context: "together with matrix (give xyz/rpy or matrix)",
                },
            )),
            (None, xyz, rpy) => {
                let mut p = [0.0; 3];
                if let Some(xyz) = xyz {
                    for (k, x) in xyz.iter().enumerate() {
                        p[k] = self.plain(&sub("xyz"), x)?;
                    }
                }
                let mut a = [0.0; 3];
                if let Some(rpy) = rpy {
                    for (k, x) in rpy.iter().enumerate() {
                        a[k] = self.angle(&sub("rpy"), x)?;
                    }
                }
                Ok(Transform::from_xyz_rpy(p, a))
            }
        }
    }

    /// `spec` with the numbers of DH row `j`: θ and d at q = 0, and `Tx(a) Rx(α)` after the
    /// joint's motion about z (`standard`) or before it (`modified`); a warning in `b` for an
    /// angle in radians larger than 2π.
    fn dh_row(
        &self,
        convention: Convention,
        j: &RawJoint,
        spec: JointSpec,
        b: &mut ChainBuilder,
    ) -> Result<JointSpec, LoadErrorKind> {
        let context = convention.context();
        let missing = |field: &str| self.problem(field, FieldProblem::Missing { context });
        let not_allowed = |field: &str| self.problem(field, FieldProblem::NotAllowed { context });
        if j.origin.is_some() {
            return Err(not_allowed("origin"));
        }
        if j.axis.is_some() {
            return Err(not_allowed("axis"));
        }
        let a = self.plain("a", j.a.as_ref().ok_or_else(|| missing("a"))?)?;
        let alpha = self.angle("alpha", j.alpha.as_ref().ok_or_else(|| missing("alpha"))?)?;
        let d = self.plain("d", j.d.as_ref().ok_or_else(|| missing("d"))?)?;
        let theta = self.angle("theta", j.theta.as_ref().ok_or_else(|| missing("theta"))?)?;
        for (field, value) in [("alpha", alpha), ("theta", theta)] {
            if self.unit == AngleUnit::Rad && value.abs() > TAU {
                b.warn(format!(
                    "joint '{}': {field} = {value} rad is larger than 2π in magnitude; is it in degrees? (set angle_unit: deg)",
                    j.name
                ));
            }
        }
        // Tx(a) Rx(α): the constant part of a DH row, before (modified) or after (standard) the
        // joint's motion about z.
        let screw = Transform {
            p: [a, 0.0, 0.0],
            ..Transform::rot_x(alpha)
        };
        let spec = spec.with_offsets(theta, d);
        Ok(if convention == Convention::Standard {
            spec.with_post(screw)
        } else {
            spec.with_origin(screw)
        })
    }

    /// `spec` with the origin and axis of row `j` of the axis form (eq. 2.119); a fixed joint
    /// needs no axis.
    fn axis_row(
        &self,
        j: &RawJoint,
        kind: JointKind,
        spec: JointSpec,
    ) -> Result<JointSpec, LoadErrorKind> {
        let context = Convention::Axis.context();
        let not_allowed = |field: &str| self.problem(field, FieldProblem::NotAllowed { context });
        for (field, present) in [
            ("a", j.a.is_some()),
            ("alpha", j.alpha.is_some()),
            ("d", j.d.is_some()),
            ("theta", j.theta.is_some()),
        ] {
            if present {
                return Err(not_allowed(field));
            }
        }
        let origin = j
            .origin
            .as_ref()
            .ok_or_else(|| self.problem("origin", FieldProblem::Missing { context }))?;
        if origin.name.is_some() {
            return Err(not_allowed("origin.name"));
        }
        let spec = spec.with_origin(self.frame("origin", origin)?);
        match (&j.axis, kind) {
            (Some(axis), _) => {
                let mut v = [0.0; 3];
                for (k, x) in axis.iter().enumerate() {
                    v[k] = self.plain("axis", x)?;
                }
                if v == [0.0; 3] {
                    return Err(self.problem("axis", FieldProblem::ZeroAxis));
                }
                Ok(spec.with_axis(v))
            }
            (None, JointKind::Fixed | JointKind::Floating | JointKind::Ball) => Ok(spec),
            (None, _) => Err(self.problem("axis", FieldProblem::Missing { context })),
        }
    }

    /// The limits of row `j`, of a joint of `kind`: none for a fixed or continuous joint, a pair
    /// for a revolute or prismatic one, a pair for θ and one for d for a cylindrical one.
    fn joint_limits(
        &self,
        j: &RawJoint,
        kind: JointKind,
    ) -> Result<[Option<Limits>; 2], LoadErrorKind> {
        match (&j.limits, kind) {
            (None, _) => Ok([None, None]),
            (
                Some(_),
                JointKind::Fixed | JointKind::Continuous | JointKind::Floating | JointKind::Ball,
            ) => Err(self.problem(
                    "limits",
                    FieldProblem::NotAllowed {
                        context: "for a fixed, continuous, floating or ball joint",
                    },
                )),
            (Some(RawLimits::Pair(pair)), JointKind::Revolute | JointKind::Prismatic) => {
                Ok([Some(self.limits(pair, kind == JointKind::Revolute)?), None])
            }
            (Some(RawLimits::Cylindrical { theta, d }), JointKind::Cylindrical) => {
                Ok([Some(self.limits(theta, true)?), Some(self.limits(d, false)?)])
            }
            (Some(RawLimits::Pair(_)), _) => Err(self.problem(
                "limits",
                FieldProblem::Shape {
                    expected: "a cylindrical joint needs {theta: [lower, upper], d: [lower, upper]}",
                },
            )),
            (Some(RawLimits::Cylindrical { .. }), _) => Err(self.problem(
                "limits",
                FieldProblem::Shape {
                    expected: "a one-coordinate joint needs [lower, upper]",
                },
            )),
        }
    }
}

/// Parses DH YAML text into a chain description.
pub(crate) fn parse(source: &str, default_name: &str) -> Result<ChainBuilder, LoadErrorKind> {
    let options = with_limits(
        serde_saphyr::options! {
            angle_conversions: true,
            reject_unsupported_tags: true,
        },
        source,
    );
    let raw: RawRobot =
        serde_saphyr::from_str_with_options(source, options).map_err(|e| yaml_error(source, &e))?;
    check_merge_keys(source)?;
    let unit = raw.angle_unit;
    let mut r = Reader {
        source,
        unit,
        joint: None,
    };

    let mut b = ChainBuilder::new(raw.name.clone().unwrap_or_else(|| default_name.to_string()));
    let base_name = raw
        .base
        .as_ref()
        .and_then(|f| f.name.clone())
        .unwrap_or_else(|| "base".to_string());
    b.link(base_name.clone());
    if let Some(base) = &raw.base {
        b.world_from_root(r.frame("base", base)?);
    }

    let mut parent = base_name;
    for (i, j) in raw.joints.iter().enumerate() {
        r.joint = Some(j.name.clone());
        let link = j.link.clone().unwrap_or_else(|| format!("link{}", i + 1));
        let kind = match j.kind {
            RawKind::Revolute => JointKind::Revolute,
            RawKind::Continuous => JointKind::Continuous,
            RawKind::Prismatic => JointKind::Prismatic,
            RawKind::Cylindrical => JointKind::Cylindrical,
            RawKind::Fixed => JointKind::Fixed,
            RawKind::Floating => JointKind::Floating,
            RawKind::Ball => JointKind::Ball,
        };
        let spec = JointSpec::new(j.name.clone(), kind, parent.clone(), link.clone());
        let mut spec = match raw.convention {
            Convention::Standard | Convention::Modified
                if matches!(kind, JointKind::Floating | JointKind::Ball) =>
            {
                return Err(r.problem(
                    "type",
                    FieldProblem::NotAllowed {
                        context: "in a DH table: floating and ball joints are written in the axis convention (convention: axis)",
                    },
                ));
            }
            Convention::Standard | Convention::Modified => {
                r.dh_row(raw.convention, j, spec, &mut b)?
            }
            Convention::Axis => r.axis_row(j, kind, spec)?,
        };
        spec.limits = r.joint_limits(j, kind)?;
        b.link(link.clone());
        b.joint(spec);
        parent = link;
    }
    r.joint = None;
    if let Some(tool) = &raw.tool {
        let name = tool.name.clone().unwrap_or_else(|| "tool".to_string());
        let placement = r.frame("tool", tool)?;
        // (The tool is a link and the fixed joint to it, both under its name.)
        if let Some(owner) = b.name_owner(&name) {
            return Err(r.problem("tool.name", FieldProblem::NameTaken { name, owner }));
        }
        b.link(name.clone());
        b.joint(
            JointSpec::new(name.clone(), JointKind::Fixed, parent, name).with_origin(placement),
        );
    }
    Ok(b)
}

/// `options` with the resource limits both parses of `source` share: at most [`replay_limit`]
/// events replayed by aliases, and the parser's budget less its test of the ratio of aliases to
/// anchors (from a hundred aliases on, more than ten per anchor is refused), which refuses a long
/// chain whose joints repeat one anchored template or limits pair, and does not see the bombs
/// that the replay limit stops (the ratio of a bomb of nested anchors is below ten).
fn with_limits(mut options: serde_saphyr::Options, source: &str) -> serde_saphyr::Options {
    options.budget = serde_saphyr::budget! {
        enforce_alias_anchor_ratio: false,
    };
    options.alias_limits = serde_saphyr::alias_limits! {
        max_total_replayed_events: replay_limit(source),
    };
    options
}

/// Turns a parser error into [`LoadErrorKind::Yaml`], naming the joint entry and the field it
/// falls in.
fn yaml_error(source: &str, e: &serde_saphyr::Error) -> LoadErrorKind {
    let location = e.location();
    // (Files are at most `MAX_FILE_BYTES` long, so lines and columns fit in 32 bits.)
    let (line, column) = (
        location.and_then(|l| u32::try_from(l.line()).ok()),
        location.and_then(|l| u32::try_from(l.column()).ok()),
    );
    let mut message = e.without_snippet().to_string();
    // The parser appends its own " at line L, column C"; the location is reported separately.
    if let Some(i) = message.rfind(" at line ") {
        message.truncate(i);
    }
    // Advice on the parser's functions and options means nothing to the file's author.
    for advice in [", set DuplicateKeyPolicy", "; use from_str_multiple"] {
        if let Some(i) = message.find(advice) {
            message.truncate(i);
        }
    }
    // The parser's counts mean little without the rule they broke.
    if message.starts_with("alias replay limit exceeded") {
        message.push_str(&format!(
            " (aliases may replay {REPLAYS_PER_BYTE} events per byte of the file)"
        ));
    } else if message.starts_with("budget breached") {
        message.push_str(" (a limit of the YAML parser against hostile files)");
    }
    let (joint, field) = line
        .zip(column)
        .map_or((None, None), |at| locate(source, at, &message));
    LoadErrorKind::Yaml {
        line,
        column,
        joint,
        field,
        message,
    }
}

/// How many events aliases may replay in a parse of `source`: [`REPLAYS_PER_BYTE`] per byte of
/// the file. An alias is a few bytes that replay what its anchor holds, so a robot file that
/// repeats a joint template or a limits pair through aliases replays about one event per byte (a
/// 60-joint chain written through one template: 0.6); an alias bomb, nested anchors or merge keys
/// that merge merged templates, replays exponentially more than its size. Both parses, the typed
/// one and the one that places errors, stop there.
fn replay_limit(source: &str) -> usize {
    source.len().saturating_mul(REPLAYS_PER_BYTE)
}

/// Refuses a mapping with two merge keys (`<<: *a` and `<<: *b`), which the parser merges
/// both of, each silently winning or losing on the keys they share: like any other key, a merge
/// key may appear once in a mapping (merge several with `<<: [*a, *b]`). Runs after the typed
/// parse, under its limits, on files that hold `<<` at all.
fn check_merge_keys(source: &str) -> Result<(), LoadErrorKind> {
    if !source.contains("<<") {
        return Ok(());
    }
    let options = with_limits(
        serde_saphyr::options! {
            angle_conversions: true,
            merge_keys: serde_saphyr::MergeKeyPolicy::AsOrdinary,
            duplicate_keys: serde_saphyr::DuplicateKeyPolicy::Error,
        },
        source,
    );
    match serde_saphyr::from_str_with_options::<Node>(source, options) {
        Err(e) if e.to_string().contains("duplicate") && e.to_string().contains("<<") => {
            let mut error = yaml_error(source, &e);
            if let LoadErrorKind::Yaml { field, message, .. } = &mut error {
                // (The entries a merge brings in stand where its alias does, which misleads
                // the search for the field; the key is the merge key itself.)
                *field = None;
                *message = "a second merge key `<<` in one mapping (merge several with \
                            `<<: [*a, *b]`)"
                    .into();
            }
            Err(error)
        }
        _ => Ok(()),
    }
}

/// See [`replay_limit`].
const REPLAYS_PER_BYTE: usize = 4;

/// The joint entry (its name, or `#n` for the n-th entry without one) and the field (`a`,
/// `origin.xyz`, `base.rpy`) that hold the position `at` (line, column) of the parser's
/// `message`, if the file parses leniently.
///
/// The parser places errors in a scalar on the value, and errors in a sequence or mapping (a
/// wrong length, an unknown or duplicate key) on its key. A position on a map's first key is
/// also where the map begins, and a missing key is reported there, so that key is not named;
/// nor is a key the message names itself.
///
/// This parse builds the whole document as a tree, aliases replayed into it, under the typed
/// parse's limits ([`with_limits`]; the parser's own replay limit, a million events, let an alias
/// bomb of a few hundred bytes build a million nodes first).
fn locate(source: &str, at: (u32, u32), message: &str) -> (Option<String>, Option<String>) {
    let Ok(root) = serde_saphyr::from_str_with_options::<Spanned<Node>>(
        source,
        with_limits(
            serde_saphyr::options! {
                angle_conversions: true,
                // Every entry, so that a repeated key is found where it is repeated.
                duplicate_keys: serde_saphyr::DuplicateKeyPolicy::PassThrough,
            },
            source,
        ),
    ) else {
        return (None, None);
    };
    let start = |n: &Spanned<Node>| {
        let at = |x: u64| u32::try_from(x).unwrap_or(u32::MAX);
        (at(n.referenced.line()), at(n.referenced.column()))
    };
    let (mut joint, mut path) = (None, Vec::new());
    let mut node = &root;
    loop {
        match &node.value {
            Node::Map(entries) => {
                // The key starting last at or before `at`. Not the last such entry in order: a
                // merge key (`<<: *template`) appends the template's entries, placed where the
                // alias stands, after the keys written out beside it.
                let Some(i) = entries
                    .iter()
                    .enumerate()
                    .filter(|(_, (k, _))| start(k) <= at)
                    .max_by_key(|(_, (k, _))| start(k))
                    .map(|(i, _)| i)
                else {
                    break;
                };
                let (key, value) = &entries[i];
                let Node::Scalar(name) = &key.value else {
                    break;
                };
                if at < start(value) {
                    let named = message.contains(&format!("`{name}`"))
                        || message.contains(&format!("key: {name}"));
                    if i > 0 && at == start(key) && !named {
                        path.push(name.clone());
                    }
                    break;
                }
                path.push(name.clone());
                node = value;
            }
            Node::Seq(items) => {
                let Some(i) = items.iter().rposition(|item| start(item) <= at) else {
                    break;
                };
                if joint.is_none() && path == ["joints"] {
                    let name = match &items[i].value {
                        Node::Map(entries) => {
                            entries
                                .iter()
                                .find_map(|(k, v)| match (&k.value, &v.value) {
                                    (Node::Scalar(k), Node::Scalar(name)) if k == "name" => {
                                        Some(name.clone())
                                    }
                                    _ => None,
                                })
                        }
                        _ => None,
                    };
                    joint = Some(name.unwrap_or_else(|| format!("#{}", i + 1)));
                    path.clear();
                }
                node = &items[i];
            }
            Node::Scalar(_) => break,
        }
    }
    (joint, (!path.is_empty()).then(|| path.join(".")))
}
