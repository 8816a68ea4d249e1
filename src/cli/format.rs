//! How `fk` prints its results: JSON objects and aligned tables, orientation coordinates.

use crate::cli::args::{FkArgs, Orientation, Point};
use crate::cli::common::output_error;
use crate::cli::error::CliError;
use crate::eval::Chain;
use crate::eval::{AccelerationParts, LinkAcceleration, LinkVelocity};
use crate::model::chain::LinkId;
use crate::model::transform::Transform;
use nalgebra::Vector3;
use serde::{Serialize, Serializer, ser::SerializeMap};
use std::io::Write;

/// One configuration to evaluate.
pub(super) struct Configuration {
    pub(super) q: Vec<f64>,
    pub(super) qd: Option<Vec<f64>>,
    pub(super) qdd: Option<Vec<f64>>,
}

/// Per link: pose, and velocity/acceleration when asked for.
pub(super) type LinkResult = (
    LinkId,
    Transform,
    Option<LinkVelocity>,
    Option<LinkAcceleration>,
);

/// Per point: position, velocity, acceleration and its parts, as far as asked for.
pub(super) struct PointResult {
    pub(super) position: Vector3<f64>,
    pub(super) velocity: Option<Vector3<f64>>,
    pub(super) acceleration: Option<(Vector3<f64>, AccelerationParts)>,
}

/// One `--jacobian` link's matrices, in buffers reused from one configuration to the next.
pub(super) struct JacobianResult {
    pub(super) link: LinkId,
    pub(super) j: nalgebra::Matrix6xX<f64>,
    /// `J̇`, current when `with_rate` (the configuration has `qd`).
    pub(super) j_dot: nalgebra::Matrix6xX<f64>,
    pub(super) with_rate: bool,
}

/// The coordinates of `a` that `--orientation` names, in the order the README gives (the matrix
/// row by row, quaternion `w x y z`, `roll pitch yaw`, `phi theta psi`, the axis then the angle,
/// `γ1 γ2 γ3`); `None` where the representation is undefined (a singularity).
pub(super) fn orientation_values(
    a: &nalgebra::Matrix3<f64>,
    kind: Orientation,
) -> Option<Coordinates> {
    use crate::orientation::{AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy};
    match kind {
        Orientation::Matrix => Some(Coordinates::new([
            a.m11, a.m12, a.m13, a.m21, a.m22, a.m23, a.m31, a.m32, a.m33,
        ])),
        Orientation::Quat => {
            let e = EulerParameters::from_matrix(a);
            Some(Coordinates::new([e.e0, e.e1, e.e2, e.e3]))
        }
        Orientation::Rpy => Rpy::from_matrix(a)
            .ok()
            .map(|r| Coordinates::new([r.roll, r.pitch, r.yaw])),
        Orientation::Zxz => EulerZxz::from_matrix(a)
            .ok()
            .map(|e| Coordinates::new([e.phi, e.theta, e.psi])),
        Orientation::AxisAngle => AxisAngle::from_matrix(a)
            .ok()
            .map(|x| Coordinates::new([x.axis.x, x.axis.y, x.axis.z, x.angle])),
        Orientation::Rodrigues => RodriguezParameters::from_matrix(a)
            .ok()
            .map(|g| Coordinates::new([g.0.x, g.0.y, g.0.z])),
    }
}

/// The orientation coordinates of one link (at most a matrix's nine), held without an
/// allocation: the output of a batch makes one per link and line.
pub(super) struct Coordinates {
    pub(super) values: [f64; 9],
    pub(super) len: usize,
}

impl Coordinates {
    fn new<const N: usize>(values: [f64; N]) -> Self {
        const { assert!(N <= 9) };
        let mut all = [0.0; 9];
        for (slot, x) in all.iter_mut().zip(values) {
            *slot = x;
        }
        Coordinates {
            values: all,
            len: N,
        }
    }

    fn as_slice(&self) -> &[f64] {
        &self.values[..self.len]
    }
}

/// What a row of results is headed by: its line of a `--batch` file, or its message's time (ns)
/// in a `--bag`.
#[derive(Clone, Copy, Debug)]
pub(super) enum RowLabel {
    Line(usize),
    Time(i64),
}

impl std::fmt::Display for RowLabel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RowLabel::Line(n) => write!(f, "{n}"),
            RowLabel::Time(t) => write!(f, "{t}"),
        }
    }
}

