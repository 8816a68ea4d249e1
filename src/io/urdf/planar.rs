//! URDF's planar joint, split into the joints kinechain evaluates: a translation along each of
//! two in-plane axes, then a rotation about the joint's axis.
//!
//! urdfdom defines a planar joint by its axis, the plane's normal, and leaves the in-plane axes
//! to the reader. kinechain takes `u` as the coordinate axis (of the joint frame) farthest from
//! the normal `n` — the first of x, y, z with the smallest `|n_i|` — made orthogonal to `n`, and
//! `v = n × u`: for the usual axis `0 0 1`, `u` and `v` are the joint frame's x and y, the plane
//! of Pinocchio's planar joint. The joint `NAME` becomes the prismatic joints `NAME.x` (along
//! `u`) and `NAME.y` (along `v`) and the continuous joint `NAME.theta` (about `n`), joined by
//! the links `NAME/x` and `NAME/y`: its three entries of `q` and `q̇` are named `NAME.x`,
//! `NAME.y`, `NAME.theta`. Its `<limit>` is ignored (urdfdom gives it no meaning for planar
//! joints).

use crate::model::builder::JointSpec;
use crate::model::joint::JointKind;

/// The links and joints the planar joint `spec` (read as its rotation: origin, axis, parent,
/// child) stands for.
pub(super) fn decompose(spec: JointSpec) -> (Vec<String>, Vec<JointSpec>) {
    let n = normalized(spec.axis);
    let (u, v) = in_plane(n);
    let name = &spec.name;
    let (lx, ly) = (format!("{name}/x"), format!("{name}/y"));
    let x = JointSpec::new(
        format!("{name}.x"),
        JointKind::Prismatic,
        spec.parent.as_str(),
        lx.as_str(),
    )
    .with_origin(spec.origin)
    .with_axis(u);
    let y = JointSpec::new(
        format!("{name}.y"),
        JointKind::Prismatic,
        lx.as_str(),
        ly.as_str(),
    )
    .with_axis(v);
    let theta = JointSpec::new(
        format!("{name}.theta"),
        JointKind::Continuous,
        ly.as_str(),
        spec.child.as_str(),
    )
    .with_axis(n);
    (vec![lx, ly], vec![x, y, theta])
}

fn normalized(a: [f64; 3]) -> [f64; 3] {
    let norm = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / norm, a[1] / norm, a[2] / norm]
}

/// The in-plane axes `u`, `v` of the unit normal `n` (see the module's documentation).
fn in_plane(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let far = (0..3)
        .min_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(0);
    let mut e = [0.0; 3];
    e[far] = 1.0;
    let along = n[far];
    let u = normalized([
        e[0] - along * n[0],
        e[1] - along * n[1],
        e[2] - along * n[2],
    ]);
    let v = [
        n[1] * u[2] - n[2] * u[1],
        n[2] * u[0] - n[0] * u[2],
        n[0] * u[1] - n[1] * u[0],
    ];
    (u, v)
}

#[cfg(test)]
mod tests {
    use super::in_plane;

    #[test]
    fn the_usual_axis_gives_the_joint_frames_x_and_y() {
        assert_eq!(
            in_plane([0.0, 0.0, 1.0]),
            ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        );
        assert_eq!(
            in_plane([1.0, 0.0, 0.0]),
            ([0.0, 1.0, 0.0], [0.0, 0.0, 1.0])
        );
        let (u, v) = in_plane([0.6, 0.0, 0.8]);
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        assert!(dot(u, [0.6, 0.0, 0.8]).abs() < 1e-15 && dot(u, v).abs() < 1e-15);
        assert!((dot(v, v) - 1.0).abs() < 1e-15);
    }
}
