//! MJCF attribute values: numbers, the `<compiler>` settings that change their meaning, default
//! classes, and placements (`pos` with one of `quat`, `axisangle`, `euler`, `xyaxes`, `zaxis`).

use super::tree::{At, Element, Problem};
use crate::model::transform::Transform;
use nalgebra::{Matrix3, Quaternion, Rotation3, Unit, UnitQuaternion, Vector3};
use std::collections::HashMap;

/// The `<compiler>` settings that change what kinematic attributes mean.
#[derive(Clone, Debug)]
pub(crate) struct Compiler {
    /// `angle="degree"` (MuJoCo's default): euler and axis-angle angles, and hinge ranges and
    /// references, are in degrees.
    pub(crate) degrees: bool,
    /// `eulerseq`: three of `xyzXYZ`; lower case rotates about the moving axes (intrinsic),
    /// upper case about the fixed ones (extrinsic).
    pub(crate) eulerseq: [u8; 3],
    /// `autolimits` (default true): a joint with a `range` and `limited="auto"` is limited.
    pub(crate) autolimits: bool,
    /// `alignfree` (default false): a free body without children is moved onto its inertial
    /// frame (unless its free joint's `align` says otherwise).
    pub(crate) alignfree: bool,
    /// `inertiafromgeom`: `Some(true)` always from the geoms, `Some(false)` never, `None`
    /// ("auto", the default) when the body has no `<inertial>`.
    pub(crate) inertiafromgeom: Option<bool>,
    /// `inertiagrouprange` (default 0 5): the geom groups that count for a body's inertia.
    pub(crate) inertiagrouprange: [i64; 2],
    /// Where `fusestatic="true"` is set, if it is: MuJoCo then fuses bodies without joints into
    /// their parents, which moves no frame but renumbers bodies and sites.
    pub(crate) fusestatic: Option<At>,
}

impl Default for Compiler {
    fn default() -> Self {
        Compiler {
            degrees: true,
            eulerseq: *b"xyz",
            autolimits: true,
            alignfree: false,
            inertiafromgeom: None,
            inertiagrouprange: [0, 5],
            fusestatic: None,
        }
    }
}

impl Compiler {
    /// Reads one `<compiler>` element over the settings so far.
    pub(crate) fn read(&mut self, el: &Element) -> Result<(), Problem> {
        if let Some((v, at)) = el.attribute("angle") {
            self.degrees = match v {
                "degree" => true,
                "radian" => false,
                _ => {
                    return Err(Problem::at(
                        at,
                        format!("compiler angle is '{v}'; MJCF allows 'degree' or 'radian'"),
                    ));
                }
            };
        }
        if let Some((v, at)) = el.attribute("eulerseq") {
            let b = v.as_bytes();
            if b.len() != 3 || !b.iter().all(|c| b"xyzXYZ".contains(c)) {
                return Err(Problem::at(
                    at,
                    format!("eulerseq is '{v}'; MJCF wants three of x, y, z, X, Y, Z"),
                ));
            }
            self.eulerseq = [b[0], b[1], b[2]];
        }
        if let Some((v, at)) = el.attribute("autolimits") {
            self.autolimits = boolean(v, at, "autolimits")?;
        }
        if let Some((v, at)) = el.attribute("alignfree") {
            self.alignfree = boolean(v, at, "alignfree")?;
        }
        if let Some((v, at)) = el.attribute("inertiafromgeom") {
            self.inertiafromgeom = match v {
                "auto" => None,
                v => Some(boolean(v, at, "inertiafromgeom")?),
            };
        }
        if let Some((v, at)) = el.attribute("inertiagrouprange") {
            let [lo, hi] = reals::<2>(v, at, "inertiagrouprange")?;
            self.inertiagrouprange = [lo as i64, hi as i64];
        }
        if let Some((v, at)) = el.attribute("fusestatic") {
            self.fusestatic = boolean(v, at, "fusestatic")?.then_some(at);
        }
        // MuJoCo refuses global coordinates; "local" is the only meaning kinechain reads.
        if let Some((v, at)) = el.attribute("coordinate")
            && v != "local"
        {
            return Err(Problem::at(
                at,
                format!(
                    "compiler coordinate is '{v}'; MuJoCo reads only 'local' (global coordinates are no longer supported)"
                ),
            ));
        }
        Ok(())
    }