/// `{"links": {"NAME": {..}, ..}, ..}` for one configuration's `results`, then `"points"`,
/// `"jacobians"` and `"jacobian_dots"` where there are any: serialised straight into the
/// output, since a `Value` tree allocates a node per number (which took most of a batch run's
/// time).
pub(super) struct ResultsJson<'a> {
    /// The batch line or bag message the results are for (none for `--q`).
    pub(super) line: Option<RowLabel>,
    pub(super) chain: &'a Chain,
    pub(super) results: &'a [LinkResult],
    pub(super) orientation: Orientation,
    pub(super) points: &'a [Point],
    pub(super) point_results: &'a [PointResult],
    pub(super) jacobians: &'a [JacobianResult],
}

impl Serialize for ResultsJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        /// The links, keyed by name.
        struct Links<'b>(&'b ResultsJson<'b>);
        impl Serialize for Links<'_> {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                let r = self.0;
                let mut m = s.serialize_map(Some(r.results.len()))?;
                for result in r.results {
                    let link = LinkJson {
                        result,
                        orientation: r.orientation,
                    };
                    m.serialize_entry(r.chain.link(result.0).name(), &link)?;
                }
                m.end()
            }
        }
        let mut m = s.serialize_map(None)?;
        match self.line {
            Some(RowLabel::Line(line)) => m.serialize_entry("line", &line)?,
            Some(RowLabel::Time(time)) => m.serialize_entry("time", &time)?,
            None => {}
        }
        m.serialize_entry("links", &Links(self))?;
        if !self.points.is_empty() {
            let points = self.points.iter().zip(self.point_results);
            let list = points.map(|(p, r)| PointJson {
                link: self.chain.link(p.link).name(),
                u: xyz(&p.u),
                position: xyz(&r.position),
                velocity: r.velocity.as_ref().map(xyz),
                acceleration: r.acceleration.as_ref().map(|(a, _)| xyz(a)),
                acceleration_parts: r.acceleration.as_ref().map(|(_, parts)| PartsJson {
                    origin: xyz(&parts.origin),
                    tangential: xyz(&parts.tangential),
                    normal: xyz(&parts.normal),
                }),
            });
            m.serialize_entry("points", &Listed(list))?;
        }
        if !self.jacobians.is_empty() {
            let jacobians = |rate| JacobiansJson {
                chain: self.chain,
                jacobians: self.jacobians,
                rate,
            };
            m.serialize_entry("jacobians", &jacobians(false))?;
            if self.jacobians.iter().any(|r| r.with_rate) {
                m.serialize_entry("jacobian_dots", &jacobians(true))?;
            }
        }
        m.end()
    }
}

/// One `--point`: `{"link", "u", "position"}`, then with rates `"velocity"`, and with
/// accelerations `"acceleration"` and `"acceleration_parts"`.
#[derive(Serialize)]
pub(super) struct PointJson<'a> {
    pub(super) link: &'a str,
    pub(super) u: [f64; 3],
    pub(super) position: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) velocity: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) acceleration: Option<[f64; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) acceleration_parts: Option<PartsJson>,
}

/// The parts of a point's acceleration (eq. 2.75) that do not vanish for a point fixed on its
/// link.
#[derive(Serialize)]
pub(super) struct PartsJson {
    pub(super) origin: [f64; 3],
    pub(super) tangential: [f64; 3],
    pub(super) normal: [f64; 3],
}

/// `{"LINK": [[row], … six rows], …}` per `--jacobian` link, rows `v_x, v_y, v_z, ω_x, ω_y,
/// ω_z`, columns in `q` order: `J`, or `J̇` when `rate`.
pub(super) struct JacobiansJson<'a> {
    pub(super) chain: &'a Chain,
    pub(super) jacobians: &'a [JacobianResult],
    pub(super) rate: bool,
}

impl Serialize for JacobiansJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.jacobians.len()))?;
        for r in self.jacobians {
            let matrix = if self.rate { &r.j_dot } else { &r.j };
            // Column-major storage: row `i` is every sixth entry from the `i`-th.
            let entries = matrix.as_slice();
            let rows = (0..6).map(|i| Listed(entries.iter().skip(i).step_by(6)));
            m.serialize_entry(self.chain.link(r.link).name(), &Listed(rows))?;
        }
        m.end()
    }
}

/// The items of an iterator, serialised as a JSON array without collecting them.
pub(super) struct Listed<I>(I);

impl<I> Serialize for Listed<I>
where
    I: Iterator + Clone,
    I::Item: Serialize,
{
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(self.0.clone())
    }
}

