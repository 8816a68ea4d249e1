"""Link poses for tables of joint values: pandas DataFrames, pyarrow Tables, and through
``map_partitions`` Dask DataFrames.

>>> out = kc.table.poses(df, chain, links=["panda_hand"], orientation="quaternion")   # doctest: +SKIP
>>> ddf.map_partitions(kc.table.poses, chain, links=["panda_hand"],
...                    meta=kc.table.poses_meta(ddf._meta, chain, links=["panda_hand"]))  # doctest: +SKIP

Joint values come from one float64 column per entry of ``q``, named as ``chain.q_names``
(a cylindrical joint's as ``NAME.theta`` and ``NAME.d``, a floating base's as
``root_joint.x`` … ``root_joint.qz``), or from one list column (``q_column=``: an Arrow
``fixed_size_list``, ``list`` or ``large_list`` of float32 or float64, or a pandas column of
sequences, read from its buffers without a loop over rows). Every other column is carried
through unchanged, in order; after them come, for
each link asked for, ``<link>.x``, ``<link>.y``, ``<link>.z`` and its orientation:
``quaternion`` → ``<link>.qw .qx .qy .qz``; ``matrix`` → ``<link>.r00`` … ``<link>.r22``;
``rpy`` → ``<link>.roll .pitch .yaw`` (NaN at gimbal lock).

Logs name their joints otherwise and use other units:

- ``names=[...]`` with ``q_column``: the joint each entry of the list is (entries whose name is
  not an entry of ``chain.q_names``, or None, are ignored: a gripper's command, a force);
  without ``q_column``, ``names={column: joint}`` for columns named otherwise.
- Joints of the chain that nothing names are an error listing them, unless ``fixed={joint:
  value}`` holds them at a value (in the chain's units).
- ``units="deg"``: every angle of ``q`` (``chain.q_units`` says which entries are ``"rad"``) is
  read in degrees, ``q = np.deg2rad(value)``; prismatic entries stay metres.
  ``calibration={joint: (scale, offset)}``: ``q = value * scale + offset`` for that joint, in place
  of ``units`` (a gripper logged as 0–100 %, an encoder's zero).

A list column's null rows, rows of another length and rows holding a null value are an error
naming the row (or, with ``on_error="null"``, rows whose pose columns are null).

Rows whose values are not finite or out of limits are an error naming the row and the joint;
with ``on_error="null"`` their pose columns are null and the other rows are computed. Rows are
evaluated in chunks through the batch engine, without the GIL, on all cores unless ``threads``
says otherwise; the values equal ``chain.fk`` on the same rows bit for bit.
"""

from __future__ import annotations

import re
from typing import Any, Iterable, List, Mapping, Optional, Tuple

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


def _list_values(table: Any, column: str, arrow: bool, width: int) -> Tuple[np.ndarray, np.ndarray, List[str]]:
    """The list column ``column`` as an ``(N, width)`` float64 array, read from its Arrow buffers
    without a loop over rows; which rows are bad (null, another length, a null value), NaN in
    the array; and for the first few bad rows, what is wrong."""
    import pyarrow as pa

    try:
        col = table.column(column) if arrow else pa.array(table[column], from_pandas=True)
    except (pa.ArrowException, TypeError, ValueError) as e:
        raise StateError(f"column {column!r} cannot be read as lists of numbers: {e}") from None
    arr = col.combine_chunks() if isinstance(col, pa.ChunkedArray) else col
    t = arr.type
    n = len(arr)
    if pa.types.is_null(t):
        # (Every row null: also what pandas gives for an empty column, as in a Dask meta frame.)
        length = np.zeros(n, dtype=np.int64)
        starts = np.zeros(n, dtype=np.int64)
        child = pa.array([], pa.float64())
    elif pa.types.is_fixed_size_list(t):
        length = np.full(n, t.list_size, dtype=np.int64)
        starts = (np.arange(n, dtype=np.int64) + arr.offset) * t.list_size
        child = arr.values
    elif pa.types.is_list(t) or pa.types.is_large_list(t):
        offsets = np.asarray(arr.offsets, dtype=np.int64)
        length = np.diff(offsets)
        starts = offsets[:-1]
        child = arr.values
    else:
        raise StateError(f"column {column!r} holds {t}, not lists of numbers "
                         "(fixed_size_list, list or large_list of float32 or float64)")
    if not (pa.types.is_floating(child.type) or pa.types.is_integer(child.type)):
        raise StateError(f"column {column!r} holds lists of {child.type}, not of numbers")
    flat = child.to_numpy(zero_copy_only=False).astype(np.float64, copy=False)
    bad = length != width
    if arr.null_count:
        bad |= ~arr.is_valid().to_numpy(zero_copy_only=False)
    if child.null_count:
        # Rows that hold a null value: the null values' positions, found in their rows.
        holes = np.flatnonzero(~child.is_valid().to_numpy(zero_copy_only=False))
        row = np.searchsorted(starts, holes, side="right") - 1
        inside = (row >= 0) & (holes < starts[np.clip(row, 0, None)] + length[np.clip(row, 0, None)])
        bad[row[inside]] = True
    good = ~bad
    if good.all() and n and (starts[-1] - starts[0]) == (n - 1) * width:
        q = flat[starts[0]:starts[0] + n * width].reshape(n, width)
    else:
        q = np.full((n, width), np.nan)
        if good.any():
            q[good] = flat[starts[good][:, None] + np.arange(width)]
    problems = []
    for i in np.flatnonzero(bad)[:3]:
        if arr.null_count and not arr[int(i)].is_valid:
            problems.append(f"row {i}: {column} is null")
        elif length[i] != width:
            problems.append(f"row {i}: {column} has {length[i]} values; {width} expected")
        else:
            problems.append(f"row {i}: {column} holds a null value")
    return q, bad, problems


