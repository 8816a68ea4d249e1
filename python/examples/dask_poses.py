"""Link poses for a Parquet dataset of joint logs, on a Dask cluster.

    python python/examples/dask_poses.py ROBOT INPUT_DIR OUTPUT_DIR [--links L ...]
        [--orientation quaternion|matrix|rpy] [--scheduler ADDRESS] [--workers N]
        [--q-column COLUMN] [--units rad|deg]

INPUT_DIR holds Parquet files with one float64 column per joint (named as `kinechain info`
lists them; other columns are carried through), or is a LeRobot dataset (meta/info.json and
data/): then `observation.state` (or --q-column) is read as the joint values, entries named as
info.json names them (`shoulder_pan.pos` is joint `shoulder_pan`), in --units. Without
--scheduler a LocalCluster of --workers processes runs on this machine; with --scheduler
tcp://host:8786 the same code runs on any Dask cluster whose workers have kinechain installed
(the chain is shipped to them by pickling). Columns are read Arrow-backed; read the output
back with pyarrow or `pd.read_parquet(OUTPUT_DIR, dtype_backend="pyarrow")` (pandas cannot
rebuild a fixed-size-list column's type from the metadata it writes).
"""

import argparse
import os

import dask.dataframe as dd
from dask.distributed import Client, LocalCluster

import kinechain as kc


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("robot")
    p.add_argument("input")
    p.add_argument("output")
    p.add_argument("--links", nargs="*", default=None, help="links to add (default: every link)")
    p.add_argument("--orientation", default="quaternion", choices=["quaternion", "matrix", "rpy"])
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    p.add_argument("--workers", type=int, default=2, help="worker processes of the local cluster")
    p.add_argument("--q-column", default=None, help="a list column of joint values (LeRobot: observation.state)")
    p.add_argument("--units", default="rad", choices=["rad", "deg"], help="units of the angles in the input")
    a = p.parse_args()
    chain = kc.load(a.robot)
    options = {"units": a.units}
    if os.path.exists(os.path.join(a.input, "meta", "info.json")):
        column = a.q_column or "observation.state"
        files = kc.logs.lerobot_files(a.input)
        options.update(q_column=column, names=kc.logs.lerobot_names(a.input, chain, column))
    else:
        files = a.input
        if a.q_column:
            options["q_column"] = a.q_column
    if a.scheduler:
        client = Client(a.scheduler)
    else:
        client = Client(LocalCluster(n_workers=a.workers, threads_per_worker=1, processes=True))
    with client:
        # (Arrow-backed columns keep list columns, such as LeRobot's, lists for Parquet output.)
        ddf = dd.read_parquet(files, dtype_backend="pyarrow")
        meta = kc.table.poses_meta(ddf._meta, chain, a.links, a.orientation, **options)
        out = ddf.map_partitions(kc.table.poses, chain, a.links, a.orientation, meta=meta, **options)
        out.to_parquet(a.output)
    print(f"wrote {a.output}: {len(meta.columns) - len(ddf.columns)} pose columns added")


if __name__ == "__main__":
    main()
