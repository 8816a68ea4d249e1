//! Orientation coordinates (`kinechain::orientation`): the book's worked examples and problems
//! through every representation, and property tests over random rotations and rotations near
//! each singularity.

use kinechain::nalgebra::{Matrix3, Unit, Vector3, Vector4};
use kinechain::orientation::*;
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};

fn max_diff(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    (a - b).abs().max()
}

fn axis(x: f64, y: f64, z: f64) -> Unit<Vector3<f64>> {
    Unit::new_normalize(Vector3::new(x, y, z))
}

fn deg(x: f64) -> f64 {
    x.to_radians()
}

// ---------------------------------------------------------------------------------------------
// Worked examples (the book prints 4–5 digits; compared at half a unit of the last digit unless
// the book's own rounding is larger, as noted).

/// Ex. 2.1: planar motion about z, the Euler-parameter form of the matrix (eq. 2.14).
#[test]
fn example_2_1_planar_rotation() {
    for theta in [0.3, 1.7, -2.9] {
        let e = EulerParameters::from_axis_angle(&Vector3::z_axis(), theta);
        assert_eq!((e.e1, e.e2), (0.0, 0.0));
        let a = e.to_matrix();
        let book = Matrix3::new(
            2.0 * e.e0 * e.e0 - 1.0,
            -2.0 * e.e0 * e.e3,
            0.0,
            2.0 * e.e0 * e.e3,
            2.0 * e.e0 * e.e0 - 1.0,
            0.0,
            0.0,
            0.0,
            2.0 * (e.e0 * e.e0 + e.e3 * e.e3) - 1.0,
        );
        assert!(max_diff(&a, &book) < 4e-16);
        assert!(max_diff(&a, &rot_z(theta)) < 4e-16);
    }
}

/// Ex. 2.3: 45° about (1,1,1)/√3 applied to r = (2,3,4), by Rodrigues (eq. 2.9), Euler
/// parameters (eq. 2.14) and the exponential form (eq. 2.26) as a power series.
#[test]
fn example_2_3_three_forms_of_one_rotation() {
    let v = axis(1.0, 1.0, 1.0);
    let a = rotation_matrix(&v, deg(45.0));
    let r = a * Vector3::new(2.0, 3.0, 4.0);
    for (got, book) in r.iter().zip([2.70114, 2.18350, 4.11536]) {
        assert!((got - book).abs() < 5e-6, "{r:?}");
    }
    let e = EulerParameters::from_axis_angle(&v, deg(45.0));
    assert!(max_diff(&a, &e.to_matrix()) < 4e-16);
    // exp(θ [v]x) = Σ (θ [v]x)^n / n!
    let k = skew(&v) * deg(45.0);
    let (mut term, mut sum) = (Matrix3::identity(), Matrix3::identity());
    for n in 1..30 {
        term = term * k / n as f64;
        sum += term;
    }
    assert!(max_diff(&a, &sum) < 4e-16);
}

