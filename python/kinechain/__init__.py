"""Forward kinematics of robot chains: poses, velocities, accelerations and Jacobians of every
link, from Denavit-Hartenberg YAML or URDF files, with numpy arrays in and out.

>>> import kinechain as kc
>>> chain = kc.load("robots/ur5.yaml")            # doctest: +SKIP
>>> r = chain.fk(chain.neutral())                  # doctest: +SKIP
>>> r["tool0"]                                      # doctest: +SKIP

Units are radians, metres and seconds; every quantity is in the world (base) frame; ``q`` lists
the independent joints in ``chain.q_names`` order (a floating base's position and quaternion
first). A 2-D ``q`` (one configuration per row)
is evaluated in Rust with the GIL released, on all cores unless ``threads`` says otherwise.
"""

from __future__ import annotations

import os
from typing import Any, Union

import numpy as np

from ._kinechain import Chain, Error, FkResult, LoadError, StateError, __version__

__all__ = ["Chain", "Error", "FkResult", "LoadError", "StateError", "load", "orientation", "table", "testing", "__version__"]


def load(
    path: Union[str, "os.PathLike[str]"], *, floating_base: bool = False, couplings: bool = False
) -> Chain:
    """Loads a robot file: a DH table (``.yaml``/``.yml``), a URDF file (``.urdf``) or a
    MuJoCo MJCF file (``.xml``; ``q`` is then MuJoCo's ``qpos``, entry for entry, and
    ``chain.keyframes`` holds its ``<key>`` configurations).

    With ``floating_base``, a floating joint ``root_joint`` is added between the world and the
    robot's root link (a humanoid's or a quadruped's base, as Pinocchio's
    ``JointModelFreeFlyer``): ``q`` then starts with its position and quaternion (w, x, y, z),
    ``qd`` with its velocity and angular velocity in world axes.

    With ``couplings`` (MJCF), each linear ``<equality><joint>`` coupling makes its first joint
    follow the second (a mimic joint, with no entry of ``q``), so that ``q`` holds the leaders.

    Raises ``LoadError`` (naming the file, line, column and joint) if it cannot be read."""
    return Chain.from_file(os.fspath(path), floating_base=floating_base, couplings=couplings)


def _float_array(x: Any, name: str) -> np.ndarray:
    """``x`` as a C-contiguous float64 array (no copy when it already is one)."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise StateError(f"{name} cannot be read as float64 numbers: {e}") from None
    if a.ndim == 0:
        raise StateError(f"{name} has shape (): expected (dof,) or (N, dof)")
    return np.ascontiguousarray(a)


from . import orientation, table, testing  # noqa: E402  (orientation coordinates; tables; assertions for test suites)