/// One link's members: `"pose"`, or `"position"` and the orientation coordinates (`null` where
/// the representation is undefined, at a singularity); then the rates there are.
pub(super) struct LinkJson<'a> {
    pub(super) result: &'a LinkResult,
    pub(super) orientation: Orientation,
}

impl Serialize for LinkJson<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let (_, pose, vel, acc) = self.result;
        let mut m = s.serialize_map(None)?;
        let kind = self.orientation;
        if kind == Orientation::Matrix {
            m.serialize_entry("pose", &pose.to_rows())?;
        } else {
            m.serialize_entry("position", &xyz(&pose.translation()))?;
            let key = orientation_labels(kind).0;
            let values = orientation_values(&pose.rotation(), kind);
            match (kind, values.as_ref().map(Coordinates::as_slice)) {
                (_, None) => m.serialize_entry(key, &())?,
                (Orientation::Quat, Some(&[w, x, y, z])) => {
                    m.serialize_entry(key, &Named([("w", w), ("x", x), ("y", y), ("z", z)]))?;
                }
                (Orientation::Rpy, Some(&[roll, pitch, yaw])) => {
                    let angles = [("roll", roll), ("pitch", pitch), ("yaw", yaw)];
                    m.serialize_entry(key, &Named(angles))?;
                }
                (Orientation::Zxz, Some(&[phi, theta, psi])) => {
                    let angles = [("phi", phi), ("theta", theta), ("psi", psi)];
                    m.serialize_entry(key, &Named(angles))?;
                }
                (Orientation::AxisAngle, Some(&[x, y, z, angle])) => {
                    m.serialize_entry(
                        key,
                        &AxisAngleJson {
                            axis: [x, y, z],
                            angle,
                        },
                    )?;
                }
                // Rodriguez parameters, an array.
                (_, Some(v)) => m.serialize_entry(key, v)?,
            }
        }
        if let Some(v) = vel {
            m.serialize_entry("omega", &xyz(&v.omega))?;
            m.serialize_entry("v", &xyz(&v.v))?;
        }
        if let Some(a) = acc {
            m.serialize_entry("alpha", &xyz(&a.alpha))?;
            m.serialize_entry("a", &xyz(&a.a))?;
        }
        m.end()
    }
}

/// `{"axis": [x, y, z], "angle": θ}`.
#[derive(Serialize)]
pub(super) struct AxisAngleJson {
    pub(super) axis: [f64; 3],
    pub(super) angle: f64,
}

/// An object of numbers with the given member names, in their order.
pub(super) struct Named<const N: usize>([(&'static str, f64); N]);

impl<const N: usize> Serialize for Named<N> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(N))?;
        for (key, value) in &self.0 {
            m.serialize_entry(key, value)?;
        }
        m.end()
    }
}

