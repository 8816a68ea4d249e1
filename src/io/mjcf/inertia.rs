//! MuJoCo's free-joint alignment (`<compiler alignfree>`, `<freejoint align>`): a body whose only
//! joint is free and that has no child bodies gets its inertial frame as its body frame, and
//! what it holds moves the other way, so that everything stays where it was at `qpos0` but the
//! body's own frame (and `qpos`) is the inertial one.
//!
//! The inertial frame is MuJoCo's compiler's: the `<inertial>` element's `pos` and orientation
//! (or the principal axes of its `fullinertia`), or, when the inertia comes from the geoms (no
//! `<inertial>`, or `inertiafromgeom="true"`), that of the geoms with mass (in the groups
//! `inertiagrouprange` names): one geom's own frame, or the centre of mass and principal axes of
//! several (each a solid or, with `shellinertia`, a shell of uniform density). Principal axes are
//! those MuJoCo's compiler finds: Jacobi rotations, each zeroing the largest off-diagonal entry,
//! accumulated in a quaternion from the identity until the off-diagonal entries are rounding,
//! the moments then sorted in decreasing order by quarter turns (any orthonormal eigenvectors
//! would do for the physics; the frame is MuJoCo's only with MuJoCo's choice among them, which
//! this path makes). Checked against MuJoCo 4.0.1 to 1e-15 (its 3.x releases stopped the
//! rotations at 10⁻¹² and left axes about 10⁻⁸ off the exact ones). A mesh geom with mass is refused with an error naming it:
//! its inertial frame is the mesh's own, which kinechain does not read.

use super::attrs::{Kind, Pose, boolean, fromto, placement, reals};
use super::scene::{Body, Item, Source};
use super::tree::Problem;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Smallest mass MuJoCo counts for a geom (`mjEPS`).
const MIN_MASS: f64 = 1e-14;

/// The inertial frame `body` is moved onto (in its own frame), if the alignment applies to it.
pub(super) fn align(body: &Body<'_>, source: &Source) -> Result<Option<Pose>, Problem> {
    let [joint] = body.joints.as_slice() else {
        return Ok(None);
    };
    if body.children > 0 || !is_free(joint, source) {
        return Ok(None);
    }
    let wanted = match joint.el.attribute("align") {
        Some(("auto", _)) | None => source.compiler.alignfree,
        Some((v, at)) => boolean(v, at, "align")?,
    };
    if !wanted {
        return Ok(None);
    }
    inertial_frame(body, source).map(Some)
}

fn is_free(joint: &Item<'_>, source: &Source) -> bool {
    if joint.el.name == "freejoint" {
        return true;
    }
    let class = joint
        .el
        .attribute("class")
        .map_or(joint.class.as_str(), |(c, _)| c);
    source
        .defaults
        .value(joint.el, Kind::Joint, class, "type")
        .is_some_and(|(t, _)| t == "free")
}

