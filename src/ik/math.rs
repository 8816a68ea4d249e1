//! The small dense algebra of a step: rotation logarithm and right Jacobian of SO(3),
//! quaternions, and the Cholesky solve of the damped normal equations.

/// Solves `A x = b` in place (`b` ← `x`) for a symmetric positive definite `A` of order `m`,
/// given by its lower triangle, row-major (overwritten by its Cholesky factor). False when `A`
/// is not positive definite in rounding. The systems here are of order 6 to a few dozen, for
/// which a general library's dynamic-size decomposition spends more on its generality than on
/// the arithmetic (measured: a third of a solve's time with `nalgebra`'s).
pub(super) fn cholesky_solve(a: &mut [f64], m: usize, b: &mut [f64]) -> bool {
    for i in 0..m {
        for j in 0..=i {
            let mut sum = a[i * m + j];
            for k in 0..j {
                sum -= a[i * m + k] * a[j * m + k];
            }
            if i == j {
                if sum.is_nan() || sum <= 0.0 {
                    return false;
                }
                a[i * m + i] = sum.sqrt();
            } else {
                a[i * m + j] = sum / a[j * m + j];
            }
        }
    }
    // L y = b, then Lᵀ x = y.
    for i in 0..m {
        let mut sum = b[i];
        for k in 0..i {
            sum -= a[i * m + k] * b[k];
        }
        b[i] = sum / a[i * m + i];
    }
    for i in (0..m).rev() {
        let mut sum = b[i];
        for k in i + 1..m {
            sum -= a[k * m + i] * b[k];
        }
        b[i] = sum / a[i * m + i];
    }
    true
}

/// [`cholesky_solve`] for order 6, `A` by its lower triangle in rows padded to eight lanes, with
/// one division per row. Every loop has constant bounds (the inner ones masked), so that the
/// factorisation unrolls into straight-line code.
#[allow(clippy::needless_range_loop)] // the indices are the algorithm's, as in `cholesky_solve`
#[inline(always)]
pub(super) fn cholesky_solve6(a: &mut [[f64; 8]; 6], b: &mut [f64; 6]) -> bool {
    let mut inv = [0.0; 6];
    for j in 0..6 {
        // Column j: its diagonal, then the entries below it.
        let mut d = a[j][j];
        for k in 0..6 {
            if k < j {
                d -= a[j][k] * a[j][k];
            }
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        a[j][j] = d;
        inv[j] = 1.0 / d;
        for i in 0..6 {
            if i > j {
                let mut sum = a[i][j];
                for k in 0..6 {
                    if k < j {
                        sum -= a[i][k] * a[j][k];
                    }
                }
                a[i][j] = sum * inv[j];
            }
        }
    }
    for i in 0..6 {
        let mut sum = b[i];
        for k in 0..6 {
            if k < i {
                sum -= a[i][k] * b[k];
            }
        }
        b[i] = sum * inv[i];
    }
    for i in (0..6).rev() {
        let mut sum = b[i];
        for k in 0..6 {
            if k > i {
                sum -= a[k][i] * b[k];
            }
        }
        b[i] = sum * inv[i];
    }
    true
}

crate::eval::simd::isa::fma_dispatch!(avx2 pub(super) fn step6(j: &[f64], held: &[bool], lambda: f64, e: &[f64], step: &mut [f64]) -> bool => step6_generic);

/// The damped step of one six-row goal, `step = J̃ᵀ (J̃ J̃ᵀ + λ I)⁻¹ e` (`J̃`: `j`, six rows by
/// columns, with the `held` columns zeroed). False, with a zero step, if the system cannot be
/// solved. Compiled per instruction set (wider vectors, no fused operations: the same bits on
/// every CPU).
#[inline(always)]
#[allow(clippy::extra_unused_type_parameters)] // `fma_dispatch` names one per instruction set
fn step6_generic<A>(j: &[f64], held: &[bool], lambda: f64, e: &[f64], step: &mut [f64]) -> bool {
    // J̃ J̃ᵀ + λ I, a sum of the columns' outer products, by rows padded to eight lanes (constant
    // bounds: it stays in vector registers).
    let mut a = [[0.0; 8]; 6];
    for (col, held) in j.chunks_exact(6).zip(held) {
        let mut c = [0.0; 8];
        if !*held {
            c[..6].copy_from_slice(col);
        }
        for (row, x) in a.iter_mut().zip(c) {
            for (y, z) in row.iter_mut().zip(c) {
                *y += x * z;
            }
        }
    }
    for (k, row) in a.iter_mut().enumerate() {
        row[k] += lambda;
    }
    let mut y = [0.0; 6];
    y.copy_from_slice(&e[..6]);
    if !cholesky_solve6(&mut a, &mut y) {
        step.fill(0.0);
        return false;
    }
    for ((s, col), held) in step.iter_mut().zip(j.chunks_exact(6)).zip(held) {
        *s = if *held {
            0.0
        } else {
            col[0] * y[0]
                + col[1] * y[1]
                + col[2] * y[2]
                + col[3] * y[3]
                + col[4] * y[4]
                + col[5] * y[5]
        };
    }
    true
}

pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `Rᵀ u` for a rotation stored by columns.
pub(super) fn transpose_apply(r: &[[f64; 3]; 3], u: [f64; 3]) -> [f64; 3] {
    [
        r[0][0] * u[0] + r[0][1] * u[1] + r[0][2] * u[2],
        r[1][0] * u[0] + r[1][1] * u[1] + r[1][2] * u[2],
        r[2][0] * u[0] + r[2][1] * u[1] + r[2][2] * u[2],
    ]
}

/// `Aᵀ B` for rotations stored by columns: column `j` is `Aᵀ b_j`.
pub(super) fn mul_tr(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    [
        transpose_apply(a, b[0]),
        transpose_apply(a, b[1]),
        transpose_apply(a, b[2]),
    ]
}

/// `A Bᵀ` for rotations stored by columns (entry `(i, j)` is `Σ_k A_ik B_jk`), by columns.
pub(super) fn mul_rt(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (j, column) in m.iter_mut().enumerate() {
        for (i, x) in column.iter_mut().enumerate() {
            *x = a[0][i] * b[0][j] + a[1][i] * b[1][j] + a[2][i] * b[2][j];
        }
    }
    m
}

/// The rotation vector `θ n` of a rotation matrix (stored by columns): `log` of SO(3), with
/// `θ ∈ [0, π]`; near `θ = π`, the axis from the diagonal (where `R − Rᵀ` loses it).
pub(crate) fn rotation_log(r: &[[f64; 3]; 3]) -> [f64; 3] {
    let at = |i: usize, j: usize| r[j][i];
    let w = [
        at(2, 1) - at(1, 2),
        at(0, 2) - at(2, 0),
        at(1, 0) - at(0, 1),
    ];
    let trace = at(0, 0) + at(1, 1) + at(2, 2);
    let c = (0.5 * (trace - 1.0)).clamp(-1.0, 1.0);
    let s = 0.5 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt();
    let theta = s.atan2(c);
    if c > -0.99 {
        // θ / (2 sin θ), its series where sin θ vanishes with θ.
        let f = if theta < 1e-4 {
            0.5 + theta * theta / 12.0
        } else {
            0.5 * theta / s
        };
        return w.map(|x| f * x);
    }
    // n nᵀ = (R + Rᵀ)/2 − c I over (1 − c): the largest diagonal entry gives a safe component.
    let k = (0..3)
        .max_by(|&a, &b| at(a, a).total_cmp(&at(b, b)))
        .unwrap_or(0);
    let nk = ((at(k, k) - c) / (1.0 - c)).max(0.0).sqrt();
    let mut n = [0.0; 3];
    for (i, x) in n.iter_mut().enumerate() {
        *x = if i == k {
            nk
        } else {
            0.5 * (at(i, k) + at(k, i)) / ((1.0 - c) * nk)
        };
    }
    // The sign that makes sin θ n agree with (R − Rᵀ)/2.
    if n[0] * w[0] + n[1] * w[1] + n[2] * w[2] < 0.0 {
        n = n.map(|x| -x);
    }
    let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|x| theta * x / norm)
}