/// Ex. 2.4 and 2.5: 180° about b1 = (1,0,1), then 90° about b2 = (0,1,0) (body lines); the
/// single-frame and multiframe methods agree, and b3 = (1,0,0) ends at (−1,0,0).
#[test]
fn examples_2_4_and_2_5_successive_rotations() {
    let rotations = [(axis(1.0, 0.0, 1.0), PI), (axis(0.0, 1.0, 0.0), FRAC_PI_2)];
    let single = single_frame(&rotations);
    let multi = multiframe(&rotations);
    let book = Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
    assert!(max_diff(&single, &book) < 1e-15);
    assert!(max_diff(&multi, &book) < 1e-15);
    let b3 = single * Vector3::x();
    assert!((b3 - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-15);
    // The book's intermediate A1 = I + 2[v1]x² (sin 180° = 0).
    let a1 = rotation_matrix(&rotations[0].0, PI);
    assert!(
        max_diff(
            &a1,
            &Matrix3::new(0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 1.0, 0.0, 0.0)
        ) < 1e-15
    );
    // Rotations do not commute.
    let swapped = multiframe(&[rotations[1], rotations[0]]);
    assert!(max_diff(&swapped, &book) > 0.5);
}

/// Ex. 2.6: 3° about (2,2,−1) is close to I + [v]x θ (the book's matrix), to second order.
#[test]
fn example_2_6_small_rotation() {
    let v = axis(2.0, 2.0, -1.0);
    let theta = deg(3.0);
    let exact = rotation_matrix(&v, theta);
    let linear = Matrix3::identity() + skew(&v) * theta;
    let book = Matrix3::new(
        1.0, 0.01745, 0.03491, -0.01745, 1.0, -0.03491, -0.03491, 0.03491, 1.0,
    );
    assert!(max_diff(&linear, &book) < 5e-6);
    // The neglected terms are 2 [v]x² sin²(θ/2) and [v]x (sin θ − θ): at most θ²/2.
    assert!(max_diff(&exact, &linear) <= theta * theta / 2.0);
}

/// Ex. 2.7: 10 rad/s about (1,1,1)/√3: at t = 0.1 s the Euler parameters are (0.8776, 0.2768 ×3)
/// and ω = ω̄ = (5.773, 5.773, 5.773) from ω = 2Eė, ω̄ = 2Ēė (eqs. 2.45–2.46).
#[test]
fn example_2_7_euler_parameters_and_angular_velocity() {
    let v = axis(1.0, 1.0, 1.0);
    let (theta, theta_dot) = (1.0, 10.0);
    let e = EulerParameters::from_axis_angle(&v, theta);
    assert!((e.e0 - 0.8776).abs() < 5e-5 && (e.e1 - 0.2768).abs() < 5e-5);
    let (s, c) = (0.5 * theta).sin_cos();
    let e_dot = Vector4::new(-s, c * v.x, c * v.y, c * v.z) * (0.5 * theta_dot);
    let w = e.omega(&e_dot);
    let w_bar = e.omega_local(&e_dot);
    let exact = 10.0 / 3f64.sqrt();
    for k in 0..3 {
        assert!((w[k] - exact).abs() < 1e-13 && (w_bar[k] - exact).abs() < 1e-13);
        assert!((w[k] - 5.773).abs() < 1e-3); // the book truncates 5.7735
    }
    // And back: ė = ½ Eᵀ ω.
    assert!((e.rates(&w) - e_dot).norm() < 1e-14);
}

/// Ex. 2.9: Euler angles and their rates from Euler parameters and ω.
#[test]
fn example_2_9_euler_angle_rates() {
    let e = EulerParameters {
        e0: 0.9239,
        e1: 0.2209,
        e2: 0.2209,
        e3: 0.2209,
    }
    .normalized();
    let angles = EulerZxz::from_matrix(&e.to_matrix()).unwrap();
    // The book's values come from 4-digit parameters; 0.01° tolerance covers that rounding.
    assert!(
        (angles.theta.to_degrees() - 36.41).abs() < 0.01,
        "{angles:?}"
    );
    assert!(
        (angles.phi.to_degrees() - 58.4496).abs() < 0.01,
        "{angles:?}"
    );
    assert!(
        (angles.psi.to_degrees() + 31.5604).abs() < 0.01,
        "{angles:?}"
    );
    let omega = Vector3::new(120.72, 75.87, -46.59);
    let rates = angles.rates(&omega).unwrap();
    for (got, book) in rates.iter().zip([-132.2553, 127.8171, 106.4338]) {
        assert!((got - book).abs() < 0.05, "{rates:?}");
    }
    assert!((angles.g_matrix() * rates - omega).norm() < 1e-12);
}

/// Ex. 2.10: axes given by direction vectors, then 45° about the body z and 60° about the body x.
#[test]
fn example_2_10_direction_cosines() {
    let a0 = from_direction_cosines(
        [
            Vector3::new(0.5, 0.0, 0.5),
            Vector3::new(0.25, 0.25, -0.25),
            Vector3::new(-2.0, 4.0, 2.0),
        ],
        1e-12,
    )
    .unwrap();
    let a = a0 * rot_z(deg(45.0)) * rot_x(deg(60.0));
    let book = Matrix3::new(
        0.9082, -0.3994, -0.1247, 0.4082, 0.9112, 0.0547, 0.0917, -0.1007, 0.9906,
    );
    // The book multiplies A0 rounded to 4 digits, which moves its last digit by up to 1.5 units
    // (exact: 0.09176, −0.10064, 0.99066 in the bottom row).
    assert!(max_diff(&a, &book) < 1.5e-4, "{a}");
    // The same as the multiframe composition about the body axes.
    let multi = a0
        * multiframe(&[
            (Vector3::z_axis(), deg(45.0)),
            (Vector3::x_axis(), deg(60.0)),
        ]);
    assert!(max_diff(&a, &multi) < 1e-15);
    // Direction cosines satisfy eqs. 2.101–2.104.
    assert!(max_diff(&(a0.transpose() * a0), &Matrix3::identity()) < 1e-15);
    assert!(max_diff(&(a0 * a0.transpose()), &Matrix3::identity()) < 1e-15);
    // Bad frames are refused.
    let skewed = [Vector3::x(), Vector3::new(1.0, 1.0, 0.0), Vector3::z()];
    assert!(matches!(
        from_direction_cosines(skewed, 1e-9),
        Err(FrameError::NotOrthogonal { .. })
    ));
    let left = [Vector3::x(), Vector3::y(), -Vector3::z()];
    assert_eq!(
        from_direction_cosines(left, 1e-9),
        Err(FrameError::LeftHanded)
    );
    let zero = [Vector3::x(), Vector3::zeros(), Vector3::z()];
    assert_eq!(
        from_direction_cosines(zero, 1e-9),
        Err(FrameError::ZeroAxis { axis: 2 })
    );
}

#[test]
fn bounds_are_where_the_documentation_puts_them() {
    // The orthogonality tolerance is inclusive: exactly orthogonal axes pass a tolerance of 0.
    let scaled = [2.0 * Vector3::x(), Vector3::y(), 0.5 * Vector3::z()];
    assert_eq!(from_direction_cosines(scaled, 0.0), Ok(Matrix3::identity()));
    // Axes in one plane 60° apart: every |αₖ·αₗ| is 0.5 (to rounding), the least a plane allows,
    // so a tolerance below 0.5 refuses them and none at 0.5 or above is accepted.
    let (s60, c60) = 60f64.to_radians().sin_cos();
    let flat = [
        Vector3::x(),
        Vector3::new(c60, s60, 0.0),
        Vector3::new(-c60, s60, 0.0),
    ];
    assert!(matches!(
        from_direction_cosines(flat, 0.499),
        Err(FrameError::NotOrthogonal { .. })
    ));
    for tolerance in [-1e-9, f64::NAN, 0.5, 2.0] {
        assert!(matches!(
            from_direction_cosines(scaled, tolerance),
            Err(FrameError::InvalidTolerance { .. })
        ));
    }
    // Axes of tiny or huge finite components are directions like any other: their squares
    // would underflow to 0 or overflow to ∞, so they are scaled before they are normalised.
    let (s30, c30) = 30f64.to_radians().sin_cos();
    let tilted = [
        Vector3::new(c30, s30, 0.0),
        Vector3::new(-s30, c30, 0.0),
        Vector3::z(),
    ];
    let expected = from_direction_cosines(tilted, 1e-15).unwrap();
    for factor in [1e-200, 1e-300, 1e200, 1e300] {
        let a = from_direction_cosines(tilted.map(|v| v * factor), 1e-15);
        assert!(
            a.is_ok_and(|a| max_diff(&a, &expected) <= 4.0 * f64::EPSILON),
            "{factor:e}"
        );
    }
    for bad in [f64::NAN, f64::INFINITY] {
        assert_eq!(
            from_direction_cosines(
                [Vector3::x(), Vector3::y(), Vector3::new(0.0, 0.0, bad)],
                0.1
            ),
            Err(FrameError::ZeroAxis { axis: 3 })
        );
    }
    // z-x-z rates fail when |sin θ| < RATE_SINGULARITY, and sin θ = θ exactly this close to 0.
    let w = Vector3::new(0.1, -0.2, 0.3);
    let at = |theta: f64| EulerZxz {
        phi: 0.4,
        theta,
        psi: -0.3,
    };
    assert_eq!(RATE_SINGULARITY.sin(), RATE_SINGULARITY);
    assert!(at(RATE_SINGULARITY).rates(&w).is_ok());
    assert!(at(RATE_SINGULARITY).rates_from_local(&w).is_ok());
    let below = RATE_SINGULARITY.next_down();
    assert!(at(below).rates(&w).is_err());
    assert!(at(below).rates_from_local(&w).is_err());
    // x-y-z rates fail when |cos θ| < RATE_SINGULARITY: on either side of the bound.
    for (offset, singular) in [(0.5, true), (2.0, false)] {
        let theta = FRAC_PI_2 - offset * RATE_SINGULARITY;
        let x = EulerXyz {
            phi: 0.4,
            theta,
            psi: -0.3,
        };
        assert_eq!(x.rates(&w).is_err(), singular, "{offset}");
        assert_eq!(x.rates_from_local(&w).is_err(), singular, "{offset}");
    }
    // Euler parameters of a half turn (e₀ = 0) keep the axis as it is, not its negative.
    let half_turn_x = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
    let e = EulerParameters::from_matrix(&half_turn_x);
    assert_eq!(
        e.as_vector(),
        Vector4::new(0.0, 1.0, 0.0, 0.0),
        "{:?}",
        e.as_vector()
    );
}

// ---------------------------------------------------------------------------------------------
// Problems: one rotation and one ω through every representation, checked for consistency.

/// Every representation of `e` recomposes to the same matrix, and the rates each gives for `ω`
/// describe the same motion: all map back to `ω`, and one small time step with each lands on
/// the same rotation (to the step's second order).
fn consistent(e: &EulerParameters, omega: &Vector3<f64>) {
    let a = e.to_matrix();
    let aa = AxisAngle::from_matrix(&a).unwrap();
    let rodriguez = RodriguezParameters::from_matrix(&a).unwrap();
    let zxz = EulerZxz::from_matrix(&a).unwrap();
    let xyz = EulerXyz::from_matrix(&a).unwrap();
    let rpy = Rpy::from_matrix(&a).unwrap();
    for m in [
        aa.to_matrix(),
        rodriguez.to_matrix(),
        zxz.to_matrix(),
        xyz.to_matrix(),
        rpy.to_matrix(),
        zxz.to_euler_parameters().to_matrix(),
        rodriguez.to_euler_parameters().to_matrix(),
    ] {
        assert!(max_diff(&m, &a) < 2e-15, "{}", max_diff(&m, &a));
    }
    // Problem 20: Euler angles ↔ Euler parameters.
    let from_angles = zxz.to_euler_parameters();
    assert!((from_angles.as_vector() - e.as_vector()).norm() < 1e-15);
    // Rodriguez parameters → Euler parameters (the inverse of eq. 2.88), which gives e₀ > 0: `e`
    // or `−e`, the same rotation.
    let from_gamma = rodriguez.to_euler_parameters().as_vector();
    let e_positive = e.as_vector() * e.e0.signum();
    assert!(
        (from_gamma - e_positive).norm() < 1e-15,
        "{from_gamma} vs {e_positive}"
    );

    let e_dot = e.rates(omega);
    let g_dot = rodriguez.rates(omega);
    let zxz_dot = zxz.rates(omega).unwrap();
    let xyz_dot = xyz.rates(omega).unwrap();
    assert!((e.omega(&e_dot) - omega).norm() < 1e-12 * omega.norm());
    assert!((rodriguez.g_matrix() * g_dot - omega).norm() < 1e-12 * omega.norm());
    assert!((zxz.g_matrix() * zxz_dot - omega).norm() < 1e-12 * omega.norm());
    assert!((xyz.g_matrix() * xyz_dot - omega).norm() < 1e-12 * omega.norm());
    // Local forms: ω̄ = Aᵀω.
    let w_bar = a.transpose() * omega;
    assert!((e.omega_local(&e_dot) - w_bar).norm() < 1e-12 * omega.norm());
    assert!((rodriguez.g_bar_matrix() * g_dot - w_bar).norm() < 1e-12 * omega.norm());
    assert!((zxz.g_bar_matrix() * zxz_dot - w_bar).norm() < 1e-12 * omega.norm());
    assert!((xyz.g_bar_matrix() * xyz_dot - w_bar).norm() < 1e-12 * omega.norm());
    assert!((rodriguez.rates_from_local(&w_bar) - g_dot).norm() < 1e-11 * g_dot.norm().max(1.0));
    assert!((zxz.rates_from_local(&w_bar).unwrap() - zxz_dot).norm() < 1e-11 * zxz_dot.norm());
    assert!((xyz.rates_from_local(&w_bar).unwrap() - xyz_dot).norm() < 1e-11 * xyz_dot.norm());
    // The rotation one small step later, four ways; the step's exact effect is exp(h [ω]x) A.
    let h = 1e-7;
    let exact = rotation_matrix(&Unit::new_normalize(*omega), omega.norm() * h) * a;
    let step = |m: Matrix3<f64>| max_diff(&m, &exact);
    let bound = 4.0 * (omega.norm() * h).powi(2) + 1e-14;
    assert!(
        step(
            EulerParameters::from_vector(&(e.as_vector() + e_dot * h))
                .normalized()
                .to_matrix()
        ) < bound
    );
    assert!(step(RodriguezParameters(rodriguez.0 + g_dot * h).to_matrix()) < bound);
    let z = EulerZxz {
        phi: zxz.phi + h * zxz_dot[0],
        theta: zxz.theta + h * zxz_dot[1],
        psi: zxz.psi + h * zxz_dot[2],
    };
    assert!(step(z.to_matrix()) < bound);
    let x = EulerXyz {
        phi: xyz.phi + h * xyz_dot[0],
        theta: xyz.theta + h * xyz_dot[1],
        psi: xyz.psi + h * xyz_dot[2],
    };
    assert!(step(x.to_matrix()) < bound);
}

/// Problems 12 and 15: e = (0.9239, 0.2209 ×3), ω = (120.72, 75.87, −46.59); Problems 13 and 14:
/// e = (0.8660, 0.2887 ×3), ω = (110, 90, 0). The book's parameters are rounded to 4 digits and
/// are normalised first.
#[test]
fn problems_12_to_15_rates_in_every_representation() {
    let cases = [
        ((0.9239, 0.2209), Vector3::new(120.72, 75.87, -46.59)),
        ((0.8660, 0.2887), Vector3::new(110.0, 90.0, 0.0)),
    ];
    for ((e0, ei), omega) in cases {
        let e = EulerParameters {
            e0,
            e1: ei,
            e2: ei,
            e3: ei,
        }
        .normalized();
        consistent(&e, &omega);
        // The parameter rates keep the constraint (eq. 2.11 differentiated): e·ė = 0.
        assert!(e.as_vector().dot(&e.rates(&omega)).abs() < 1e-13);
    }
}

/// Problem 21: the matrix of Problem 7 (20 rad/s about (1,0,3), t = 0.1 s) has eigenvalues 1 and
/// e^{±iθ}, determinant 1, and the axis as eigenvector of eigenvalue 1.
#[test]
fn problem_21_eigenvalues_and_axis() {
    let v = axis(1.0, 0.0, 3.0);
    let theta = 20.0 * 0.1;
    let a = rotation_matrix(&v, theta);
    assert!((a.determinant() - 1.0).abs() < 1e-15);
    assert!((a * v.into_inner() - v.into_inner()).norm() < 1e-15);
    let eig = a.complex_eigenvalues();
    let mut found = [false; 3];
    for z in eig.iter() {
        if (z.re - 1.0).abs() < 1e-12 && z.im.abs() < 1e-12 {
            found[0] = true;
        } else if (z.re - theta.cos()).abs() < 1e-12 && (z.im - theta.sin()).abs() < 1e-12 {
            found[1] = true;
        } else if (z.re - theta.cos()).abs() < 1e-12 && (z.im + theta.sin()).abs() < 1e-12 {
            found[2] = true;
        }
    }
    assert_eq!(found, [true; 3], "{eig:?}");
    let aa = AxisAngle::from_matrix(&a).unwrap();
    assert!(
        (aa.angle - theta).abs() < 1e-15 && (aa.axis.into_inner() - v.into_inner()).norm() < 1e-15
    );
}

/// Problem 22: the matrix of Example 2.2 (printed to 5 digits), taken apart: θ = 30° about
/// (1,1,1)/√3, its Euler parameters, Rodriguez parameters and Euler angles, all consistent.
#[test]
fn problem_22_extraction() {
    let printed = Matrix3::new(
        0.91068, -0.24402, 0.33334, 0.33334, 0.91068, -0.24402, -0.24402, 0.33334, 0.91068,
    );
    let aa = AxisAngle::from_matrix(&printed).unwrap();
    assert!((aa.angle.to_degrees() - 30.0).abs() < 1e-3, "{aa:?}");
    assert!((aa.axis.into_inner() - axis(1.0, 1.0, 1.0).into_inner()).norm() < 1e-4);
    let e = EulerParameters::from_matrix(&printed);
    assert!(
        (e.e0 - deg(15.0).cos()).abs() < 1e-4
            && (e.e1 - deg(15.0).sin() / 3f64.sqrt()).abs() < 1e-4
    );
    let g = RodriguezParameters::from_matrix(&printed).unwrap();
    assert!((g.0.x - deg(15.0).tan() / 3f64.sqrt()).abs() < 1e-4);
    // The nearest rotation (through the parameters), in every representation.
    consistent(&e, &Vector3::new(1.0, -2.0, 0.5));
}

// ---------------------------------------------------------------------------------------------
// Singular cases are errors, never NaN.

#[test]
fn singular_cases_are_errors() {
    // Exactly singular matrices (rot_x(PI) is not: sin of the double nearest π is 1.2e-16, and a
    // valid decomposition exists).
    let identity = Matrix3::identity();
    let half_turn_x = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
    let half_turn_z = Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
    let quarter_y = Matrix3::new(0.0, 0.0, 1.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0);
    assert!(AxisAngle::from_matrix(&identity).is_err());
    assert!(EulerZxz::from_matrix(&identity).is_err());
    assert!(EulerZxz::from_matrix(&half_turn_x).is_err());
    assert!(EulerXyz::from_matrix(&(rot_x(0.3) * quarter_y * rot_z(-0.2))).is_err());
    assert!(Rpy::from_matrix(&(rot_z(0.3) * quarter_y.transpose() * rot_x(-0.2))).is_err());
    assert!(RodriguezParameters::from_matrix(&half_turn_z).is_err());
    // Numerically π (not exactly): defined, and it recomposes.
    let z = EulerZxz::from_matrix(&rot_x(PI)).unwrap();
    assert!(max_diff(&z.to_matrix(), &rot_x(PI)) < 4.0 * f64::EPSILON);
    let lock = EulerZxz {
        phi: 0.3,
        theta: 0.0,
        psi: -0.2,
    };
    assert!(lock.rates(&Vector3::new(1.0, 2.0, 3.0)).is_err());
    assert!(lock.rates_from_local(&Vector3::new(1.0, 2.0, 3.0)).is_err());
    let lock = EulerXyz {
        phi: 0.3,
        theta: FRAC_PI_2,
        psi: -0.2,
    };
    assert!(lock.rates(&Vector3::new(1.0, 2.0, 3.0)).is_err());
    // Defined cases nearby give finite numbers.
    let near = rot_x(1e-9) * rot_z(0.4);
    let a = EulerZxz::from_matrix(&near).unwrap();
    assert!(a.phi.is_finite() && a.psi.is_finite() && a.theta > 0.0);
    assert!(max_diff(&a.to_matrix(), &near) < 4e-16);
}

/// Rodriguez parameters of a rotation a hair short of a half turn are huge but finite (γ = tan
/// θ/2 along the axis), and everything computed from them stays finite and right: a half turn
/// about x whose matrix is off by `ε` in its two off-diagonal entries has `γ = 2/ε` along x, whose
/// square overflows `f64` from ε ≈ 10⁻¹⁵⁴ on. Closer still, γ itself overflows: an error.
#[test]
fn rodriguez_parameters_near_a_half_turn_stay_finite() {
    let off = |eps: f64| Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, -eps, 0.0, eps, -1.0);
    assert!(RodriguezParameters::from_matrix(&off(1e-308)).is_err());
    for eps in [1e-100, 1e-150, 1e-160, 1e-200, 1e-300, 1e-307] {
        let a = off(eps);
        let g = RodriguezParameters::from_matrix(&a).unwrap();
        assert!(
            g.0.iter().all(|x| x.is_finite()),
            "ε = {eps:e}: γ = {:?}",
            g.0
        );
        assert_eq!((g.0.y, g.0.z), (0.0, 0.0), "ε = {eps:e}");
        let e = g.to_euler_parameters();
        let want = EulerParameters::from_matrix(&a);
        for (got, expected) in [
            (e.e0, want.e0),
            (e.e1, want.e1),
            (e.e2, want.e2),
            (e.e3, want.e3),
        ] {
            assert!(
                (got - expected).abs() <= f64::EPSILON,
                "ε = {eps:e}: {e:?} against {want:?}"
            );
        }
        let back = g.to_matrix();
        assert!(
            max_diff(&back, &a) < 4.0 * f64::EPSILON,
            "ε = {eps:e}: {back}"
        );
        for m in [g.g_matrix(), g.g_bar_matrix()] {
            assert!(m.iter().all(|x| x.is_finite()), "ε = {eps:e}: {m}");
        }
        // About an axis across γ, γ̇ = ½ (ω ∓ γ × ω): finite, and exactly so here.
        let omega = Vector3::new(0.0, 0.5, 0.0);
        let gx = g.0.x;
        assert_eq!(
            g.rates(&omega),
            Vector3::new(0.0, 0.25, -0.25 * gx),
            "ε = {eps:e}"
        );
        assert_eq!(
            g.rates_from_local(&omega),
            Vector3::new(0.0, 0.25, 0.25 * gx),
            "ε = {eps:e}"
        );
    }
}

