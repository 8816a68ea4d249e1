"""Forward kinematics of robot chains: poses, velocities, accelerations and Jacobians of every
link, from Denavit-Hartenberg YAML or URDF files, with numpy arrays in and out.

>>> import kinechain as kc
>>> chain = kc.load("robots/ur5.yaml")            # doctest: +SKIP
>>> r = chain.fk(chain.neutral())                  # doctest: +SKIP
>>> r["tool0"]                                      # doctest: +SKIP

Units are radians, metres and seconds; every quantity is in the world (base) frame; ``q`` lists
the independent joints in ``chain.joint_names`` order. A 2-D ``q`` (one configuration per row)
is evaluated in Rust with the GIL released, on all cores unless ``threads`` says otherwise.
"""

from __future__ import annotations

import os
from typing import Any, Iterable, Optional, Sequence, Union

import numpy as np

from ._kinechain import Chain, Error, LoadError, StateError, __version__

__all__ = ["Chain", "Error", "FkResult", "LoadError", "StateError", "load", "orientation", "testing", "__version__"]


def load(path: Union[str, "os.PathLike[str]"]) -> Chain:
    """Loads a robot file: a DH table (``.yaml``/``.yml``) or a URDF file (``.urdf``).

    Raises ``LoadError`` (naming the file, line, column and joint) if it cannot be read."""
    return Chain.from_file(os.fspath(path))


class FkResult:
    """What ``Chain.fk`` computed, as numpy arrays whose second-to-last axes follow ``links``.

    ``poses``: ``(L, 4, 4)`` or ``(N, L, 4, 4)`` homogeneous transforms ``world_from_link``.
    With ``qd``: ``omega`` (angular velocity) and ``v`` (velocity of the link origin),
    ``(L, 3)`` or ``(N, L, 3)``. With ``qd`` and ``qdd``: ``alpha`` (angular acceleration) and
    ``a`` (classical acceleration of the link origin, d²p/dt²). Absent quantities are ``None``.
    ``r[name]`` is one link's pose, ``(4, 4)`` or ``(N, 4, 4)``.
    """

    __slots__ = ("links", "poses", "omega", "v", "alpha", "a", "_index")

    def __init__(self, values: dict) -> None:
        self.links: list = values["links"]
        self.poses: np.ndarray = values["poses"]
        self.omega: Optional[np.ndarray] = values.get("omega")
        self.v: Optional[np.ndarray] = values.get("v")
        self.alpha: Optional[np.ndarray] = values.get("alpha")
        self.a: Optional[np.ndarray] = values.get("a")
        self._index = {name: i for i, name in enumerate(self.links)}

    def __getitem__(self, link: str) -> np.ndarray:
        try:
            i = self._index[link]
        except KeyError:
            raise KeyError(f"no link named {link!r} in this result (links: {', '.join(self.links)})") from None
        return self.poses[..., i, :, :]

    def __len__(self) -> int:
        return len(self.links)

    def __repr__(self) -> str:
        have = [k for k in ("omega", "v", "alpha", "a") if getattr(self, k) is not None]
        return f"FkResult(links={len(self.links)}, poses={self.poses.shape}" + "".join(f", {k}" for k in have) + ")"


def _float_array(x: Any, name: str) -> np.ndarray:
    """``x`` as a C-contiguous float64 array (no copy when it already is one)."""
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise StateError(f"{name} cannot be read as float64 numbers: {e}") from None
    if a.ndim == 0:
        raise StateError(f"{name} has shape (): expected (dof,) or (N, dof)")
    return np.ascontiguousarray(a)


def _fk(
    self: Chain,
    q: Any,
    qd: Any = None,
    qdd: Any = None,
    *,
    links: Optional[Iterable[str]] = None,
    check_limits: bool = True,
    threads: Optional[int] = None,
) -> FkResult:
    q = _float_array(q, "q")
    qd = None if qd is None else _float_array(qd, "qd")
    qdd = None if qdd is None else _float_array(qdd, "qdd")
    if isinstance(links, str):
        links = [links]
    links = None if links is None else list(links)
    return FkResult(self._fk(q, qd, qdd, links, bool(check_limits), _threads(threads)))


def _jacobian(
    self: Chain,
    q: Any,
    link: str,
    *,
    check_limits: bool = True,
    threads: Optional[int] = None,
) -> np.ndarray:
    return self._jacobian(_float_array(q, "q"), str(link), bool(check_limits), _threads(threads))


def _threads(threads: Optional[int]) -> Optional[int]:
    if threads is None:
        return None
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
        raise Error(f"threads must be a positive integer, not {threads!r}")
    return int(threads)


_fk.__doc__ = """Poses (and with ``qd``, ``qdd`` velocities and accelerations) of the links.

``q``, ``qd``, ``qdd``: ``(dof,)`` for one configuration or ``(N, dof)`` for N, any array-like
convertible to float64. ``links``: only these links (in this order), computing only what they
need; default every link. ``check_limits``: refuse values outside the joint limits (the
default, as the command line does). ``threads``: threads of a 2-D evaluation (default: all
cores). Returns an ``FkResult``. Raises ``StateError`` (naming the configuration and joint) for
wrong shapes, non-finite or out-of-limit values, ``Error`` for an unknown link."""
_jacobian.__doc__ = """The geometric Jacobian of ``link`` at its origin, world frame: ``(6, dof)`` or
``(N, 6, dof)``, rows ``v`` then ``omega``, so that ``[v; omega] = J @ qd``.

``check_limits`` and ``threads`` as for ``fk``."""

Chain.fk = _fk  # type: ignore[attr-defined]
Chain.jacobian = _jacobian  # type: ignore[attr-defined]

from . import orientation, testing  # noqa: E402  (orientation coordinates; assertions for test suites)
