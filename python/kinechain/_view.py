"""``Chain.view``: the robot as one self-contained HTML page (``kinechain::io::view`` in Rust
writes it), shown by Jupyter or saved."""

from __future__ import annotations

import html
import os
from typing import Any, Optional, Union

import numpy as np

from ._kinechain import Chain, StateError


class View:
    """A page that draws the robot: a stick figure with every link's frame (RGB triad, name on
    hover) and the joint axes, an orbit camera, a slider per entry of ``q`` within its limits,
    and for a trajectory a timeline with play/pause. The page evaluates the chain itself (no
    server, no network). ``html`` is the page; Jupyter shows it in a frame; ``save(path)`` writes
    it."""

    __slots__ = ("html",)

    def __init__(self, page: str):
        self.html = page

    def _repr_html_(self) -> str:
        return ('<iframe style="width:100%;height:480px;border:1px solid #ddd" '
                f'srcdoc="{html.escape(self.html, quote=True)}"></iframe>')

    def save(self, path: Union[str, "os.PathLike[str]"]) -> None:
        """Writes the page to ``path`` (a new file, or replaces one)."""
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.html)

    def __repr__(self) -> str:
        return f"View({len(self.html)} bytes of HTML)"


def view(self: Chain, q: Any = None, *, times: Optional[Any] = None) -> View:
    """The robot at ``q`` (``(nq,)``; default the neutral configuration), or along a trajectory
    ``q`` of shape ``(N, nq)`` with a timeline (``times``: ``(N,)`` int64 nanoseconds, default
    0.1 s apart), as a :class:`View`. Raises ``StateError`` for a wrong shape, a value that is not
    finite, or a floating or ball joint (the page does not move those yet)."""
    rows = np.atleast_2d(np.asarray(self.neutral() if q is None else q, dtype=np.float64))
    if rows.ndim != 2 or rows.shape[1] != self.nq:
        raise StateError(f"q has shape {np.shape(q)}: expected ({self.nq},) or (N, {self.nq})")
    t = None
    if times is not None:
        t = np.ascontiguousarray(np.asarray(times, dtype=np.int64))
        if t.shape != (rows.shape[0],):
            raise StateError(f"times has shape {t.shape}: expected ({rows.shape[0]},)")
    return View(self._view_html(np.ascontiguousarray(rows), t))


Chain.view = view  # type: ignore[attr-defined]
