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
import warnings
from typing import Any, Union

import numpy as np

from ._kinechain import Chain, Error, FkResult, LoadError, LogError, StateError, __version__, _expand_xacro

__all__ = ["Chain", "Error", "FkResult", "IkResult", "LoadError", "LogError", "StateError", "View", "expand_xacro", "load", "logs", "orientation", "table", "testing", "__version__"]


def _xacro_keywords(args: Any, package_paths: Any) -> tuple:
    """``args`` (a mapping of names to values, each made text as on xacro's command line) and
    ``package_paths`` as the extension takes them."""
    if args is not None and not hasattr(args, "items"):
        raise TypeError("args must be a mapping of xacro argument names to values")
    pairs = None if args is None else [(str(k), _arg_text(v)) for k, v in args.items()]
    if isinstance(package_paths, (str, os.PathLike)):
        package_paths = [package_paths]
    paths = None if package_paths is None else [os.fspath(p) for p in package_paths]
    return pairs, paths


def _arg_text(v: Any) -> str:
    """A xacro argument's text: ``True``/``False`` as ``true``/``false``, numbers as Python
    writes them."""
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def load(
    path: Union[str, "os.PathLike[str]"],
    *,
    floating_base: bool = False,
    couplings: bool = False,
    args: Any = None,
    package_paths: Any = None,
) -> Chain:
    """Loads a robot file: a DH table (``.yaml``/``.yml``), a URDF file (``.urdf``), a xacro
    file (``.xacro``, ``.urdf.xacro``: expanded in Rust, no ROS needed) or a MuJoCo MJCF file
    (``.xml``; ``q`` is then MuJoCo's ``qpos``, entry for entry, and ``chain.keyframes`` holds
    its ``<key>`` configurations).

    For xacro, ``args`` gives the arguments (``{"ur_type": "ur5e"}``, as ``ur_type:=ur5e`` on
    xacro's command line) and ``package_paths`` directories that hold the ROS packages that
    ``$(find PKG)`` names (searched first; then ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``
    and the directories above the file).

    With ``floating_base``, a floating joint ``root_joint`` is added between the world and the
    robot's root link (a humanoid's or a quadruped's base, as Pinocchio's
    ``JointModelFreeFlyer``): ``q`` then starts with its position and quaternion (w, x, y, z),
    ``qd`` with its velocity and angular velocity in world axes.

    With ``couplings`` (MJCF), each linear ``<equality><joint>`` coupling makes its first joint
    follow the second (a mimic joint, with no entry of ``q``), so that ``q`` holds the leaders.

    What the loader noticed without refusing the file (``chain.warnings``) is issued as a
    ``UserWarning`` each.

    Raises ``LoadError`` (naming the file, line, column and joint) if it cannot be read."""
    pairs, paths = _xacro_keywords(args, package_paths)
    chain = Chain.from_file(
        os.fspath(path), floating_base=floating_base, couplings=couplings, args=pairs, package_paths=paths
    )
    for message in chain.warnings:
        warnings.warn(f"{os.fspath(path)}: {message}", stacklevel=2)
    return chain


def expand_xacro(path: Union[str, "os.PathLike[str]"], *, args: Any = None, package_paths: Any = None) -> str:
    """The URDF text that the xacro file ``path`` expands to, as ROS 2's ``xacro`` writes it
    (``args`` and ``package_paths`` as for :func:`load`). The expression language is closed:
    a description file cannot run code, and only reads includes and YAML files under the
    package directories or beside the file.

    Raises ``LoadError`` naming the file, line and column, and the macro calls and includes
    that led there."""
    pairs, paths = _xacro_keywords(args, package_paths)
    return _expand_xacro(os.fspath(path), pairs, paths)


def _float_array(x: Any, name: str) -> np.ndarray:
    """``x`` as a C-contiguous float64 array (no copy when it already is one)."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise StateError(f"{name} cannot be read as float64 numbers: {e}") from None
    if a.ndim == 0:
        raise StateError(f"{name} has shape (): expected (dof,) or (N, dof)")
    return np.ascontiguousarray(a)


from . import logs, orientation, table, testing  # noqa: E402  (joint logs; orientation coordinates; tables; assertions for test suites)
from ._ik import IkResult  # noqa: E402  (adds Chain.ik)
from ._view import View  # noqa: E402  (adds Chain.view)