/// Where the body's inertial frame is in its body frame.
fn inertial_frame(body: &Body<'_>, source: &Source) -> Result<Pose, Problem> {
    let name = body
        .item
        .name
        .as_ref()
        .map_or_else(|| "an unnamed body".to_string(), |n| format!("body '{n}'"));
    let refuse = |at, why: String| {
        Problem::at(
            at,
            format!(
                "{name}: its free joint is aligned with its inertial frame (alignfree), and {why}; \
                 give the body an <inertial> with pos and an orientation, or align=\"false\""
            ),
        )
    };
    let from_geoms = match source.compiler.inertiafromgeom {
        Some(always) => always,
        None => body.inertial.is_none(),
    };
    if !from_geoms {
        let Some(inertial) = &body.inertial else {
            return Err(refuse(
                body.item.el.at,
                "it has no <inertial> and inertiafromgeom is false".to_string(),
            ));
        };
        let el = inertial.el;
        if let Some((v, at)) = el.attribute("fullinertia") {
            let [xx, yy, zz, xy, xz, yz] = reals::<6>(v, at, "fullinertia")?;
            let p = match el.attribute("pos") {
                Some((v, at)) => Vector3::from(reals::<3>(v, at, "pos")?),
                None => Vector3::zeros(),
            };
            let q =
                principal_axes([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]).ok_or_else(|| {
                    refuse(at, "its fullinertia is not positive definite".to_string())
                })?;
            return Ok(inertial.frame.then(&Pose { p, q }));
        }
        let (p, q) = placement(el, |a| el.attribute(a), &source.compiler)?;
        return Ok(inertial.frame.then(&Pose { p, q }));
    }
    let mut massive = Vec::new();
    for geom in &body.geoms {
        if let Some(m) = massive_geom(geom, source)? {
            massive.push(m);
        }
    }
    match massive.as_slice() {
        [] => Err(refuse(body.item.el.at, "no geom gives it mass".to_string())),
        [one] => Ok(one.frame),
        several => {
            // Centre of mass, then the inertia about it in the body's axes: each geom's turned
            // by its frame, plus its mass at its offset (the parallel-axis terms).
            let total: f64 = several.iter().map(|g| g.mass).sum();
            let com = several
                .iter()
                .fold(Vector3::zeros(), |c, g| c + g.frame.p * g.mass)
                / total;
            let mut sum = [[0.0; 3]; 3];
            for g in several {
                let r = rotation_rows(&g.frame.q);
                let d = g.frame.p - com;
                for i in 0..3 {
                    for j in 0..3 {
                        let turned: f64 = (0..3).map(|k| r[i][k] * g.inertia[k] * r[j][k]).sum();
                        let shift = if i == j {
                            d.norm_squared() - d[i] * d[i]
                        } else {
                            -d[i] * d[j]
                        };
                        sum[i][j] += turned + g.mass * shift;
                    }
                }
            }
            let q = principal_axes(sum).ok_or_else(|| {
                refuse(
                    body.item.el.at,
                    "its geoms' inertia is not positive definite".to_string(),
                )
            })?;
            Ok(Pose { p: com, q })
        }
    }
}

/// A geom that counts for its body's inertia: its mass, its principal moments (in its own
/// axes) and its frame in the body.
struct Massive {
    mass: f64,
    inertia: [f64; 3],
    frame: Pose,
}

/// The rows of the rotation matrix of `q`.
fn rotation_rows(q: &UnitQuaternion<f64>) -> [[f64; 3]; 3] {
    let m = q.to_rotation_matrix();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// The principal axes of the symmetric matrix `m` as MuJoCo's compiler finds them (see the
/// module's documentation): the rotation whose columns are the axes, moments decreasing.
/// `None` when the smallest moment is not positive (MuJoCo refuses such an inertia).
fn principal_axes(m: [[f64; 3]; 3]) -> Option<UnitQuaternion<f64>> {
    // Off-diagonal entries this small next to the moments are rounding; moments this close
    // are not reordered.
    const ROUNDING: f64 = 1e-15;
    const EPS: f64 = 1e-12;
    let mut q = [1.0, 0.0, 0.0, 0.0];
    let mut moments = [m[0][0], m[1][1], m[2][2]];
    for _ in 0..500 {
        // D = Rᵀ M R, R the rotation of q.
        let r = quaternion_matrix(q);
        let d: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                let rt_m: [f64; 3] = std::array::from_fn(|k| {
                    r[0][i] * m[0][k] + r[1][i] * m[1][k] + r[2][i] * m[2][k]
                });
                rt_m[0] * r[0][j] + rt_m[1] * r[1][j] + rt_m[2] * r[2][j]
            })
        });
        moments = [d[0][0], d[1][1], d[2][2]];
        // The largest off-diagonal entry (ties to the earlier of (0,1), (0,2), (1,2)), and the
        // axis a rotation in its plane turns about.
        let (row, col, axis) = if d[0][1].abs() > d[0][2].abs() && d[0][1].abs() > d[1][2].abs() {
            (0, 1, 2)
        } else if d[0][2].abs() > d[1][2].abs() {
            (0, 2, 1)
        } else {
            (1, 2, 0)
        };
        let largest = moments.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        if d[row][col].abs() <= ROUNDING * largest {
            break;
        }
        // The 2 × 2 symmetric Schur rotation that zeroes it, by θ = atan t (|θ| ≤ π/4).
        let tau = (d[col][col] - d[row][row]) / (2.0 * d[row][col]);
        let t = if tau >= 0.0 {
            1.0 / (tau + (1.0 + tau * tau).sqrt())
        } else {
            -1.0 / (-tau + (1.0 + tau * tau).sqrt())
        };
        // As a quaternion about `axis` by half of −θ (+θ about y, the axis whose plane (x, z)
        // runs the other way), from the angle itself: through cos θ, a small turn's half
        // angle would lose its digits.
        let half = t.atan() / 2.0;
        let mut turn = [half.cos(), 0.0, 0.0, 0.0];
        turn[axis + 1] = if axis == 1 { half.sin() } else { -half.sin() };
        q = multiply(q, turn);
    }
    // Moments in decreasing order, by quarter turns about the third axis of each swap.
    for j in 0..3 {
        let a = j % 2;
        if moments[a] + EPS < moments[a + 1] {
            moments.swap(a, a + 1);
            let mut turn = [std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0, 0.0];
            turn[(a + 2) % 3 + 1] = turn[0];
            q = multiply(q, turn);
            normalize(&mut q);
        }
    }
    if moments[2] < 1e-14 {
        return None;
    }
    Some(UnitQuaternion::new_unchecked(Quaternion::new(
        q[0], q[1], q[2], q[3],
    )))
}

