"""Link poses for tables of joint values: pandas DataFrames, pyarrow Tables, and through
``map_partitions`` Dask DataFrames.

>>> out = kc.table.poses(df, chain, links=["panda_hand"], orientation="quaternion")   # doctest: +SKIP
>>> ddf.map_partitions(kc.table.poses, chain, links=["panda_hand"],
...                    meta=kc.table.poses_meta(ddf._meta, chain, links=["panda_hand"]))  # doctest: +SKIP

Joint values come from one float64 column per entry of ``q``, named as ``chain.q_names``
(a cylindrical joint's as ``NAME.theta`` and ``NAME.d``, a floating base's as
``root_joint.x`` … ``root_joint.qz``), or from one list column
(``q_column=``). Every other column is carried through unchanged, in order; after them come, for
each link asked for, ``<link>.x``, ``<link>.y``, ``<link>.z`` and its orientation:
``quaternion`` → ``<link>.qw .qx .qy .qz``; ``matrix`` → ``<link>.r00`` … ``<link>.r22``;
``rpy`` → ``<link>.roll .pitch .yaw`` (NaN at gimbal lock).

Rows whose values are not finite or out of limits are an error naming the row and the joint;
with ``on_error="null"`` their pose columns are null and the other rows are computed. Rows are
evaluated in chunks through the batch engine, without the GIL, on all cores unless ``threads``
says otherwise; the values equal ``chain.fk`` on the same rows bit for bit.
"""

from __future__ import annotations

import re
from typing import Any, Iterable, List, Optional, Tuple

import numpy as np

from . import Chain, Error, StateError
from . import orientation as _orientation

__all__ = ["poses", "poses_meta", "pose_columns"]

#: Rows evaluated per call into the batch engine (bounds the memory of all links' poses).
CHUNK_ROWS = 1 << 16

_ORIENTATION = {
    "quaternion": ["qw", "qx", "qy", "qz"],
    "matrix": [f"r{i}{j}" for i in range(3) for j in range(3)],
    "rpy": ["roll", "pitch", "yaw"],
}


def pose_columns(chain: Chain, links: Optional[Iterable[str]] = None, orientation: str = "quaternion") -> List[str]:
    """The names of the columns ``poses`` adds, in order."""
    if orientation not in _ORIENTATION:
        raise ValueError(f"orientation {orientation!r}: expected one of {', '.join(_ORIENTATION)}")
    names = chain.link_names if links is None else _link_list(links)
    return [f"{link}.{c}" for link in names for c in ["x", "y", "z"] + _ORIENTATION[orientation]]


def _link_list(links: Iterable[str]) -> List[str]:
    return [links] if isinstance(links, str) else list(links)


def _is_arrow(table: Any) -> bool:
    try:
        import pyarrow as pa
    except ImportError:
        return False
    return isinstance(table, pa.Table)


def _joint_values(table: Any, chain: Chain, q_column: Optional[str], arrow: bool) -> np.ndarray:
    """The table's joint values as an ``(N, nq)`` float64 array (NaN where null)."""
    names = chain.q_names
    n = table.num_rows if arrow else len(table)
    if q_column is not None:
        if q_column not in (table.column_names if arrow else table.columns):
            raise StateError(f"no column {q_column!r} for q (columns: {', '.join(map(str, _columns(table, arrow)))})")
        values = table.column(q_column).to_pylist() if arrow else list(table[q_column])
        q = np.full((n, chain.nq), np.nan)
        for i, row in enumerate(values):
            if row is None:
                continue
            row = np.asarray(row, dtype=np.float64)
            if row.shape != (chain.nq,):
                raise StateError(f"row {i}: {q_column} has {row.size} values; the chain takes {chain.nq} (in order: {', '.join(names)})")
            q[i] = row
        return q
    columns = _columns(table, arrow)
    doubled = sorted({j for j in names if columns.count(j) > 1})
    if doubled:
        raise StateError(f"the table has more than one column for joints {', '.join(map(repr, doubled))}: "
                         "which one holds the joint's values is ambiguous (rename or drop the others)")
    missing = [j for j in names if j not in columns]
    if missing:
        raise StateError(f"no column for joints {', '.join(map(repr, missing))} (give one float64 column per entry of q, named as chain.q_names, or q_column=)")
    q = np.empty((n, chain.nq))
    for k, j in enumerate(names):
        if arrow:
            col = table.column(j)
            q[:, k] = col.to_numpy(zero_copy_only=False).astype(np.float64) if col.null_count == 0 else \
                np.array([np.nan if v is None else v for v in col.to_pylist()], dtype=np.float64)
        else:
            q[:, k] = table[j].to_numpy(dtype=np.float64, na_value=np.nan)
    return q


def _is_pandas(table: Any) -> bool:
    try:
        import pandas as pd
    except ImportError:
        return False
    return isinstance(table, pd.DataFrame)


def _columns(table: Any, arrow: bool) -> List[Any]:
    return list(table.column_names if arrow else table.columns)


_CONFIGURATION = re.compile(r"^configuration (\d+): ")


