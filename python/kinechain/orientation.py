"""Orientation coordinates of rotation matrices (Shabana ch. 2, sec. 2.1-2.8), vectorised over
leading axes: each function takes ``(..., 3, 3)`` rotations, or ``(..., 4, 4)`` poses such as
``Chain.fk(q).poses``, and returns ``(..., k)``. Where a representation is undefined (gimbal
lock for Euler angles, the identity's axis, Rodriguez parameters at a half turn) the row is NaN,
as the command line prints ``null``; every other value recomposes to the matrix within a few ulp.
"""

from __future__ import annotations

import numpy as np

from . import _kinechain
from . import _float_array

__all__ = [
    "quaternion_from_matrix",
    "rpy_from_matrix",
    "euler_zxz_from_matrix",
    "axis_angle_from_matrix",
    "rodrigues_from_matrix",
]


def _convert(kind: str, r) -> np.ndarray:
    return _kinechain._orientation(kind, _float_array(r, "r"))


def quaternion_from_matrix(r) -> np.ndarray:
    """Euler parameters ``(w, x, y, z)`` (eq. 2.10), ``w >= 0``, by Shepperd's method."""
    return _convert("quaternion", r)


def rpy_from_matrix(r) -> np.ndarray:
    """URDF ``(roll, pitch, yaw)``: ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    return _convert("rpy", r)


def euler_zxz_from_matrix(r) -> np.ndarray:
    """Euler angles ``(phi, theta, psi)``: ``R = Rz(phi) Rx(theta) Rz(psi)`` (eq. 2.96)."""
    return _convert("euler_zxz", r)


def axis_angle_from_matrix(r) -> np.ndarray:
    """Unit axis and angle ``(x, y, z, angle)``, angle in ``[0, pi]`` (eqs. 2.9, 2.26)."""
    return _convert("axis_angle", r)


def rodrigues_from_matrix(r) -> np.ndarray:
    """Rodriguez parameters ``(g1, g2, g3) = tan(angle / 2) * axis`` (eq. 2.77)."""
    return _convert("rodrigues", r)