    /// `value` in radians: converted from degrees when the compiler says angles are in degrees.
    pub(crate) fn angle(&self, value: f64) -> f64 {
        if self.degrees {
            value * (std::f64::consts::PI / 180.0)
        } else {
            value
        }
    }
}

/// `true` or `false`.
pub(crate) fn boolean(value: &str, at: At, what: &str) -> Result<bool, Problem> {
    match value {
        "true" => Ok(true),
        "false" => Ok(false),
        _ => Err(Problem::at(
            at,
            format!("{what} is '{value}'; MJCF allows 'true' or 'false'"),
        )),
    }
}

/// Exactly `N` finite numbers separated by white space.
pub(crate) fn reals<const N: usize>(value: &str, at: At, what: &str) -> Result<[f64; N], Problem> {
    let values = real_list(value, at, what)?;
    values.try_into().map_err(|v: Vec<f64>| {
        Problem::at(at, format!("{what} has {} numbers; it takes {N}", v.len()))
    })
}

/// Finite numbers separated by white space.
pub(crate) fn real_list(value: &str, at: At, what: &str) -> Result<Vec<f64>, Problem> {
    value
        .split_whitespace()
        .map(|t| match t.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(Problem::at(
                at,
                format!("{what}: '{t}' is not a finite number"),
            )),
            Err(_) => Err(Problem::at(at, format!("{what}: '{t}' is not a number"))),
        })
        .collect()
}

/// The attributes default classes give to the elements that take part in the kinematics.
#[derive(Clone, Debug, Default)]
pub(crate) struct Class {
    joint: Vec<(String, String, At)>,
    site: Vec<(String, String, At)>,
    geom: Vec<(String, String, At)>,
}

/// Every default class by name (`main` is the top one).
#[derive(Debug)]
pub(crate) struct Defaults {
    classes: HashMap<String, Class>,
}

/// Which element's defaults.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Kind {
    Joint,
    Site,
    /// For the inertial frame of a body that `alignfree` moves.
    Geom,
}

impl Defaults {
    /// The classes of the `<default>` elements under `<mujoco>`, nested ones inheriting from
    /// their parents.
    pub(crate) fn read(root: &Element) -> Result<Self, Problem> {
        let mut classes = HashMap::new();
        classes.insert("main".to_string(), Class::default());
        for top in root.children_named("default") {
            let name = top.attribute("class").map_or("main", |(v, _)| v);
            let inherited = classes.get(name).cloned().unwrap_or_default();
            collect(top, name, inherited, &mut classes)?;
        }
        Ok(Defaults { classes })
    }

    /// Whether class `name` exists.
    pub(crate) fn check(&self, name: &str, at: At) -> Result<(), Problem> {
        if self.classes.contains_key(name) {
            Ok(())
        } else {
            Err(Problem::at(
                at,
                format!("default class '{name}' is not defined"),
            ))
        }
    }

    /// The class element `el` of kind `kind` takes its defaults from: its own `class`, else
    /// `active` (the nearest enclosing `childclass`, or `main`).
    pub(crate) fn class_of<'a>(
        &'a self,
        el: &'a Element,
        active: &'a str,
    ) -> Result<&'a str, Problem> {
        let name = match el.attribute("class") {
            Some((v, at)) => {
                self.check(v, at)?;
                v
            }
            None => active,
        };
        Ok(name)
    }

    /// Attribute `name` of `el`, else of its class's defaults for `kind`.
    pub(crate) fn value<'a>(
        &'a self,
        el: &'a Element,
        kind: Kind,
        class: &str,
        name: &str,
    ) -> Option<(&'a str, At)> {
        el.attribute(name).or_else(|| {
            let class = self.classes.get(class)?;
            let list = match kind {
                Kind::Joint => &class.joint,
                Kind::Site => &class.site,
                Kind::Geom => &class.geom,
            };
            list.iter()
                .find(|(n, _, _)| n == name)
                .map(|(_, v, at)| (v.as_str(), *at))
        })
    }
}

