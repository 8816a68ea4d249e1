"""kinechain.table on pandas, pyarrow and a Dask LocalCluster: a generated Parquet dataset of
joint logs, equal bit for bit to chain.fk on the same rows."""

import os
import subprocess
import sys

import numpy as np
import pytest

import kinechain as kc

pd = pytest.importorskip("pandas")
pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
LINKS = ["panda_hand", "panda_link4"]


@pytest.fixture(scope="module")
def chain():
    return kc.load(os.path.join(ROOT, "robots", "panda.urdf"))


@pytest.fixture(scope="module")
def dataset(chain, tmp_path_factory):
    """200 000 rows of Panda joint values with a time and an episode column, in four files."""
    rng = np.random.default_rng(7)
    n = 200_000
    q = rng.uniform(chain.lower, chain.upper, (n, chain.dof))
    frame = pd.DataFrame({"time": np.arange(n) * 0.001, "episode": np.arange(n) // 1000})
    for k, name in enumerate(chain.joint_names):
        frame[name] = q[:, k]
    directory = tmp_path_factory.mktemp("joint_logs")
    for part in range(4):
        rows = slice(part * n // 4, (part + 1) * n // 4)
        frame.iloc[rows].to_parquet(directory / f"part{part}.parquet", index=False)
    return directory, frame, q


def expected(chain, q, links, orientation="quaternion"):
    p = chain.fk(q, links=links).poses
    parts = [p[..., :3, 3]]
    if orientation == "quaternion":
        parts.append(kc.orientation.quaternion_from_matrix(p))
    elif orientation == "rpy":
        parts.append(kc.orientation.rpy_from_matrix(p))
    else:
        parts.append(p[..., :3, :3].reshape(p.shape[:-2] + (9,)))
    return np.concatenate(parts, axis=-1).reshape(len(q), -1)


@pytest.mark.parametrize("orientation", ["quaternion", "matrix", "rpy"])
def test_pandas_and_arrow_tables_equal_fk_bit_for_bit(chain, dataset, orientation):
    _, frame, q = dataset
    names = kc.table.pose_columns(chain, LINKS, orientation)
    want = expected(chain, q, LINKS, orientation)
    out = kc.table.poses(frame, chain, links=LINKS, orientation=orientation)
    assert list(out.columns) == list(frame.columns) + names
    assert out[list(frame.columns)].equals(frame)
    assert np.array_equal(out[names].to_numpy(), want, equal_nan=True)
    table = pa.Table.from_pandas(frame, preserve_index=False)
    out = kc.table.poses(table, chain, links=LINKS, orientation=orientation)
    assert out.column_names == table.column_names + names
    assert out.select(table.column_names).equals(table)
    got = np.column_stack([out.column(c).to_numpy() for c in names])
    assert np.array_equal(got, want, equal_nan=True)


def test_every_link_and_a_list_column(chain, dataset):
    _, frame, q = dataset
    small = frame.iloc[:500]
    out = kc.table.poses(small, chain)
    assert out.shape[1] == small.shape[1] + 7 * len(chain.link_names)
    listed = pd.DataFrame({"t": small["time"], "q": list(q[:500])})
    assert np.array_equal(kc.table.poses(listed, chain, LINKS, q_column="q").iloc[:, 2:].to_numpy(), expected(chain, q[:500], LINKS))
    arrow = pa.table({"q": pa.array(list(q[:500]), type=pa.list_(pa.float64(), chain.dof))})
    got = kc.table.poses(arrow, chain, LINKS, q_column="q")
    assert np.array_equal(np.column_stack([got.column(c).to_numpy() for c in got.column_names[1:]]), expected(chain, q[:500], LINKS))


def test_bad_rows_are_errors_or_nulls(chain, dataset):
    _, frame, q = dataset
    bad = frame.iloc[:1000].copy()
    bad.loc[412, "panda_joint4"] = 1.0  # outside [-3.0718, -0.0698]
    bad.loc[700, "panda_joint2"] = np.nan
    with pytest.raises(kc.StateError, match="row 412: joint 'panda_joint4'"):
        kc.table.poses(bad, chain, LINKS)
    out = kc.table.poses(bad, chain, LINKS, on_error="null")
    names = kc.table.pose_columns(chain, LINKS)
    assert out[names].isna().all(axis=1).to_numpy().nonzero()[0].tolist() == [412, 700]
    good = np.setdiff1d(np.arange(1000), [412, 700])
    assert np.array_equal(out[names].to_numpy()[good], expected(chain, q[good], LINKS))
    arrow = kc.table.poses(pa.Table.from_pandas(bad, preserve_index=False), chain, LINKS, on_error="null")
    assert arrow.column(names[0]).null_count == 2
    assert arrow.column(names[0]).is_null().to_pylist()[412]
    with pytest.raises(kc.StateError, match="no column for joints 'panda_joint1'"):
        kc.table.poses(bad.drop(columns=["panda_joint1"]), chain)
    with pytest.raises(ValueError, match="orientation"):
        kc.table.poses(bad, chain, orientation="euler")
    # A table that already has the pose columns is not given a second set.
    once = kc.table.poses(frame.iloc[:10], chain, LINKS)
    with pytest.raises(kc.Error, match="already has columns 'panda_hand.x'"):
        kc.table.poses(once, chain, LINKS)


def test_a_dask_local_cluster_gives_the_same_bits(chain, dataset):
    dd = pytest.importorskip("dask.dataframe")
    distributed = pytest.importorskip("dask.distributed")
    directory, frame, _ = dataset
    local = kc.table.poses(frame, chain, links=LINKS)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, distributed.Client(cluster):
        ddf = dd.read_parquet(str(directory))
        meta = kc.table.poses_meta(ddf._meta, chain, links=LINKS)
        out = ddf.map_partitions(kc.table.poses, chain, links=LINKS, meta=meta).compute()
    out = out.reset_index(drop=True)
    assert list(out.columns) == list(local.columns)
    assert np.array_equal(out.to_numpy(), local.to_numpy())


def test_the_dask_example_runs(chain, dataset, tmp_path):
    pytest.importorskip("dask.distributed")
    directory, frame, _ = dataset
    script = os.path.join(ROOT, "python", "examples", "dask_poses.py")
    result = subprocess.run(
        [sys.executable, script, os.path.join(ROOT, "robots", "panda.urdf"), str(directory), str(tmp_path / "out"),
         "--links", "panda_hand", "--workers", "2"],
        capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    written = pd.read_parquet(tmp_path / "out")
    assert len(written) == len(frame)
    assert np.array_equal(np.sort(written["panda_hand.x"].to_numpy()), np.sort(kc.table.poses(frame, chain, ["panda_hand"])["panda_hand.x"].to_numpy()))