/// `J_r⁻¹(φ) = I + ½ φ^ + (1/θ² − (1 + cos θ)/(2 θ sin θ)) φ^ φ^`, θ = |φ|, rows by rows.
pub(super) fn right_jacobian_inverse(phi: [f64; 3]) -> [[f64; 3]; 3] {
    let t2 = phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2];
    let theta = t2.sqrt();
    let c = if theta < 1e-4 {
        1.0 / 12.0 + t2 / 720.0
    } else {
        let (s, co) = theta.sin_cos();
        1.0 / t2 - (1.0 + co) / (2.0 * theta * s)
    };
    let [x, y, z] = phi;
    // φ^ φ^ = φ φᵀ − θ² I.
    let mut m = [
        [1.0, -0.5 * z, 0.5 * y],
        [0.5 * z, 1.0, -0.5 * x],
        [-0.5 * y, 0.5 * x, 1.0],
    ];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, e) in row.iter_mut().enumerate() {
            *e += c * (phi[i] * phi[j] - if i == j { t2 } else { 0.0 });
        }
    }
    m
}

/// `M u` for a matrix stored by rows.
pub(super) fn mat3_apply(m: &[[f64; 3]; 3], u: [f64; 3]) -> [f64; 3] {
    m.map(|row| row[0] * u[0] + row[1] * u[1] + row[2] * u[2])
}

/// The unit quaternion (w, x, y, z) of the rotation vector `d`.
pub(super) fn quat_exp(d: [f64; 3]) -> [f64; 4] {
    let angle = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let (s, c) = (0.5 * angle).sin_cos();
    let f = if angle < 1e-8 { 0.5 } else { s / angle };
    [c, f * d[0], f * d[1], f * d[2]]
}

/// Hamilton product `a ⊗ b` (w, x, y, z): the rotation `b`, then `a`.
pub(super) fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]
}

pub(super) fn normalize4(q: [f64; 4]) -> [f64; 4] {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    q.map(|x| x / n)
}