def _chunk_poses(chain: Chain, part: np.ndarray, start: int, links: Optional[List[str]], threads: Optional[int],
                 rows: np.ndarray, null: bool) -> Tuple[np.ndarray, np.ndarray]:
    """The poses of the rows ``part`` (the table's rows ``rows[start:]``) and which of them are
    defined. A row whose poses overflow (finite joint values so large that a position is not)
    is an error naming the table's row, or with ``null`` a row left undefined."""
    try:
        return chain.fk(part, links=links, threads=threads).poses, np.ones(len(part), dtype=bool)
    except StateError as e:
        m = _CONFIGURATION.match(str(e))
        if m is None:
            raise
        if not null:
            raise StateError(f"row {int(rows[start + int(m.group(1))])}: {str(e)[m.end():]}") from None
    nlinks = len(chain.link_names if links is None else links)
    # Undefined rows hold the identity until their values are set to NaN (orientation
    # coordinates are not taken of NaN matrices).
    p = np.tile(np.eye(4), (len(part), nlinks, 1, 1))
    defined = np.ones(len(part), dtype=bool)
    for i, qi in enumerate(part):
        try:
            p[i] = chain.fk(qi, links=links).poses
        except StateError:
            defined[i] = False
    return p, defined


def _pose_values(chain: Chain, q: np.ndarray, links: Optional[List[str]], orientation: str,
                 threads: Optional[int], rows: np.ndarray, null: bool) -> Tuple[np.ndarray, np.ndarray]:
    """``(N, L * k)``: each row's pose columns, in ``pose_columns`` order; and which rows are
    defined (see ``_chunk_poses``). ``rows``: each row's number in the table."""
    n = q.shape[0]
    width = 3 + len(_ORIENTATION[orientation])
    nlinks = len(chain.link_names if links is None else links)
    out = np.empty((n, nlinks, width))
    defined = np.ones(n, dtype=bool)
    for start in range(0, n, CHUNK_ROWS):
        part = q[start:start + CHUNK_ROWS]
        p, d = _chunk_poses(chain, part, start, links, threads, rows, null)
        defined[start:start + len(part)] = d
        block = out[start:start + len(part)]
        block[..., :3] = p[..., :3, 3]
        if orientation == "quaternion":
            block[..., 3:] = _orientation.quaternion_from_matrix(p)
        elif orientation == "rpy":
            block[..., 3:] = _orientation.rpy_from_matrix(p)
        else:
            block[..., 3:] = p[..., :3, :3].reshape(p.shape[:-2] + (9,))
        block[~d] = np.nan
    return out.reshape(n, nlinks * width), defined


def poses(
    table: Any,
    chain: Chain,
    links: Optional[Iterable[str]] = None,
    orientation: str = "quaternion",
    *,
    q_column: Optional[str] = None,
    on_error: str = "raise",
    threads: Optional[int] = None,
) -> Any:
    """``table`` (pandas DataFrame or pyarrow Table) with each link's pose added as columns; the
    same kind of table is returned. See the module's documentation."""
    if on_error not in ("raise", "null"):
        raise ValueError(f"on_error {on_error!r}: expected 'raise' or 'null'")
    links = None if links is None else _link_list(links)
    names = pose_columns(chain, links, orientation)
    arrow = _is_arrow(table)
    if not arrow and not _is_pandas(table):
        raise TypeError(f"table must be a pandas DataFrame or a pyarrow Table, not {type(table).__name__} "
                        "(for an array of joint values, use chain.fk)")
    clash = [c for c in names if c in set(map(str, _columns(table, arrow)))]
    if clash:
        raise Error(f"the table already has columns {', '.join(map(repr, clash[:5]))}{' …' if len(clash) > 5 else ''}: "
                    "refusing to add a second column of the same name")
    q = _joint_values(table, chain, q_column, arrow)
    ok = chain._admitted(q) if len(q) else np.ones(0, dtype=bool)
    if not ok.all() and on_error == "raise":
        i = int(np.flatnonzero(~ok)[0])
        try:
            chain.fk(q[i])
        except StateError as e:
            label = "" if arrow or table.index[i] == i else f" (index {table.index[i]!r})"
            raise StateError(f"row {i}{label}: {e}") from None
    values = np.full((len(q), len(names)), np.nan)
    null = on_error == "null"
    if ok.all():
        values, ok = _pose_values(chain, q, links, orientation, threads, np.arange(len(q)), null)
    elif ok.any():
        rows = np.flatnonzero(ok)
        values[ok], ok[rows] = _pose_values(chain, q[ok], links, orientation, threads, rows, null)
    if arrow:
        import pyarrow as pa

        mask = None if ok.all() else ~ok
        for k, name in enumerate(names):
            table = table.append_column(name, pa.array(values[:, k], type=pa.float64(), mask=mask))
        return table
    import pandas as pd

    added = pd.DataFrame(values, columns=names, index=table.index)
    return pd.concat([table, added], axis=1)


def poses_meta(meta: Any, chain: Chain, links: Optional[Iterable[str]] = None, orientation: str = "quaternion",
               **kwargs: Any) -> Any:
    """The empty result ``poses`` gives for the empty table ``meta`` (a Dask DataFrame's
    ``_meta``): what ``map_partitions`` needs as ``meta=``. Same arguments as ``poses``."""
    return poses(meta.iloc[:0] if hasattr(meta, "iloc") else meta.slice(0, 0), chain, links, orientation, **kwargs)