fn collect(
    el: &Element,
    name: &str,
    mut class: Class,
    classes: &mut HashMap<String, Class>,
) -> Result<(), Problem> {
    for child in &el.children {
        let list = match child.name.as_str() {
            "joint" => &mut class.joint,
            "site" => &mut class.site,
            "geom" => &mut class.geom,
            _ => continue,
        };
        for (n, v, at) in &child.attributes {
            list.retain(|(m, _, _)| m != n);
            list.push((n.clone(), v.clone(), *at));
        }
    }
    classes.insert(name.to_string(), class.clone());
    for nested in el.children_named("default") {
        let Some((sub, _)) = nested.attribute("class") else {
            return Err(Problem::at(
                nested.at,
                "a nested <default> has no class attribute",
            ));
        };
        collect(nested, sub, class.clone(), classes)?;
    }
    Ok(())
}

/// The orientation attributes MJCF allows, one at a time.
const ORIENTATIONS: [&str; 5] = ["quat", "axisangle", "euler", "xyaxes", "zaxis"];

/// The placement an element's `pos` and orientation give, its attributes looked up by `get`
/// (the element's own, then its defaults'). An orientation the element itself gives replaces
/// any its defaults give.
pub(crate) fn placement<'a>(
    el: &'a Element,
    get: impl Fn(&str) -> Option<(&'a str, At)>,
    compiler: &Compiler,
) -> Result<(Vector3<f64>, UnitQuaternion<f64>), Problem> {
    let pos = match get("pos") {
        Some((v, at)) => Vector3::from(reals::<3>(v, at, "pos")?),
        None => Vector3::zeros(),
    };
    let own: Vec<_> = ORIENTATIONS
        .iter()
        .filter_map(|n| el.attribute(n).map(|v| (*n, v)))
        .collect();
    let given = if own.is_empty() {
        ORIENTATIONS
            .iter()
            .filter_map(|n| get(n).map(|v| (*n, v)))
            .collect()
    } else {
        own
    };
    let rotation = match given.as_slice() {
        [] => UnitQuaternion::identity(),
        [(name, (v, at))] => orientation(name, v, *at, compiler)?,
        [(a, (_, at)), (b, _), ..] => {
            return Err(Problem::at(
                *at,
                format!(
                    "<{}> gives both {a} and {b}; MJCF takes one orientation",
                    el.name
                ),
            ));
        }
    };
    Ok((pos, rotation))
}

/// The rotation one orientation attribute gives.
fn orientation(
    name: &str,
    value: &str,
    at: At,
    compiler: &Compiler,
) -> Result<UnitQuaternion<f64>, Problem> {
    let small = |what: &str| Problem::at(at, format!("{name}: {what} is zero or too small"));
    match name {
        "quat" => {
            let [w, x, y, z] = reals::<4>(value, at, name)?;
            let scale = [w, x, y, z].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if scale < 1e-300 {
                return Err(small("the quaternion"));
            }
            let q = Quaternion::new(w / scale, x / scale, y / scale, z / scale);
            Ok(UnitQuaternion::from_quaternion(q))
        }
        "axisangle" => {
            let [x, y, z, a] = reals::<4>(value, at, name)?;
            let axis = unit(Vector3::new(x, y, z)).ok_or_else(|| small("the axis"))?;
            let axis = Unit::new_unchecked(axis);
            Ok(UnitQuaternion::from_axis_angle(&axis, compiler.angle(a)))
        }
        "euler" => {
            let angles = reals::<3>(value, at, name)?;
            let mut q = UnitQuaternion::identity();
            for (&axis, angle) in compiler.eulerseq.iter().zip(angles) {
                let unit = match axis.to_ascii_lowercase() {
                    b'x' => Vector3::x_axis(),
                    b'y' => Vector3::y_axis(),
                    _ => Vector3::z_axis(),
                };
                let turn = UnitQuaternion::from_axis_angle(&unit, compiler.angle(angle));
                // Lower case: about the moving axes (post-multiplied); upper case: about the
                // fixed ones (pre-multiplied).
                q = if axis.is_ascii_lowercase() {
                    q * turn
                } else {
                    turn * q
                };
            }
            Ok(q)
        }
        "xyaxes" => {
            let v = reals::<6>(value, at, name)?;
            let x = Vector3::new(v[0], v[1], v[2]);
            let x = unit(x).ok_or_else(|| small("the x axis"))?;
            let y = Vector3::new(v[3], v[4], v[5]);
            let y = unit(y).ok_or_else(|| small("the y axis"))?;
            let y = unit(y - x * x.dot(&y))
                .ok_or_else(|| small("the y axis (once made orthogonal to x)"))?;
            let z = x.cross(&y);
            let m = Matrix3::from_columns(&[x, y, z]);
            Ok(UnitQuaternion::from_rotation_matrix(
                &Rotation3::from_matrix_unchecked(m),
            ))
        }
        _ => {
            let z = Vector3::from(reals::<3>(value, at, name)?);
            let z = unit(z).ok_or_else(|| small("the axis"))?;
            Ok(z_to(&z))
        }
    }
}

