//! The textbook baseline both benchmarks time: one 4×4 matrix per DH row, multiplied with
//! `nalgebra::Matrix4`.

use kinechain::nalgebra::Matrix4;

/// The transform of one DH row with joint angle `theta` and offset `d`: the modified (Craig)
/// convention of eq. (2.129), or the standard one, `Rz(θ) Tz(d) Tx(a) Rx(α)`.
pub fn dh_matrix(modified: bool, a: f64, alpha: f64, d: f64, theta: f64) -> Matrix4<f64> {
    let (st, ct) = theta.sin_cos();
    let (sa, ca) = alpha.sin_cos();
    if modified {
        Matrix4::new(
            ct,
            -st,
            0.0,
            a,
            st * ca,
            ct * ca,
            -sa,
            -d * sa,
            st * sa,
            ct * sa,
            ca,
            d * ca,
            0.0,
            0.0,
            0.0,
            1.0,
        )
    } else {
        Matrix4::new(
            ct,
            -st * ca,
            st * sa,
            a * ct,
            st,
            ct * ca,
            -ct * sa,
            a * st,
            0.0,
            sa,
            ca,
            d,
            0.0,
            0.0,
            0.0,
            1.0,
        )
    }
}
