"""Joint logs as robots write them: ROS bags (MCAP) and LeRobot datasets, read into tables that
``kinechain.table.poses`` turns into link poses.

>>> log = kc.logs.joint_states("run.mcap", topic="/joint_states")          # doctest: +SKIP
>>> out = kc.table.poses(log, chain, links=["panda_hand"])                  # doctest: +SKIP
>>> out = kc.logs.lerobot("so101_pick", chain, units="deg", links=["gripper"])  # doctest: +SKIP

Bags are read in Rust (the ``mcap`` crate inside the extension: no ROS, no other package),
chunk by chunk, with zstd and lz4 chunks decompressed and their CRCs checked. LeRobot datasets
need ``pyarrow`` (``pip install "kinechain[table]"``).
"""

from __future__ import annotations

import glob
import json
import os
import warnings
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import Chain
from ._kinechain import LogError, StateError, _read_joint_states
from . import table as _table

__all__ = ["joint_states", "write_tf", "lerobot", "lerobot_names", "lerobot_files", "LogError"]

PathLike = Union[str, "os.PathLike[str]"]


def joint_states(
    path: PathLike,
    topic: str = "/joint_states",
    *,
    time: str = "header",
    missing: str = "hold",
    velocities: bool = False,
    efforts: bool = False,
    truncated: str = "raise",
    to: str = "arrow",
) -> Any:
    """The ``sensor_msgs/JointState`` messages of ``topic`` in the MCAP file ``path`` (a ROS 2
    bag, or a ROS 1 bag converted to MCAP) as a table of one row per message, in file order:

    - ``time``: int64 nanoseconds, the message's ``header.stamp`` (``time="header"``) or the
      time the recorder logged it (``time="log"``);
    - one float64 column per joint name met in the topic, in the order first met (the names
      ``kinechain.table.poses`` looks for);
    - with ``velocities``, ``NAME.velocity`` columns; with ``efforts``, ``NAME.effort``.

    Drivers publish subsets of the joints, in any order, and several publishers may share a
    topic: each message's values go to the columns its ``name`` list gives, and a joint a message
    does not carry holds its last value (``missing="hold"``) or is null (``missing="null"``);
    before a joint's first value it is null either way.

    A file cut off in the middle of a record (a killed recording) raises ``LogError`` naming the
    messages read; ``truncated="keep"`` returns the messages before the cut, with a warning.
    A missing topic (the error lists the bag's topics and types), another message type on the
    topic, and a malformed message (named by its index and log time) raise ``LogError``.

    Returns a pyarrow Table (``to="arrow"``; nulls where a value is not known) or a pandas
    DataFrame (``to="pandas"``; NaN)."""
    if truncated not in ("raise", "keep"):
        raise ValueError(f"truncated {truncated!r}: expected 'raise' or 'keep'")
    if to not in ("arrow", "pandas"):
        raise ValueError(f"to {to!r}: expected 'arrow' or 'pandas'")
    if time not in ("header", "log"):
        raise ValueError(f"time {time!r}: expected 'header' or 'log'")
    if missing not in ("hold", "null"):
        raise ValueError(f"missing {missing!r}: expected 'hold' or 'null'")
    names, stamps, position, velocity, effort, cut = _read_joint_states(
        os.fspath(path), topic, time, missing, velocities, efforts, truncated == "keep")
    if cut:
        warnings.warn(f"{os.fspath(path)}: the file ends in the middle of a record; the {len(stamps)} "
                      f"messages of {topic} before the cut are read", RuntimeWarning, stacklevel=2)
    if "time" in names:
        raise LogError(f"{os.fspath(path)}: topic {topic} has a joint named 'time', the name of the time column")
    columns: Dict[str, np.ndarray] = {"time": stamps}
    blocks = [(position, "")]
    if velocity is not None:
        blocks.append((velocity, ".velocity"))
    if effort is not None:
        blocks.append((effort, ".effort"))
    for values, suffix in blocks:
        for k, name in enumerate(names):
            columns[name + suffix] = values[:, k]
    if to == "pandas":
        import pandas as pd

        return pd.DataFrame(columns)
    import pyarrow as pa

    arrays = []
    for name, values in columns.items():
        if name == "time":
            arrays.append(pa.array(values, type=pa.int64()))
        else:
            nan = np.isnan(values)
            arrays.append(pa.array(values, type=pa.float64(), mask=nan if nan.any() else None))
    return pa.Table.from_arrays(arrays, names=list(columns))