/// The rotation matrix (rows) of the unit quaternion `q` (w, x, y, z).
fn quaternion_matrix([w, x, y, z]: [f64; 4]) -> [[f64; 3]; 3] {
    if [w, x, y, z] == [1.0, 0.0, 0.0, 0.0] {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let (ww, wx, wy, wz) = (w * w, w * x, w * y, w * z);
    let (xx, xy, xz, yy, yz, zz) = (x * x, x * y, x * z, y * y, y * z, z * z);
    [
        [ww + xx - yy - zz, 2.0 * (xy - wz), 2.0 * (xz + wy)],
        [2.0 * (xy + wz), ww - xx + yy - zz, 2.0 * (yz - wx)],
        [2.0 * (xz - wy), 2.0 * (yz + wx), ww - xx - yy + zz],
    ]
}

/// The Hamilton product `a b`, normalised.
fn multiply(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let mut p = [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ];
    normalize(&mut p);
    p
}

/// `v` scaled to unit length, unless its norm is within 10⁻¹⁴ of 1 (or it is nearly zero).
fn normalize(v: &mut [f64; 4]) {
    let n = v.iter().map(|x| x * x).sum::<f64>();
    if n < 1e-14 {
        return;
    }
    let n = n.sqrt();
    if (n - 1.0).abs() > 1e-14 {
        for x in v.iter_mut() {
            *x /= n;
        }
    }
}

/// `geom` if it counts for its body's inertia (its group within `inertiagrouprange`, a mass
/// above `mjEPS`): its mass, moments and frame in the body; else `None`.
fn massive_geom(geom: &Item<'_>, source: &Source) -> Result<Option<Massive>, Problem> {
    let el = geom.el;
    let class = source.defaults.class_of(el, &geom.class)?;
    let get = |n: &str| source.defaults.value(el, Kind::Geom, class, n);
    let number = |n: &str, default: f64| -> Result<f64, Problem> {
        match get(n) {
            Some((v, at)) => Ok(reals::<1>(v, at, n)?[0]),
            None => Ok(default),
        }
    };
    let group = number("group", 0.0)?;
    let [lo, hi] = source.compiler.inertiagrouprange;
    if group < lo as f64 || group > hi as f64 {
        return Ok(None);
    }
    let kind = get("type").map_or("sphere", |(t, _)| t);
    let meshy = matches!(kind, "mesh" | "sdf" | "hfield") || get("mesh").is_some();
    let shell = match get("shellinertia") {
        Some((v, at)) => boolean(v, at, "shellinertia")?,
        None => false,
    };
    let mut size = match get("size") {
        Some((v, at)) => {
            let mut s = super::attrs::real_list(v, at, "size")?;
            s.resize(3, 0.0);
            [s[0], s[1], s[2]]
        }
        None => [0.0; 3],
    };
    let placed = match get("fromto") {
        Some((v, at)) => {
            let [a, b, c, d, e, f] = reals::<6>(v, at, "fromto")?;
            let half = ((a - d).powi(2) + (b - e).powi(2) + (c - f).powi(2)).sqrt() / 2.0;
            size = match kind {
                "box" | "ellipsoid" => [size[0], size[0], half],
                _ => [size[0], half, size[2]],
            };
            Some(fromto(v, at)?)
        }
        None => None,
    };
    let measure = if meshy {
        0.0
    } else {
        volume(kind, size, shell)
    };
    let mass = match get("mass") {
        Some((v, at)) => reals::<1>(v, at, "mass")?[0],
        None if meshy => number("density", 1000.0)?,
        None => number("density", 1000.0)? * measure,
    };
    if mass <= MIN_MASS {
        return Ok(None);
    }
    if meshy {
        return Err(Problem::at(
            el.at,
            "a free body aligned with its inertial frame (alignfree) has a mesh geom with mass: \
             its inertial frame is the mesh's, which kinechain does not read; give the body an \
             <inertial> with pos and an orientation, or align=\"false\"",
        ));
    }
    let pose = match placed {
        Some(pose) => pose,
        None => {
            let (p, q) = placement(el, get, &source.compiler)?;
            Pose { p, q }
        }
    };
    Ok(Some(Massive {
        mass,
        inertia: moments(kind, size, shell, mass),
        frame: geom.frame.then(&pose),
    }))
}

/// The volume of a primitive geom (its area with `shell`); zero for a plane.
fn volume(kind: &str, s: [f64; 3], shell: bool) -> f64 {
    use std::f64::consts::PI;
    let (r, h) = (s[0], 2.0 * s[1]);
    match (kind, shell) {
        ("sphere", false) => 4.0 * PI * r * r * r / 3.0,
        ("sphere", true) => 4.0 * PI * r * r,
        ("capsule", false) => PI * (r * r * h + 4.0 * r * r * r / 3.0),
        ("capsule", true) => 4.0 * PI * r * r + 2.0 * PI * r * h,
        ("cylinder", false) => PI * r * r * h,
        ("cylinder", true) => 2.0 * PI * r * r + 2.0 * PI * r * h,
        ("ellipsoid", false) => 4.0 * PI * s[0] * s[1] * s[2] / 3.0,
        ("ellipsoid", true) => {
            // Thomsen's approximation of the surface.
            let p = 1.6075;
            let sum = (s[0] * s[1]).powf(p) + (s[1] * s[2]).powf(p) + (s[2] * s[0]).powf(p);
            4.0 * PI * (sum / 3.0).powf(1.0 / p)
        }
        ("box", false) => 8.0 * s[0] * s[1] * s[2],
        ("box", true) => 8.0 * (s[0] * s[1] + s[1] * s[2] + s[2] * s[0]),
        _ => 0.0,
    }
}

/// The principal moments of a primitive geom of mass `m` about its own axes: a solid of
/// uniform density, or with `shell` a shell of uniform surface density (MuJoCo's formulas).
fn moments(kind: &str, s: [f64; 3], shell: bool, m: f64) -> [f64; 3] {
    use std::f64::consts::PI;
    let (r, half) = (s[0], s[1]);
    let h = 2.0 * half;
    let (s00, s11, s22) = (s[0] * s[0], s[1] * s[1], s[2] * s[2]);
    match (kind, shell) {
        ("sphere", false) => [2.0 * m * r * r / 5.0; 3],
        ("sphere", true) => [2.0 * m * r * r / 3.0; 3],
        ("capsule", false) => {
            // A cylinder and two hemispheres shifted along the axis.
            let sphere = m * 4.0 * r / (4.0 * r + 3.0 * h);
            let cylinder = m - sphere;
            let across = cylinder * (3.0 * r * r + h * h) / 12.0
                + 2.0 * sphere * r * r / 5.0
                + sphere * h * (3.0 * r + 2.0 * h) / 8.0;
            [
                across,
                across,
                cylinder * r * r / 2.0 + 2.0 * sphere * r * r / 5.0,
            ]
        }
        ("capsule", true) => {
            let a_sphere = 4.0 * PI * r * r;
            let sphere = m * a_sphere / (a_sphere + 2.0 * PI * r * h);
            let cylinder = m - sphere;
            let (com, at) = (r / 2.0, half + r / 2.0);
            let across = cylinder * (6.0 * r * r + h * h) / 12.0
                + 2.0 * sphere * r * r / 3.0
                + sphere * (at * at - com * com);
            [
                across,
                across,
                cylinder * r * r + 2.0 * sphere * r * r / 3.0,
            ]
        }
        ("cylinder", false) => {
            let across = m * (3.0 * r * r + h * h) / 12.0;
            [across, across, m * r * r / 2.0]
        }
        ("cylinder", true) => {
            let disk_area = PI * r * r;
            let disk = m * disk_area / (2.0 * disk_area + 2.0 * PI * r * h);
            let tube = m - 2.0 * disk;
            let across = tube * (6.0 * r * r + h * h) / 12.0
                + 2.0 * (disk * r * r / 4.0 + disk * half * half);
            [across, across, tube * r * r + 2.0 * (disk * r * r / 2.0)]
        }
        ("ellipsoid", false) => [
            m * (s11 + s22) / 5.0,
            m * (s00 + s22) / 5.0,
            m * (s00 + s11) / 5.0,
        ],
        ("ellipsoid", true) => {
            // The solid grown by 10⁻⁶ less the solid, at the density that gives mass m.
            let e = 1e-6;
            let va = 4.0 * PI * s[0] * s[1] * s[2] / 3.0;
            let (a, b, c) = (s[0] + e, s[1] + e, s[2] + e);
            let vb = 4.0 * PI * a * b * c / 3.0;
            let density = m / (vb - va);
            let (ma, mb) = (va * density, vb * density);
            [
                mb * (b * b + c * c) / 5.0 - ma * (s11 + s22) / 5.0,
                mb * (a * a + c * c) / 5.0 - ma * (s00 + s22) / 5.0,
                mb * (a * a + b * b) / 5.0 - ma * (s00 + s11) / 5.0,
            ]
        }
        ("box", false) => [
            m * (s11 + s22) / 3.0,
            m * (s00 + s22) / 3.0,
            m * (s00 + s11) / 3.0,
        ],
        ("box", true) => box_shell(s, m),
        _ => [0.0; 3],
    }
}

/// The moments of a box's six faces of uniform surface density, mass `m`.
fn box_shell(s: [f64; 3], m: f64) -> [f64; 3] {
    let (lx, ly, lz) = (2.0 * s[0], 2.0 * s[1], 2.0 * s[2]);
    let (a0, a1, a2) = (lx * ly, ly * lz, lz * lx);
    let total = 2.0 * (a0 + a1 + a2);
    let (m0, m1, m2) = (m * a0 / total, m * a1 / total, m * a2 / total);
    let (s00, s11, s22) = (s[0] * s[0], s[1] * s[1], s[2] * s[2]);
    // Each pair of faces: about its own centre, then shifted to the box's.
    let x = m0 * ly * ly / 12.0 + m1 * (ly * ly + lz * lz) / 12.0 + m2 * lz * lz / 12.0;
    let y = m0 * lx * lx / 12.0 + m1 * lz * lz / 12.0 + m2 * (lx * lx + lz * lz) / 12.0;
    let z = m0 * (lx * lx + ly * ly) / 12.0 + m1 * ly * ly / 12.0 + m2 * lx * lx / 12.0;
    [
        2.0 * (m0 * s22 + m2 * s11 + x),
        2.0 * (m0 * s22 + m1 * s00 + y),
        2.0 * (m1 * s00 + m2 * s11 + z),
    ]
}
