"""Rows per second through ``kinechain.table.poses`` (Panda, end link, quaternion) against the
raw numpy batch on one core, and on a Dask LocalCluster of one and of two worker processes:
``python python/benchmarks/table.py [ROWS]``. Needs pandas, pyarrow and dask[distributed]."""

import os
import sys
import tempfile
import time

import numpy as np
import pandas as pd

import kinechain as kc

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def best(f, rounds=3):
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return min(times)


def main():
    import dask.dataframe as dd
    from dask.distributed import Client, LocalCluster

    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2_000_000
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    q = np.random.default_rng(1).uniform(chain.lower, chain.upper, (n, chain.dof))
    frame = pd.DataFrame(q, columns=chain.joint_names)
    frame.insert(0, "time", np.arange(n) * 1e-3)
    links = ["panda_hand"]
    raw = best(lambda: kc.orientation.quaternion_from_matrix(chain.fk(q, links=links, threads=1).poses))
    table = best(lambda: kc.table.poses(frame, chain, links, threads=1))
    print(f"{n} rows; raw batch + quaternion, 1 thread: {n / raw / 1e6:.2f} M rows/s")
    print(f"kc.table.poses (pandas), 1 thread: {n / table / 1e6:.2f} M rows/s ({table / raw:.2f}x the raw time)")
    with tempfile.TemporaryDirectory() as d, tempfile.TemporaryDirectory() as written:
        for part in range(16):
            frame.iloc[part * n // 16:(part + 1) * n // 16].to_parquet(os.path.join(d, f"p{part}.parquet"), index=False)
        rates = {}
        for workers in (1, 2):
            with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as c, Client(c):
                ddf = dd.read_parquet(d)
                meta = kc.table.poses_meta(ddf._meta, chain, links)
                run = lambda: ddf.map_partitions(kc.table.poses, chain, links, threads=1, meta=meta).to_parquet(os.path.join(written, f"out{workers}"), overwrite=True)  # noqa: E731
                run()
                rates[workers] = n / best(run)
            print(f"Dask, {workers} worker process(es), Parquet in and out: {rates[workers] / 1e6:.2f} M rows/s")
        print(f"two workers against one: {rates[2] / rates[1]:.2f}x")


if __name__ == "__main__":
    main()