/// The entries of `v`, for serialising as `[x, y, z]`.
pub(super) fn xyz(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// The name of an `--orientation`'s coordinates (the JSON member; for the matrix, the table's
/// column) and what they are, in order (the table's column header).
pub(super) fn orientation_labels(kind: Orientation) -> (&'static str, &'static str) {
    match kind {
        Orientation::Matrix => ("rotation", "rows"),
        Orientation::Quat => ("quaternion", "w x y z"),
        Orientation::Rpy => ("rpy", "roll pitch yaw"),
        Orientation::Zxz => ("euler_zxz", "phi theta psi"),
        Orientation::AxisAngle => ("axis_angle", "x y z; angle"),
        Orientation::Rodrigues => ("rodrigues", "γ1 γ2 γ3"),
    }
}

/// Writes `value` as one line of JSON, serialised into `buf` (reused from line to line) and
/// written with one call.
pub(super) fn write_json_line(
    out: &mut dyn Write,
    buf: &mut Vec<u8>,
    value: &impl Serialize,
) -> Result<(), CliError> {
    // (Serialising into memory fails only for a map key that is not a string, which the
    // values written here do not have.)
    write_buffered_line(out, buf, |buf| {
        serde_json::to_writer(buf, value).map_err(|e| output_error(e.into()))
    })
}

/// Writes the text `fill` appends to `buf` (emptied first, and reused from line to line) and a
/// newline, with one call.
pub(super) fn write_buffered_line(
    out: &mut dyn Write,
    buf: &mut Vec<u8>,
    fill: impl FnOnce(&mut Vec<u8>) -> Result<(), CliError>,
) -> Result<(), CliError> {
    buf.clear();
    fill(buf)?;
    buf.push(b'\n');
    out.write_all(buf).map_err(output_error)
}

/// The error for the first result that is not finite (a value too large for `f64`, which JSON
/// cannot print): every pose, rate and point result of one configuration.
pub(super) fn check_finite(
    chain: &Chain,
    results: &[LinkResult],
    points: &[Point],
    point_results: &[PointResult],
) -> Result<(), CliError> {
    let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
    for (l, pose, vel, acc) in results {
        let parts = [
            (
                "pose",
                pose.to_rows().iter().flatten().all(|x| x.is_finite()),
            ),
            ("omega", vel.is_none_or(|v| finite(&v.omega))),
            ("v", vel.is_none_or(|v| finite(&v.v))),
            ("alpha", acc.is_none_or(|a| finite(&a.alpha))),
            ("a", acc.is_none_or(|a| finite(&a.a))),
        ];
        if let Some(&(what, _)) = parts.iter().find(|(_, ok)| !ok) {
            return Err(CliError::NotFinite {
                what,
                place: format!("link '{}'", chain.link(*l).name()),
            });
        }
    }
    for (p, r) in points.iter().zip(point_results) {
        let acceleration = r.acceleration.as_ref();
        let parts = [
            ("position", finite(&r.position)),
            ("velocity", r.velocity.as_ref().is_none_or(finite)),
            (
                "acceleration",
                acceleration.is_none_or(|(a, parts)| {
                    finite(a)
                        && [
                            parts.origin,
                            parts.tangential,
                            parts.normal,
                            parts.coriolis,
                            parts.local,
                        ]
                        .iter()
                        .all(finite)
                }),
            ),
        ];
        if let Some(&(what, _)) = parts.iter().find(|(_, ok)| !ok) {
            return Err(CliError::NotFinite {
                what,
                place: p.label(chain).to_string(),
            });
        }
    }
    Ok(())
}

/// Appends `x` as a number for a table, right-aligned in `width` columns (0: as wide as it is):
/// six decimals, or six significant digits after the first in exponent form from 10⁹ on (where
/// six decimals would print hundreds of digits for a large value). A value that shows as zero
/// has no sign: the `-` of `-0.000000` would come from a rounding residue such as −6·10⁻¹⁷ or
/// from −0, not from the robot.
pub(super) fn push_fixed(buf: &mut Vec<u8>, x: f64, width: usize) {
    let start = buf.len();
    if x.abs() >= 1e9 {
        let _ = write!(buf, "{x:>width$.6e}");
        return;
    }
    let _ = write!(buf, "{x:>width$.6}");
    let cell = &buf[start..];
    let Some(sign) = cell.iter().position(|&b| b != b' ') else {
        return;
    };
    let zero = |rest: &[u8]| rest.iter().all(|&b| b == b'0' || b == b'.');
    if cell[sign] == b'-' && zero(&cell[sign + 1..]) {
        if sign > 0 {
            // The sign's column becomes padding.
            buf[start + sign] = b' ';
        } else {
            buf.remove(start);
            if buf.len() - start < width {
                buf.insert(start, b' ');
            }
        }
    }
}

/// Appends the numbers of `cells` ([`push_fixed`], each `width` wide) with `separator` between
/// them.
pub(super) fn push_cells(
    buf: &mut Vec<u8>,
    cells: impl IntoIterator<Item = f64>,
    separator: &[u8],
    width: usize,
) {
    for (i, x) in cells.into_iter().enumerate() {
        if i > 0 {
            buf.extend_from_slice(separator);
        }
        push_fixed(buf, x, width);
    }
}

/// `fk --format table`: appends one row per link, its position and its orientation in the
/// coordinates `--orientation` names (`undefined` at a singularity of the representation), then
/// its rates; no newline after the last row.
pub(super) fn results_table(
    chain: &Chain,
    results: &[LinkResult],
    orientation: Orientation,
    buf: &mut Vec<u8>,
) {
    let width = results
        .iter()
        .map(|(l, ..)| chain.link(*l).name().chars().count())
        .max()
        .unwrap_or(4)
        .max(4);
    let (name, coordinates) = orientation_labels(orientation);
    let _ = write!(
        buf,
        "{:<width$} {:>12} {:>12} {:>12}   {name} ({coordinates})",
        "link", "x", "y", "z"
    );
    // A matrix's rows, and the axis before its angle, are separated by `;`.
    let group = match orientation {
        Orientation::Matrix | Orientation::AxisAngle => 3,
        _ => 4,
    };
    let row = |buf: &mut Vec<u8>, label: &str, v: &Vector3<f64>| {
        let _ = write!(buf, "\n{label:>width$} ");
        push_cells(buf, [v.x, v.y, v.z], b" ", 12);
    };
    for (l, pose, vel, acc) in results {
        let p = pose.translation();
        let _ = write!(buf, "\n{:<width$} ", chain.link(*l).name());
        push_cells(buf, [p.x, p.y, p.z], b" ", 12);
        buf.extend_from_slice(b"   ");
        match orientation_values(&pose.rotation(), orientation) {
            None => buf.extend_from_slice(b"undefined"),
            Some(values) => {
                buf.push(b'[');
                for (i, chunk) in values.as_slice().chunks(group).enumerate() {
                    if i > 0 {
                        buf.extend_from_slice(b"; ");
                    }
                    push_cells(buf, chunk.iter().copied(), b" ", 0);
                }
                buf.push(b']');
            }
        }
        if let Some(v) = vel {
            row(buf, "omega", &v.omega);
            row(buf, "v", &v.v);
        }
        if let Some(a) = acc {
            row(buf, "alpha", &a.alpha);
            row(buf, "a", &a.a);
        }
    }
}

/// The column names of one link's orientation in CSV output (`<link>.<name>`), in the order of
/// [`orientation_values`].
pub(super) fn orientation_columns(kind: Orientation) -> &'static [&'static str] {
    match kind {
        Orientation::Matrix => &[
            "r00", "r01", "r02", "r10", "r11", "r12", "r20", "r21", "r22",
        ],
        Orientation::Quat => &["qw", "qx", "qy", "qz"],
        Orientation::Rpy => &["roll", "pitch", "yaw"],
        Orientation::Zxz => &["phi", "theta", "psi"],
        Orientation::AxisAngle => &["axis_x", "axis_y", "axis_z", "angle"],
        Orientation::Rodrigues => &["g1", "g2", "g3"],
    }
}