/// `v` scaled to unit length (through its largest component first, so that no square
/// overflows or underflows); `None` when it is (nearly) zero.
pub(crate) fn unit(v: Vector3<f64>) -> Option<Vector3<f64>> {
    let scale = v.amax();
    if scale < 1e-300 {
        return None;
    }
    let v = v / scale;
    let norm = v.norm();
    (norm > 1e-10).then(|| v / norm)
}

/// The smallest rotation that turns the z axis to `z` (unit), as MuJoCo computes it: about
/// `ẑ × z` by the angle between them; half a turn about x for `z = −ẑ`.
pub(crate) fn z_to(z: &Vector3<f64>) -> UnitQuaternion<f64> {
    let cross = Vector3::z().cross(z);
    let s = cross.norm();
    if s < 1e-10 {
        return if z.z >= 0.0 {
            UnitQuaternion::identity()
        } else {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        };
    }
    let angle = s.atan2(z.z);
    UnitQuaternion::from_axis_angle(&Unit::new_unchecked(cross / s), angle)
}

/// The rigid transform of a position and a rotation.
pub(crate) fn transform(pos: &Vector3<f64>, rotation: &UnitQuaternion<f64>) -> Transform {
    Transform::from_parts(&rotation.to_rotation_matrix().into_inner(), pos)
}

/// A position and an orientation: where a frame is in its parent's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pose {
    pub(crate) p: Vector3<f64>,
    pub(crate) q: UnitQuaternion<f64>,
}

impl Pose {
    pub(crate) const IDENTITY: Pose = Pose {
        p: Vector3::new(0.0, 0.0, 0.0),
        q: UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(1.0, 0.0, 0.0, 0.0)),
    };

    /// `self` then `then` (in `self`'s frame).
    pub(crate) fn then(&self, then: &Pose) -> Pose {
        Pose {
            p: self.p + self.q * then.p,
            q: self.q * then.q,
        }
    }

    /// The pose that undoes `self`.
    pub(crate) fn inverse(&self) -> Pose {
        let q = self.q.inverse();
        Pose {
            p: -(q * self.p),
            q,
        }
    }

    pub(crate) fn transform(&self) -> crate::model::transform::Transform {
        transform(&self.p, &self.q)
    }
}

/// The placement `fromto="x1 y1 z1 x2 y2 z2"` gives a site or geom: at the middle, its z axis
/// turned to point from the second point to the first, as MuJoCo turns it.
pub(crate) fn fromto(value: &str, at: At) -> Result<Pose, Problem> {
    let [a, b, c, d, e, f] = reals::<6>(value, at, "fromto")?;
    let (from, to) = (Vector3::new(a, b, c), Vector3::new(d, e, f));
    let axis = unit(from - to).ok_or_else(|| {
        Problem::at(
            at,
            "fromto: the two points coincide (or their distance overflows)",
        )
    })?;
    Ok(Pose {
        p: (from + to) * 0.5,
        q: z_to(&axis),
    })
}
