//! `kinechain.orientation`'s compiled half: orientation coordinates (sec. 2.1–2.8) of arrays
//! of rotation matrices, through the core's `orientation` module.

use crate::arrays::{entries, new_array};
use crate::errors::{Error, StateError};
use numpy::{PyArrayDyn, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Orientation coordinates of every rotation in `r` (shape `(..., 3, 3)`, or `(..., 4, 4)`
/// poses whose rotation block is read): `quaternion` (w, x, y, z: Euler parameters),
/// `rpy` (roll, pitch, yaw), `euler_zxz` (φ, θ, ψ), `axis_angle` (x, y, z, angle) or
/// `rodrigues` (γ1, γ2, γ3); NaN where the coordinates are undefined (gimbal lock, the identity's
/// axis, Rodriguez parameters at θ = π), as the command line prints `null`.
#[pyfunction]
pub(crate) fn _orientation<'py>(
    py: Python<'py>,
    kind: &str,
    r: PyReadonlyArrayDyn<'py, f64>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    use kinechain::nalgebra::Matrix3;
    use kinechain::orientation::{AxisAngle, EulerParameters, EulerZxz, RodriguezParameters, Rpy};
    let shape = r.shape().to_vec();
    let side = match shape.as_slice() {
        [.., 3, 3] => 3,
        [.., 4, 4] => 4,
        _ => {
            return Err(StateError::new_err(format!(
                "rotations of shape {shape:?}: expected (..., 3, 3) or (..., 4, 4)"
            )));
        }
    };
    let width = match kind {
        "quaternion" | "axis_angle" => 4,
        "rpy" | "euler_zxz" | "rodrigues" => 3,
        other => {
            return Err(Error::new_err(format!(
                "orientation '{other}': expected quaternion, rpy, euler_zxz, axis_angle or rodrigues"
            )));
        }
    };
    let values = r.as_slice()?;
    if let Some(bad) = values.iter().position(|x| !x.is_finite()) {
        return Err(StateError::new_err(format!(
            "rotation entry {bad} (flat index) is not finite"
        )));
    }
    let mut dims = shape[..shape.len() - 2].to_vec();
    dims.push(width);
    // Every entry is written below.
    let out = new_array(py, numpy::ndarray::IxDyn(&dims))?;
    // SAFETY: a new array, not yet handed out; every entry is written below.
    let dst = unsafe { entries(&out)? };
    for (m, d) in values
        .chunks_exact(side * side)
        .zip(dst.chunks_exact_mut(width))
    {
        let a = Matrix3::from_fn(|i, j| m[i * side + j]);
        let nan = [f64::NAN; 4];
        let v: [f64; 4] = match kind {
            "quaternion" => {
                let e = EulerParameters::from_matrix(&a);
                [e.e0, e.e1, e.e2, e.e3]
            }
            "rpy" => Rpy::from_matrix(&a).map_or(nan, |x| [x.roll, x.pitch, x.yaw, 0.0]),
            "euler_zxz" => EulerZxz::from_matrix(&a).map_or(nan, |x| [x.phi, x.theta, x.psi, 0.0]),
            "axis_angle" => {
                AxisAngle::from_matrix(&a).map_or(nan, |x| [x.axis.x, x.axis.y, x.axis.z, x.angle])
            }
            _ => RodriguezParameters::from_matrix(&a).map_or(nan, |x| [x.0.x, x.0.y, x.0.z, 0.0]),
        };
        d.copy_from_slice(&v[..width]);
    }
    Ok(out)
}
