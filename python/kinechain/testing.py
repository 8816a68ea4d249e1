"""Assertions for test suites: regression tests on link kinematics, usable directly in pytest.

>>> import kinechain as kc, kinechain.testing                             # doctest: +SKIP
>>> kc.testing.assert_same_kinematics(kc.load("arm.yaml"), kc.load("arm.urdf"))  # doctest: +SKIP

Each assertion raises ``AssertionError`` with the report (every link's largest position,
rotation and rate differences, worst first, and the first link along the chain that moved), and
returns the report as a dict when every link is within the tolerances. Problems that make the
check impossible (joints or links missing on one side, a damaged golden file) raise
``kinechain.Error``.
"""

from __future__ import annotations

import json
import os
from typing import Iterable, Mapping, Optional, Union

from . import Chain
from . import _kinechain

__all__ = ["assert_same_kinematics", "assert_matches_golden", "record_golden"]

PathLike = Union[str, "os.PathLike[str]"]


def _links(links: Optional[Iterable[str]]) -> Optional[list]:
    if links is None:
        return None
    return [links] if isinstance(links, str) else list(links)


def _count(x: object, name: str, most: int) -> int:
    """``x`` as an integer in ``[0, most]``, or a ``ValueError``/``TypeError`` naming ``name``."""
    if isinstance(x, bool) or not isinstance(x, (int,)) and not hasattr(x, "__index__"):
        raise TypeError(f"{name} must be an integer, not {type(x).__name__}")
    n = x.__index__()
    if not 0 <= n <= most:
        raise ValueError(f"{name}={n}: expected an integer from 0 to {most}")
    return n


#: The most samples a record or comparison draws (as ``kinechain record --samples``).
MAX_SAMPLES = 1_000_000


def _verdict(result: tuple) -> dict:
    passed, table, report = result
    if not passed:
        raise AssertionError("link kinematics differ\n" + table)
    return json.loads(report)


def assert_same_kinematics(
    chain_a: Chain,
    chain_b: Chain,
    *,
    samples: int = 100,
    seed: int = 1,
    level: str = "pose",
    links: Optional[Iterable[str]] = None,
    tol: float = 1e-9,
    tol_rotation: Optional[float] = None,
    tol_rates: Optional[float] = None,
    rename: Optional[Mapping[str, str]] = None,
) -> dict:
    """Asserts that ``chain_b`` places every link it shares with ``chain_a`` (by name) where
    ``chain_a`` does, at ``samples`` seeded configurations within ``chain_a``'s limits (plus zero
    and the limit corners where admitted), joints matched by name. Both chains must have the same
    joints; ``rename={"old": "new"}`` matches the joint ``old`` of ``chain_a`` to ``new`` of
    ``chain_b``. ``level``: ``"pose"``, ``"vel"`` or ``"acc"``. ``tol``: metres (and radians and
    rates unless given apart)."""
    renames = None if rename is None else [(str(k), str(v)) for k, v in dict(rename).items()]
    return _verdict(
        _kinechain._compare(
            chain_a,
            chain_b,
            _count(samples, "samples", MAX_SAMPLES),
            _count(seed, "seed", 2**64 - 1),
            str(level),
            _links(links),
            float(tol),
            float(tol if tol_rotation is None else tol_rotation),
            float(tol if tol_rates is None else tol_rates),
            renames,
        )
    )


def assert_matches_golden(
    chain: Chain,
    path: PathLike,
    *,
    tol: float = 1e-9,
    tol_rotation: Optional[float] = None,
    tol_rates: Optional[float] = None,
) -> dict:
    """Asserts that ``chain`` matches the golden file ``path`` (written by ``record_golden`` or
    ``kinechain record``) at every recorded configuration, joints matched by name."""
    return _verdict(
        _kinechain._verify_golden(
            chain,
            os.fspath(path),
            float(tol),
            float(tol if tol_rotation is None else tol_rotation),
            float(tol if tol_rates is None else tol_rates),
        )
    )


def record_golden(
    chain: Chain,
    path: PathLike,
    *,
    samples: int = 100,
    seed: int = 1,
    level: str = "pose",
    links: Optional[Iterable[str]] = None,
) -> None:
    """Writes the golden file ``path``: the same bytes as ``kinechain record ROBOT -o path``, by
    the same rules: never over the chain's own robot file; a FIFO or device written in place; a
    regular file replaced whole (keeping its permissions), through a symbolic link to it."""
    _kinechain._record_golden(chain, os.fspath(path), _count(samples, "samples", MAX_SAMPLES),
                              _count(seed, "seed", 2**64 - 1), str(level), _links(links))