#[test]
fn free_angles_are_in_the_half_open_range_up_to_pi() {
    // Half turns, written exactly: each free angle comes back as +π, never −π.
    let half_turn_z = Matrix3::new(-1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0);
    let rpy = Rpy::from_matrix(&half_turn_z).unwrap();
    assert_eq!((rpy.roll, rpy.pitch, rpy.yaw), (0.0, 0.0, PI));
    // Rx(π/2) Rz(π): z-x-z angles (0, π/2, π).
    let zxz = Matrix3::new(-1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, -1.0, 0.0);
    let e = EulerZxz::from_matrix(&zxz).unwrap();
    assert_eq!((e.phi, e.theta, e.psi), (0.0, FRAC_PI_2, PI));
    // The half turn about x with the signs of zero for which atan2 gives −π: roll = atan2(a₃₂,
    // a₃₃) with a₃₂ = −0, and x-y-z φ = atan2(−a₂₃, a₃₃) with a₂₃ = +0.
    let half_turn_x = Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, -0.0, -1.0);
    let rpy = Rpy::from_matrix(&half_turn_x).unwrap();
    assert_eq!((rpy.roll, rpy.pitch, rpy.yaw), (PI, 0.0, 0.0));
    let xyz = EulerXyz::from_matrix(&half_turn_x).unwrap();
    assert_eq!((xyz.phi, xyz.theta, xyz.psi), (PI, 0.0, 0.0));
    for a in [half_turn_z, zxz, half_turn_x] {
        for angles in [
            Rpy::from_matrix(&a).map(|r| [r.roll, r.yaw]),
            EulerXyz::from_matrix(&a).map(|x| [x.phi, x.psi]),
            EulerZxz::from_matrix(&a).map(|z| [z.phi, z.psi]),
        ]
        .into_iter()
        .flatten()
        {
            assert!(angles.iter().all(|x| *x > -PI && *x <= PI), "{angles:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Properties.

/// A rotation from a random unit quaternion (uniform on SO(3)).
fn random_rotation() -> impl Strategy<Value = EulerParameters> {
    (-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0)
        .prop_filter("away from zero", |(a, b, c, d)| {
            a * a + b * b + c * c + d * d > 1e-2
        })
        .prop_map(|(a, b, c, d)| {
            EulerParameters {
                e0: a,
                e1: b,
                e2: c,
                e3: d,
            }
            .normalized()
        })
}

/// A rotation within 1e-8 … 1e-3 rad of a singularity of one of the angle sets: an Euler
/// z-x-z θ of 0 or π, an x-y-z θ of ±π/2, a pitch of ±π/2, or a rotation angle of 0 or π.
fn near_singular() -> impl Strategy<Value = Matrix3<f64>> {
    let offset = (-8.0f64..-3.0).prop_map(|x| 10f64.powf(x));
    (0usize..7, offset, any::<bool>(), -PI..PI, -PI..PI).prop_map(|(kind, off, sign, a, b)| {
        let off = if sign { off } else { -off };
        match kind {
            0 => EulerZxz {
                phi: a,
                theta: off.abs(),
                psi: b,
            }
            .to_matrix(),
            1 => EulerZxz {
                phi: a,
                theta: PI - off.abs(),
                psi: b,
            }
            .to_matrix(),
            2 => EulerXyz {
                phi: a,
                theta: FRAC_PI_2 - off.abs(),
                psi: b,
            }
            .to_matrix(),
            3 => EulerXyz {
                phi: a,
                theta: -FRAC_PI_2 + off.abs(),
                psi: b,
            }
            .to_matrix(),
            4 => Rpy {
                roll: a,
                pitch: FRAC_PI_2 - off.abs(),
                yaw: b,
            }
            .to_matrix(),
            5 => rotation_matrix(&axis(a.cos(), a.sin(), b), off.abs()),
            _ => rotation_matrix(&axis(a.cos(), a.sin(), b), PI - off.abs()),
        }
    })
}

/// Every representation that is defined recomposes to `a` within 12 ulp of 1. An extraction
/// (a square root or atan2 and a few sums) and a recomposition (sines and cosines and two 3×3
/// products) round each entry of magnitude ≤ 1 a dozen times; the worst measured over 4·10⁵
/// random and near-singular rotations is 9 ulp (x-y-z angles near θ = ±π/2).
fn round_trips(a: &Matrix3<f64>) -> Result<(), TestCaseError> {
    const BOUND: f64 = 12.0 * f64::EPSILON;
    let e = EulerParameters::from_matrix(a);
    prop_assert!(e.e0 >= 0.0, "e0 = {}", e.e0);
    prop_assert!(
        max_diff(&e.to_matrix(), a) < BOUND,
        "Euler parameters {}",
        max_diff(&e.to_matrix(), a)
    );
    if let Ok(x) = AxisAngle::from_matrix(a) {
        prop_assert!(
            max_diff(&x.to_matrix(), a) < BOUND,
            "axis-angle {}",
            max_diff(&x.to_matrix(), a)
        );
    }
    if let Ok(x) = EulerZxz::from_matrix(a) {
        prop_assert!(
            max_diff(&x.to_matrix(), a) < BOUND,
            "zxz {}",
            max_diff(&x.to_matrix(), a)
        );
    }
    if let Ok(x) = EulerXyz::from_matrix(a) {
        prop_assert!(
            max_diff(&x.to_matrix(), a) < BOUND,
            "xyz {}",
            max_diff(&x.to_matrix(), a)
        );
    }
    if let Ok(x) = Rpy::from_matrix(a) {
        prop_assert!(
            max_diff(&x.to_matrix(), a) < BOUND,
            "rpy {}",
            max_diff(&x.to_matrix(), a)
        );
    }
    if let Ok(x) = RodriguezParameters::from_matrix(a) {
        prop_assert!(
            max_diff(&x.to_matrix(), a) < BOUND,
            "rodriguez {}",
            max_diff(&x.to_matrix(), a)
        );
    }
    Ok(())
}

proptest! {
    // A fixed seed: the same cases on every run (the regression file replays past failures).
    #![proptest_config(ProptestConfig {
        cases: 2000,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x6b69_6e65),
        ..ProptestConfig::default()
    })]

    #[test]
    fn random_rotations_round_trip(e in random_rotation()) {
        round_trips(&e.to_matrix())?;
    }

    #[test]
    fn near_singular_rotations_round_trip(a in near_singular()) {
        // Orthonormal to rounding, as the strategy builds it (three rounded 3×3 products).
        prop_assert!(max_diff(&(a.transpose() * a), &Matrix3::identity()) < 16.0 * f64::EPSILON);
        round_trips(&a)?;
    }

    /// Eqs. 2.11, 2.19, 2.20, 2.23–2.25 and det A = 1. Each side is a sum of at most four
    /// products of numbers ≤ 1: 4 ulp of 1 bounds its rounding. The formulas assume a unit `e`,
    /// and `e` is unit only to rounding: with `δ = ‖e‖² − 1`, `E Eᵀ = (1 + δ) I`, and the matrix
    /// of eq. 2.11 (diagonal written `1 − 2(…)`) is `R + δ (R − I)` for a rotation `R`, so
    /// `AᵀA − I ≈ δ (2I − R − Rᵀ)` and `det A − 1 ≈ δ (3 − tr R)`, both up to `4|δ|`.
    #[test]
    fn euler_parameter_identities(e in random_rotation()) {
        const ULP: f64 = f64::EPSILON;
        let (a, em, eb) = (e.to_matrix(), e.e_matrix(), e.e_bar_matrix());
        let i3 = Matrix3::identity();
        prop_assert!((e.as_vector().norm() - 1.0).abs() <= 2.0 * ULP);
        let delta = (e.as_vector().norm_squared() - 1.0).abs();
        prop_assert!(max_diff(&(em * eb.transpose()), &a) <= 4.0 * ULP + delta);
        prop_assert!(max_diff(&(em * em.transpose()), &i3) <= 4.0 * ULP + delta);
        prop_assert!(max_diff(&(eb * eb.transpose()), &i3) <= 4.0 * ULP + delta);
        let i4_minus = kinechain::nalgebra::Matrix4::identity() - e.as_vector() * e.as_vector().transpose();
        prop_assert!((em.transpose() * em - i4_minus).abs().max() <= 4.0 * ULP + delta);
        prop_assert!((eb.transpose() * eb - i4_minus).abs().max() <= 4.0 * ULP + delta);
        prop_assert!(max_diff(&(a.transpose() * a), &i3) <= 8.0 * ULP + 4.0 * delta);
        prop_assert!((a.determinant() - 1.0).abs() <= 8.0 * ULP + 4.0 * delta);
    }

    /// Composition: A(p ⊗ q) = A(p) A(q) (the matrix H): two different orders of a few sums of
    /// products, within 8 ulp of 1, plus what the inputs' distance from unit norm adds (as in
    /// `euler_parameter_identities`: each matrix is off a rotation by up to 2|δ| per entry, and
    /// a product of two spreads that over a row: 2|δ_pq| + 2√3 (|δ_p| + |δ_q|) < 6 (|δ_p| + |δ_q|)).
    #[test]
    fn composition_through_h(p in random_rotation(), q in random_rotation()) {
        let delta = |e: &EulerParameters| (e.as_vector().norm_squared() - 1.0).abs();
        let bound = 8.0 * f64::EPSILON + 6.0 * (delta(&p) + delta(&q));
        prop_assert!(max_diff(&p.compose(&q).to_matrix(), &(p.to_matrix() * q.to_matrix())) <= bound);
    }

    /// Each velocity map against a finite difference: along t ↦ coordinates + rates·t, the
    /// matrix's derivative satisfies Ȧ Aᵀ = [ω]x (eq. 2.27) and Aᵀ Ȧ = [ω̄]x (eq. 2.29).
    /// Central difference with h = 1e-6: truncation h²/6 |A'''| ≲ 1e-12, rounding 1e-16/h = 1e-10.
    #[test]
    fn velocity_maps_match_finite_differences(
        e in random_rotation(),
        rates in (-2.0f64..2.0, -2.0f64..2.0, -2.0f64..2.0),
        dt in (-2.0f64..2.0),
    ) {
        let h = 1e-6;
        let tol = 1e-9;
        let vee = |m: Matrix3<f64>| Vector3::new(0.5 * (m[(2, 1)] - m[(1, 2)]), 0.5 * (m[(0, 2)] - m[(2, 0)]), 0.5 * (m[(1, 0)] - m[(0, 1)]));
        let check = |at: &dyn Fn(f64) -> Matrix3<f64>, w: Vector3<f64>, w_bar: Vector3<f64>| -> Result<(), TestCaseError> {
            let a = at(0.0);
            let a_dot = (at(h) - at(-h)) / (2.0 * h);
            prop_assert!((vee(a_dot * a.transpose()) - w).norm() < tol, "ω {} vs {}", vee(a_dot * a.transpose()), w);
            prop_assert!((vee(a.transpose() * a_dot) - w_bar).norm() < tol, "ω̄");
            Ok(())
        };
        // Euler parameters: any ė tangent to the unit sphere.
        let raw = Vector4::new(rates.0, rates.1, rates.2, dt);
        let e_dot = raw - e.as_vector() * e.as_vector().dot(&raw);
        check(&|t| EulerParameters::from_vector(&(e.as_vector() + e_dot * t)).normalized().to_matrix(), e.omega(&e_dot), e.omega_local(&e_dot))?;
        let r_dot = Vector3::new(rates.0, rates.1, rates.2);
        if let Ok(g) = RodriguezParameters::from_euler_parameters(&e)
            && g.0.norm() < 10.0
        {
            check(
                &|t| RodriguezParameters(g.0 + r_dot * t).to_matrix(),
                g.g_matrix() * r_dot,
                g.g_bar_matrix() * r_dot,
            )?;
        }
        let a = e.to_matrix();
        if let Ok(z) = EulerZxz::from_matrix(&a) {
            check(&|t| EulerZxz { phi: z.phi + r_dot.x * t, theta: z.theta + r_dot.y * t, psi: z.psi + r_dot.z * t }.to_matrix(), z.g_matrix() * r_dot, z.g_bar_matrix() * r_dot)?;
        }
        if let Ok(x) = EulerXyz::from_matrix(&a) {
            check(&|t| EulerXyz { phi: x.phi + r_dot.x * t, theta: x.theta + r_dot.y * t, psi: x.psi + r_dot.z * t }.to_matrix(), x.g_matrix() * r_dot, x.g_bar_matrix() * r_dot)?;
        }
    }
}