def _joint_values(table: Any, chain: Chain, q_column: Optional[str], arrow: bool, names: Any, units: str,
                  calibration: Optional[Mapping[str, Any]], fixed: Optional[Mapping[str, float]]
                  ) -> Tuple[np.ndarray, np.ndarray, List[str]]:
    """The table's joint values as an ``(N, nq)`` float64 array (NaN where null), in the chain's
    units; which rows are bad (a list column's null rows and rows of another length); and what
    is wrong with the first of them."""
    joints = chain.q_names
    n = table.num_rows if arrow else len(table)
    columns = _columns(table, arrow)
    if q_column is not None:
        if q_column not in columns:
            raise StateError(f"no column {q_column!r} for q (columns: {', '.join(map(str, columns))})")
        if names is not None and (isinstance(names, (str, Mapping)) or not isinstance(names, Iterable)):
            raise TypeError("names= with q_column is a list: the joint each entry of the list is (None for none)")
        entries = joints if names is None else list(names)
        raw, bad, problems = _list_values(table, q_column, arrow, len(entries))
        if names is None and problems:
            problems[0] += f" (in order: {', '.join(joints)}; or give names=[...])"
        sources = {}
        for k, e in enumerate(entries):
            if e in sources:
                raise StateError(f"names gives joint {e!r} twice (entries {sources[e]} and {k} of {q_column})")
            if e is not None:
                sources[e] = k
        take = lambda j: raw[:, sources[j]]  # noqa: E731
    else:
        if names is not None and not isinstance(names, Mapping):
            raise TypeError("names= without q_column is a mapping {column: joint} for columns named otherwise; "
                            "a list of names is for the entries of q_column")
        renamed = {} if names is None else {str(v): k for k, v in names.items() if v is not None}
        for c, j in ([] if names is None else names.items()):
            if c not in columns:
                raise StateError(f"names maps column {c!r} to joint {j!r}, but the table has no column {c!r}")
        wanted = [renamed.get(j, j) for j in joints]
        doubled = sorted({c for c in wanted if columns.count(c) > 1}, key=str)
        if doubled:
            raise StateError(f"the table has more than one column for joints {', '.join(map(repr, doubled))}: "
                             "which one holds the joint's values is ambiguous (rename or drop the others)")
        sources = {j: c for j, c in zip(joints, wanted) if c in columns}
        bad, problems = np.zeros(n, dtype=bool), []

        def take(j: str) -> np.ndarray:
            c = sources[j]
            if arrow:
                col = table.column(c)
                if col.null_count == 0:
                    return col.to_numpy(zero_copy_only=False).astype(np.float64)
                return np.array([np.nan if v is None else v for v in col.to_pylist()], dtype=np.float64)
            return table[c].to_numpy(dtype=np.float64, na_value=np.nan)

    fixed = dict(fixed or {})
    unknown = [j for j in list(fixed) + list(calibration or {}) if j not in joints]
    if unknown:
        raise StateError(f"fixed/calibration name {', '.join(map(repr, unknown))}, not entries of q "
                         f"(chain.q_names: {', '.join(joints)})")
    missing = [j for j in joints if j not in sources and j not in fixed]
    if missing:
        where = f"no entry of {q_column!r} is named" if q_column is not None else "no column for"
        ignored = [e for e in sources if e not in joints]
        raise StateError(f"{where} joints {', '.join(map(repr, missing))}"
                         + (f" (entries not joints of the chain, ignored: {', '.join(map(repr, ignored))})" if ignored else "")
                         + "; give their values with fixed={joint: value}"
                         + ("" if q_column is not None else ", map columns with names={column: joint}, or q_column="))
    if units not in ("rad", "deg"):
        raise ValueError(f"units {units!r}: expected 'rad' or 'deg'")
    q = np.empty((n, chain.nq))
    unit = chain.q_units
    for k, j in enumerate(joints):
        if j not in sources:
            q[:, k] = float(fixed[j])
            continue
        x = take(j)
        if calibration is not None and j in calibration:
            scale, offset = calibration[j]
            q[:, k] = x * float(scale) + float(offset)
        elif units == "deg" and unit[k] == "rad":
            q[:, k] = np.deg2rad(x)
        else:
            q[:, k] = x
    return q, bad, problems