/// The links `fk` prints: those of `--link` (each once, in the order named) or every link.
pub(super) fn csv_links(chain: &Chain, args: &FkArgs) -> Vec<String> {
    if args.links.is_empty() {
        return chain.links().iter().map(|l| l.name().to_string()).collect();
    }
    let mut names: Vec<String> = Vec::new();
    for n in &args.links {
        if !names.contains(n) {
            names.push(n.clone());
        }
    }
    names
}

/// A CSV field: as it is, or quoted (quotes doubled) when it holds a comma, quote or line break.
pub(super) fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// The CSV header: `line` (with `--batch`) or `time` (with `--bag`), then `<link>.x`, `<link>.y`, `<link>.z` and the
/// orientation columns of every link printed, then `error` (with `--batch` or `--bag`: the
/// message of a line or message that failed under `--keep-going`). The names of `kinechain.table.poses` in Python.
pub(super) fn csv_header(chain: &Chain, args: &FkArgs) -> String {
    let mut fields: Vec<String> = Vec::new();
    if args.batch.is_some() {
        fields.push("line".into());
    } else if args.bag.is_some() {
        fields.push("time".into());
    }
    for link in csv_links(chain, args) {
        for c in ["x", "y", "z"]
            .iter()
            .chain(orientation_columns(args.orientation))
        {
            fields.push(csv_field(&format!("{link}.{c}")));
        }
    }
    if args.batch.is_some() || args.bag.is_some() {
        fields.push("error".into());
    }
    fields.join(",")
}

/// One configuration's CSV row: numbers that read back to the same `f64`, an empty field where
/// an orientation is undefined.
pub(super) fn csv_row(
    line: Option<RowLabel>,
    results: &[LinkResult],
    kind: Orientation,
    buf: &mut Vec<u8>,
) {
    use std::fmt::Write as _;
    let mut row = line.map(|l| l.to_string()).unwrap_or_default();
    let mut first = line.is_none();
    let mut push = |row: &mut String, value: Option<f64>| {
        if !first {
            row.push(',');
        }
        first = false;
        if let Some(x) = value {
            // `{:?}` of an f64 is the shortest text that reads back to it.
            let _ = write!(row, "{x:?}");
        }
    };
    for (_, pose, _, _) in results {
        let p = pose.translation();
        for x in [p.x, p.y, p.z] {
            push(&mut row, Some(x));
        }
        let width = orientation_columns(kind).len();
        match orientation_values(&pose.rotation(), kind) {
            Some(c) => c.as_slice().iter().for_each(|&x| push(&mut row, Some(x))),
            None => (0..width).for_each(|_| push(&mut row, None)),
        }
    }
    // The empty `error` field of a batch line or bag message.
    if line.is_some() {
        row.push(',');
    }
    buf.extend_from_slice(row.as_bytes());
}
