use super::*;
use crate::eval::kernel::frame::Frame;
use crate::eval::kernel::joint::body_sin_cos;
use crate::eval::kernel::pose_lanes;
use crate::eval::layout::body::{Body, CheapPlacement, Placement};
use crate::eval::layout::stored::{stored, transform};
use crate::eval::simd::fused::Fused;
use crate::eval::simd::portable::Separate;
use crate::model::joint::Motion;

fn bodies() -> Vec<Body> {
    let general = Transform::from_xyz_rpy([0.1, -0.4, 0.25], [0.3, -1.1, 2.0]);
    let placements = [
        Placement::Identity,
        Placement::Translation([0.3, -0.2, 0.7]),
        Placement::ScrewX {
            a: 0.35,
            c: 0.3_f64.cos(),
            s: 0.3_f64.sin(),
        },
        Placement::OffsetRot {
            t: [0.1, -0.25, 0.4],
            axis: 0,
            c: 0.8_f64.cos(),
            s: 0.8_f64.sin(),
        },
        Placement::OffsetRot {
            t: [0.0, 0.0, 0.4],
            axis: 1,
            c: (-0.6_f64).cos(),
            s: (-0.6_f64).sin(),
        },
        Placement::OffsetRot {
            t: [0.0, 0.3, 0.0],
            axis: 2,
            c: std::f64::consts::FRAC_PI_2.cos(),
            s: std::f64::consts::FRAC_PI_2.sin(),
        },
        // Quarter turns, as DH tables give them: sin α = ±1 exactly, cos α ≈ 6.1e-17.
        Placement::ScrewX {
            a: 0.2,
            c: std::f64::consts::FRAC_PI_2.cos(),
            s: std::f64::consts::FRAC_PI_2.sin(),
        },
        Placement::OffsetRot {
            t: [0.0, 0.3, -0.1],
            axis: 0,
            c: (-std::f64::consts::FRAC_PI_2).cos(),
            s: (-std::f64::consts::FRAC_PI_2).sin(),
        },
        Placement::General(general),
    ];
    let axes = [
        Axis::X,
        Axis::Y,
        Axis::Z,
        Axis::NegX,
        Axis::NegY,
        Axis::NegZ,
        Axis::General([0.6, 0.0, -0.8]),
    ];
    let var = |index| Term::Var {
        index,
        scale: 1.0,
        offset: 0.25,
    };
    let mut out = Vec::new();
    for pre in &placements {
        for post in &placements {
            for axis in &axes {
                for (theta, d) in [
                    (var(0), Term::Const(0.0)),
                    (Term::Const(0.0), var(1)),
                    (var(0), var(1)),
                    (Term::Const(0.4), Term::Const(0.2)),
                ] {
                    let motion = Motion::new(*axis, theta, d);
                    out.push(Body::new(Some(0), *pre, motion, *post, 0));
                }
            }
        }
    }
    out
}

fn bits(f: &Transform) -> Vec<u64> {
    f.r.iter()
        .flatten()
        .chain(&f.p)
        .map(|x| x.to_bits())
        .collect()
}

fn check<A: Arith>() {
    let parent = Transform::from_xyz_rpy([1.0, 2.0, -0.5], [-0.7, 0.2, 2.9]);
    let q = [1.3, -0.45];
    let generic_parent = Frame::splat(&parent);
    let padded_parent = Frame4::<A::Col>::load(&stored(&parent));
    for body in bodies() {
        let sin_cos = body_sin_cos::<f64, A>(&body, &q);
        for has_parent in [true, false] {
            let generic = pose_lanes::pose_step::<f64, A>(
                has_parent.then_some(&generic_parent),
                &body,
                &q,
                sin_cos,
            );
            let padded = pose_step::<A>(has_parent.then_some(&padded_parent), &body, &q, sin_cos);
            let mut out = stored(&Transform::IDENTITY);
            padded.store(&mut out);
            let out = transform(&out);
            let generic = Transform::from(generic);
            assert_eq!(bits(&out), bits(&generic), "{body:?}, parent {has_parent}");
        }
    }
}

/// The quarter-turn form of a rotation about x gives the bits of the plane rotation it
/// replaces, signed zeros included (the identity frame has them).
fn check_quarter_turns<A: Arith>() {
    let frames = [
        Transform::from_xyz_rpy([1.0, 2.0, -0.5], [-0.7, 0.2, 2.9]),
        Transform::IDENTITY,
        Transform::from_xyz_rpy([0.0, -0.0, 0.0], [0.0, std::f64::consts::PI, 0.0]),
    ];
    for frame in &frames {
        for alpha in [std::f64::consts::FRAC_PI_2, -std::f64::consts::FRAC_PI_2] {
            let (s, c) = alpha.sin_cos();
            let mut turn = CheapPlacement::new(&Placement::Identity).unwrap();
            turn.turn_x(c, s);
            let quarter = if s < 0.0 {
                CheapPlacement::NEGATIVE_QUARTER
            } else {
                CheapPlacement::QUARTER
            };
            assert_eq!(CheapPlacement::turn(turn.shape), quarter);
            let mut quarter = Frame4::<A::Col>::load(&stored(frame)).0;
            cheap_place::<A>(&mut quarter, &turn);
            let mut general = Frame4::<A::Col>::load(&stored(frame)).0;
            plane(&mut general, 1, 2, s, c);
            let (mut a, mut b) = (stored(frame), stored(frame));
            Frame4(quarter).store(&mut a);
            Frame4(general).store(&mut b);
            assert_eq!(
                bits(&transform(&a)),
                bits(&transform(&b)),
                "alpha {alpha}, {frame:?}"
            );
        }
    }
}

#[test]
fn quarter_turns_are_the_plane_rotation_bit_for_bit() {
    assert_eq!(std::f64::consts::FRAC_PI_2.sin(), 1.0);
    check_quarter_turns::<Separate>();
    if crate::eval::simd::isa::isa() != crate::eval::simd::isa::Isa::Baseline {
        check_quarter_turns::<Fused>();
    }
}

/// Whole-vector stores put every entry where a transform keeps it, on each column type and
/// through the dispatched reader (the instruction set this machine runs).
#[test]
fn frames_leave_the_registers_entry_for_entry() {
    let mut t = Transform::IDENTITY;
    for (i, x) in t.entries_mut().iter_mut().enumerate() {
        *x = (i + 1) as f64;
    }
    assert_eq!(t.r[1], [4.0, 5.0, 6.0]);
    assert_eq!(t.p, [10.0, 11.0, 12.0]);
    let out = |mut t: Transform| t.entries_mut().to_vec();
    assert_eq!(
        out(Frame4::<<Separate as Arith>::Col>::load(&stored(&t)).to_transform()),
        out(t)
    );
    if crate::eval::simd::isa::isa() != crate::eval::simd::isa::Isa::Baseline {
        assert_eq!(
            out(Frame4::<<Fused as Arith>::Col>::load(&stored(&t)).to_transform()),
            out(t)
        );
    }
    assert_eq!(out(link_pose(&stored(&t), &Placement::Identity)), out(t));
}

#[test]
fn padded_frames_are_the_generic_frames_bit_for_bit() {
    check::<Separate>();
    if crate::eval::simd::isa::isa() != crate::eval::simd::isa::Isa::Baseline {
        check::<Fused>();
    }
}
