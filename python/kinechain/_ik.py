"""``Chain.ik``: inverse kinematics (the solver is ``kinechain::ik`` in Rust; this module reads
the shapes of the targets and makes the result)."""

from __future__ import annotations

from typing import Any, Optional, Sequence, Union

import numpy as np

from ._kinechain import Chain, Error, StateError

_POSE_ONLY = (1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
_POSITION_ONLY = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)


class IkResult:
    """What :meth:`Chain.ik` found, for one row of targets or ``N`` rows.

    ``q``: ``(nq,)`` or ``(N, nq)``, within every joint's limits, the best found where no solution
    was; ``success``: every target within the tolerances (a bool, or ``(N,)``);
    ``position_error`` (m) and ``rotation_error`` (rad): each target's residual, ``()`` / ``(N,)``
    for one link, ``(k,)`` / ``(N, k)`` for a list of ``k`` links; ``iterations`` and
    ``restarts``: the search's, an int or ``(N,)``."""

    __slots__ = ("q", "success", "position_error", "rotation_error", "iterations", "restarts")

    def __init__(self, q, success, position_error, rotation_error, iterations, restarts):
        self.q = q
        self.success = success
        self.position_error = position_error
        self.rotation_error = rotation_error
        self.iterations = iterations
        self.restarts = restarts

    def __repr__(self) -> str:
        s = np.asarray(self.success)
        if s.ndim == 0:
            return (
                f"IkResult(success={bool(s)}, position_error={self.position_error!r}, "
                f"rotation_error={self.rotation_error!r}, iterations={self.iterations})"
            )
        return f"IkResult({int(s.sum())} of {s.size} solved)"