def _info(dataset_dir: PathLike) -> Dict[str, Any]:
    path = os.path.join(os.fspath(dataset_dir), "meta", "info.json")
    try:
        with open(path, encoding="utf-8") as f:
            info = json.load(f)
    except FileNotFoundError:
        raise LogError(f"{os.fspath(dataset_dir)} is not a LeRobot dataset: no meta/info.json") from None
    except (OSError, ValueError) as e:
        raise LogError(f"cannot read {path}: {e}") from None
    if not isinstance(info, dict) or not isinstance(info.get("features"), dict):
        raise LogError(f"{path}: no 'features' object (a LeRobot dataset's info.json lists its features)")
    return info


def _feature_names(info: Dict[str, Any], column: str, path: str) -> List[str]:
    """The names of the entries of ``column`` as ``info.json`` lists them (a list, or LeRobot
    v2's ``{"motors": [...]}``)."""
    features = info["features"]
    if column not in features:
        raise LogError(f"{path}: no feature {column!r} (features: {', '.join(features)})")
    names = features[column].get("names")
    if isinstance(names, dict) and len(names) == 1:
        names = next(iter(names.values()))
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise LogError(f"{path}: feature {column!r} does not name its entries "
                       "(give names=[...] with one name per entry)")
    return names


def lerobot_names(
    dataset_dir: PathLike,
    chain: Chain,
    column: str = "observation.state",
    names: Union[None, Sequence[Optional[str]], Mapping[str, Optional[str]]] = None,
) -> List[Optional[str]]:
    """Which joint of ``chain`` each entry of the dataset's ``column`` is (None: not a joint):
    the names ``meta/info.json`` gives, with LeRobot's ``.pos`` suffix dropped where the name
    without it is a joint of the chain (``shoulder_pan.pos`` → ``shoulder_pan``). ``names``
    replaces them (a list, one per entry) or renames some (a mapping from the dataset's name to a
    joint, or to None to ignore the entry)."""
    path = os.path.join(os.fspath(dataset_dir), "meta", "info.json")
    if names is not None and not isinstance(names, Mapping):
        return list(names)
    listed = _feature_names(_info(dataset_dir), column, path)
    joints = set(chain.q_names)
    out: List[Optional[str]] = []
    for n in listed:
        if isinstance(names, Mapping) and n in names:
            out.append(names[n])
        elif n not in joints and n.endswith(".pos") and n[:-4] in joints:
            out.append(n[:-4])
        else:
            out.append(n)
    if isinstance(names, Mapping):
        unknown = [k for k in names if k not in listed]
        if unknown:
            raise LogError(f"{path}: names renames {', '.join(map(repr, unknown))}, which {column!r} does not have "
                           f"(its entries: {', '.join(listed)})")
    return out


def lerobot_files(dataset_dir: PathLike) -> List[str]:
    """The dataset's Parquet data files (``data/chunk-*/file-*.parquet`` in LeRobot v3,
    ``data/chunk-*/episode_*.parquet`` in v2), in order."""
    root = os.path.join(os.fspath(dataset_dir), "data")
    files = sorted(glob.glob(os.path.join(root, "**", "*.parquet"), recursive=True))
    if not files:
        raise LogError(f"{os.fspath(dataset_dir)}: no Parquet files under data/")
    return files