def _row_label(table: Any, i: int, arrow: bool) -> str:
    """`` (index X)`` after ``row i`` where a DataFrame's index differs from its row number."""
    if arrow or table.index[i] == i:
        return ""
    label = table.index[i]
    return f" (index {label.item() if isinstance(label, np.generic) else label!r})"


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
    names: Any = None,
    units: str = "rad",
    calibration: Optional[Mapping[str, Any]] = None,
    fixed: Optional[Mapping[str, float]] = None,
    on_error: str = "raise",
    threads: Optional[int] = None,
) -> Any:
    """``table`` (pandas DataFrame or pyarrow Table) with each link's pose added as columns; the
    same kind of table is returned. See the module's documentation."""
    if on_error not in ("raise", "null"):
        raise ValueError(f"on_error {on_error!r}: expected 'raise' or 'null'")
    links = None if links is None else _link_list(links)
    added_names = pose_columns(chain, links, orientation)
    arrow = _is_arrow(table)
    if not arrow and not _is_pandas(table):
        raise TypeError(f"table must be a pandas DataFrame or a pyarrow Table, not {type(table).__name__} "
                        "(for an array of joint values, use chain.fk)")
    clash = [c for c in added_names if c in set(map(str, _columns(table, arrow)))]
    if clash:
        raise Error(f"the table already has columns {', '.join(map(repr, clash[:5]))}{' …' if len(clash) > 5 else ''}: "
                    "refusing to add a second column of the same name")
    q, bad, problems = _joint_values(table, chain, q_column, arrow, names, units, calibration, fixed)
    if problems and on_error == "raise":
        i = int(np.flatnonzero(bad)[0])
        label = _row_label(table, i, arrow)
        raise StateError(problems[0].replace(f"row {i}:", f"row {i}{label}:", 1) + " (on_error='null' leaves such rows null)")
    ok = chain._admitted(q) if len(q) else np.ones(0, dtype=bool)
    if not ok.all() and on_error == "raise":
        i = int(np.flatnonzero(~ok)[0])
        try:
            chain.fk(q[i])
        except StateError as e:
            label = _row_label(table, i, arrow)
            raise StateError(f"row {i}{label}: {e}") from None
    values = np.full((len(q), len(added_names)), np.nan)
    null = on_error == "null"
    if ok.all():
        values, ok = _pose_values(chain, q, links, orientation, threads, np.arange(len(q)), null)
    elif ok.any():
        rows = np.flatnonzero(ok)
        values[ok], ok[rows] = _pose_values(chain, q[ok], links, orientation, threads, rows, null)
    if arrow:
        import pyarrow as pa

        mask = None if ok.all() else ~ok
        for k, name in enumerate(added_names):
            table = table.append_column(name, pa.array(values[:, k], type=pa.float64(), mask=mask))
        return table
    import pandas as pd

    added = pd.DataFrame(values, columns=added_names, index=table.index)
    return pd.concat([table, added], axis=1)


def poses_meta(meta: Any, chain: Chain, links: Optional[Iterable[str]] = None, orientation: str = "quaternion",
               **kwargs: Any) -> Any:
    """The empty result ``poses`` gives for the empty table ``meta`` (a Dask DataFrame's
    ``_meta``): what ``map_partitions`` needs as ``meta=``. Same arguments as ``poses``."""
    return poses(meta.iloc[:0] if hasattr(meta, "iloc") else meta.slice(0, 0), chain, links, orientation, **kwargs)