def _targets(target: Any, name: str) -> tuple:
    """One goal's targets as ``(n or None, (n, 4, 4) array, position_only)``."""
    try:
        a = np.asarray(target, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise StateError(f"target of '{name}' cannot be read as float64 numbers: {e}") from None
    if a.shape == (4, 4):
        return None, a.reshape(1, 4, 4), False
    if a.ndim == 3 and a.shape[1:] == (4, 4):
        return a.shape[0], a, False
    if a.shape == (3,) or (a.ndim == 2 and a.shape[1] == 3):
        p = a.reshape(-1, 3)
        m = np.tile(np.eye(4), (p.shape[0], 1, 1))
        m[:, :3, 3] = p
        return (None if a.ndim == 1 else a.shape[0]), m, True
    raise StateError(
        f"target of '{name}' has shape {a.shape}: expected (4, 4) or (N, 4, 4) poses, (3,) or (N, 3) positions"
    )


def _per_link(value: Any, k: int, what: str, several: bool) -> list:
    if not several:
        return [value]
    if value is None:
        return [None] * k
    if isinstance(value, (str, bytes)) or len(value) != k:
        raise Error(f"{what} must be a list of {k} entries, one per link, when link is a list")
    return list(value)


def ik(
    self: Chain,
    target: Any,
    link: Union[str, Sequence[str]],
    q0: Any = None,
    *,
    base: Any = None,
    point: Any = None,
    weights: Any = None,
    threads: Optional[int] = None,
    seed: int = 0,
    position_tolerance: float = 1e-6,
    rotation_tolerance: float = 1e-6,
    iterations: int = 40,
    max_attempts: int = 100,
    time_limit: Optional[float] = None,
    closest: Optional[str] = None,
    locked: Optional[Sequence[str]] = None,
    start: str = "mid",
) -> IkResult:
    """Joint values that put ``link`` at ``target``: Levenberg–Marquardt on the pose error, with
    joint limits held at every step and seeded restarts (``kinechain::ik``; docs/library.md).

    ``target``: a ``(4, 4)`` pose or ``(N, 4, 4)`` poses, or a ``(3,)`` / ``(N, 3)`` position (the
    orientation then free). Several links: ``link`` a list and ``target`` a list of as many
    targets (all one row, or all ``N`` rows). ``base``: the link whose frame a target is given in
    (``None``: the world). ``point``: link coordinates of the point placed (default the origin).
    ``weights``: six weights ``[x, y, z, rx, ry, rz]`` along the target's axes (0 frees a
    component: ``[1, 1, 1, 1, 1, 0]`` leaves the turn about the target's z axis free). With a list
    of links, ``base``, ``point`` and ``weights`` are lists too.

    ``q0``: the seed, ``(nq,)`` or ``(N, nq)`` (default: mid-limits, or ``start="neutral"``), within
    the limits. Success: every target within ``position_tolerance`` (m) and ``rotation_tolerance``
    (rad). Attempts end after ``iterations`` steps or when they stall; up to ``max_attempts``,
    restarting from configurations drawn with ``seed``; ``time_limit`` (s) stops earlier (and
    makes results depend on the machine). ``closest="l2"`` or ``"linf"`` keeps searching through
    every attempt for the solution closest to ``q0``. ``locked``: names of joints kept at ``q0``.

    Rows run on all cores (``threads``) without the GIL; Ctrl-C stops them. The same inputs give
    the same bits on any number of threads, alone or in a batch. No solution is not an error:
    ``success`` is False and ``q`` the best found. Raises ``StateError`` for targets that are not
    rigid transforms or a seed that is out of limits or of the wrong length, ``Error`` for unknown
    links or joints and bad options."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**64:
        raise Error(f"seed must be an integer in [0, 2**64), not {seed!r}")
    if (
        type(link) is str
        and type(target) is np.ndarray
        and target.shape == (4, 4)
        and target.dtype == np.float64
        and base is None
        and point is None
        and weights is None
        and (q0 is None or (type(q0) is np.ndarray and q0.ndim == 1))
    ):
        # One pose of one link: the common call, without the general shape handling.
        q, success, pe, re, its, rs = self._ik(
            [link], [None], [(0.0, 0.0, 0.0)], [_POSE_ONLY], target, 1,
            None if q0 is None else q0.reshape(1, -1),
            seed=int(seed), threads=threads,
            position_tolerance=float(position_tolerance), rotation_tolerance=float(rotation_tolerance),
            iterations=int(iterations), max_attempts=int(max_attempts), time_limit=time_limit,
            closest=closest, locked=list(locked or ()), start=start,
        )
        return IkResult(q[0], bool(success[0]), pe[0, 0], re[0, 0], int(its[0]), int(rs[0]))
    several = not isinstance(link, str)
    links = list(link) if several else [link]
    if several and (not isinstance(target, (list, tuple)) or len(target) != len(links)):
        raise Error(f"with {len(links)} links, target must be a list of {len(links)} targets")
    targets = list(target) if several else [target]
    parsed = [_targets(t, name) for t, name in zip(targets, links)]
    rows = {p[0] for p in parsed}
    if len(rows) != 1:
        raise StateError(f"the targets differ in their number of rows: {sorted(rows, key=str)}")
    n_rows = rows.pop()
    n = 1 if n_rows is None else n_rows
    bases = _per_link(base, len(links), "base", several)
    points = [(0.0, 0.0, 0.0) if p is None else tuple(float(x) for x in np.asarray(p, dtype=float).reshape(3))
              for p in _per_link(point, len(links), "point", several)]
    ws = []
    for w, (_, _, position_only) in zip(_per_link(weights, len(links), "weights", several), parsed):
        if w is None:
            ws.append(_POSITION_ONLY if position_only else _POSE_ONLY)
        else:
            w = np.asarray(w, dtype=float)
            if w.shape != (6,):
                raise Error(f"weights has shape {w.shape}: expected 6 weights [x, y, z, rx, ry, rz]")
            ws.append(tuple(float(x) for x in w))
    stacked = np.ascontiguousarray(np.stack([p[1] for p in parsed], axis=1))  # (n, k, 4, 4)
    seeds = None
    if q0 is not None:
        seeds = np.asarray(q0, dtype=np.float64)
        if seeds.ndim == 1 and n_rows is not None:
            seeds = np.tile(seeds, (n, 1))
        seeds = np.ascontiguousarray(seeds)
        if seeds.ndim == 2 and n_rows is None and seeds.shape[0] != 1:
            raise StateError(f"q0 has shape {seeds.shape} for one row of targets: expected ({self.nq},)")
    q, success, pe, re, its, rs = self._ik(
        links, list(bases), points, ws, stacked, n, seeds,
        seed=int(seed), threads=threads,
        position_tolerance=float(position_tolerance), rotation_tolerance=float(rotation_tolerance),
        iterations=int(iterations), max_attempts=int(max_attempts), time_limit=time_limit,
        closest=closest, locked=list(locked or []), start=start,
    )
    if not several:
        pe, re = pe[:, 0], re[:, 0]
    if n_rows is None:
        return IkResult(q[0], bool(success[0]), pe[0], re[0], int(its[0]), int(rs[0]))
    return IkResult(q, success, pe, re, its, rs)


Chain.ik = ik  # type: ignore[attr-defined]