def lerobot(
    dataset_dir: PathLike,
    chain: Chain,
    column: str = "observation.state",
    *,
    names: Union[None, Sequence[Optional[str]], Mapping[str, Optional[str]]] = None,
    units: str = "rad",
    calibration: Optional[Mapping[str, Any]] = None,
    fixed: Optional[Mapping[str, float]] = None,
    links: Any = None,
    orientation: str = "quaternion",
    columns: Optional[Sequence[str]] = None,
    on_error: str = "raise",
    threads: Optional[int] = None,
    to: str = "arrow",
) -> Any:
    """A LeRobot dataset (v3, or v2: ``meta/info.json`` and Parquet files under ``data/``) with
    the poses of ``links`` added: ``column`` (a list column, ``observation.state`` by default)
    read as joint values through :func:`lerobot_names`, ``units`` (``"deg"`` for the SO-100/101
    arms), ``calibration`` and ``fixed`` as ``kinechain.table.poses`` takes them. ``columns``
    selects the dataset's columns to read and carry (default: all). Returns a pyarrow Table
    (``to="pandas"``: a DataFrame)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if to not in ("arrow", "pandas"):
        raise ValueError(f"to {to!r}: expected 'arrow' or 'pandas'")
    mapped = lerobot_names(dataset_dir, chain, column, names)
    read = None if columns is None else list(dict.fromkeys([*columns, column]))
    parts = []
    for f in lerobot_files(dataset_dir):
        try:
            parts.append(pq.read_table(f, columns=read))
        except (OSError, pa.ArrowException, KeyError) as e:
            raise LogError(f"cannot read {f}: {e}") from None
    data = pa.concat_tables(parts) if len(parts) > 1 else parts[0]
    out = _table.poses(data, chain, links, orientation, q_column=column, names=mapped, units=units,
                       calibration=calibration, fixed=fixed, on_error=on_error, threads=threads)
    return out.to_pandas() if to == "pandas" else out



def write_tf(
    chain: Chain,
    source: Any,
    path: PathLike,
    *,
    topic: str = "/joint_states",
    time: str = "time",
    q_column: Optional[str] = None,
    names: Any = None,
    units: str = "rad",
    calibration: Optional[Mapping[str, Any]] = None,
    fixed: Optional[Mapping[str, float]] = None,
    frame_prefix: str = "",
    world_frame: str = "world",
) -> Dict[str, int]:
    """Writes what ``robot_state_publisher`` would have published for a joint log to the MCAP
    file ``path`` (a ROS 2 bag that Foxglove, Lichtblick, RViz through ``ros2 bag play`` and
    Rerun read): ``/tf`` (``tf2_msgs/msg/TFMessage``, one message per row, stamped with its time,
    one transform per moving joint: parent link → child link), ``/tf_static`` (the fixed joints,
    once, recorded transient local) and ``/robot_description`` (``std_msgs/msg/String``: the
    URDF the chain was read from, or the one ``kinechain convert`` writes for the other formats).

    ``source`` is the path of a ROS bag (the ``sensor_msgs/JointState`` messages of ``topic``),
    or a table (pandas or pyarrow: a LeRobot episode's Parquet file, a log) with a ``time``
    column — int64 nanoseconds, or float seconds (LeRobot's ``timestamp``) — and the joint
    values ``kinechain.table.poses`` reads (``q_column``, ``names``, ``units``, ``calibration``,
    ``fixed`` as there). Rows whose joint values are not all known are left out. Frame ids are
    link names after ``frame_prefix``; a floating base moves in ``world_frame``. ``path`` is
    never one of the files read.

    Returns ``{"messages": …, "moving": …, "fixed": …}``. Raises ``LogError`` for an unreadable
    bag or one that lacks a joint, ``StateError`` for a table that lacks one or a row the chain
    refuses (named by index and time)."""
    inputs: List[str] = []
    if isinstance(source, (str, os.PathLike)):
        inputs.append(os.fspath(source))
        bag = joint_states(source, topic, to="arrow")
        if bag.num_rows == 0:
            # An empty topic names no joints: the file still gets the static frames.
            messages, moving, fixed_joints = chain._write_tf(np.zeros(0, np.int64), np.zeros((0, chain.nq)), os.fspath(path), inputs,
                                                             frame_prefix, world_frame)
            return {"messages": messages, "moving": moving, "fixed": fixed_joints}
        lacking = [n for n in chain.q_names if n not in bag.column_names]
        if lacking:
            raise LogError(f"{os.fspath(source)}: topic {topic} has no joint {lacking[0]!r} "
                           f"(it has {', '.join(c for c in bag.column_names if c != 'time')})")
        source, time = bag, "time"
    arrow = _table._is_arrow(source)
    column_names = list(source.column_names) if arrow else [str(c) for c in source.columns]
    if time not in column_names:
        raise StateError(f"no column {time!r} for the time (columns: {', '.join(column_names)})")
    stamps = np.asarray(source.column(time).to_numpy(zero_copy_only=False) if arrow else source[time].to_numpy())
    if stamps.dtype.kind == "f":
        stamps = np.round(stamps * 1e9)
    stamps = stamps.astype(np.int64)
    q, _, _ = _table._joint_values(source, chain, q_column, arrow, names, units, calibration, fixed)
    known = ~np.isnan(q).any(axis=1)
    stamps, q = stamps[known], np.ascontiguousarray(q[known])
    messages, moving, fixed_joints = chain._write_tf(np.ascontiguousarray(stamps), q, os.fspath(path), inputs, frame_prefix,
                                                     world_frame)
    return {"messages": messages, "moving": moving, "fixed": fixed_joints}
