"""End-effector poses of a LeRobot dataset (SO-101 arm, joint values in degrees).

    python python/examples/lerobot_poses.py [DATASET_DIR] [--rows N]

Without DATASET_DIR (or where it does not exist yet), a small dataset in LeRobot v3's layout (meta/info.json, data/chunk-000/
file-000.parquet; `observation.state` a fixed-size list of six float32: five joints in degrees
and the gripper in percent of its travel, as lerobot records the SO-100/101 follower) is written
first, into DATASET_DIR or a temporary directory. The same directory works with dask_poses.py.
"""

import argparse
import json
import os
import tempfile

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import kinechain as kc

ROBOT = os.path.join(os.path.dirname(__file__), "..", "..", "robots", "so101.urdf")
NAMES = ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos"]


def write_dataset(root: str, chain: kc.Chain, rows: int) -> None:
    """A smooth random motion within the limits, logged as lerobot logs the SO-101."""
    t = np.arange(rows) / 30.0
    lo, hi = chain.lower, chain.upper
    phase = np.linspace(0.0, 2.0, 6)
    q = lo + (hi - lo) * (0.5 + 0.4 * np.sin(0.3 * t[:, None] + phase))
    logged = np.column_stack([np.rad2deg(q[:, :5]), (q[:, 5] - lo[5]) / (hi[5] - lo[5]) * 100.0])
    os.makedirs(os.path.join(root, "meta"), exist_ok=True)
    os.makedirs(os.path.join(root, "data", "chunk-000"), exist_ok=True)
    feature = {"dtype": "float32", "shape": [6], "names": NAMES}
    info = {"codebase_version": "v3.0", "robot_type": "so101_follower", "fps": 30,
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
            "features": {"observation.state": feature, "action": feature,
                         "timestamp": {"dtype": "float32", "shape": [1], "names": None}}}
    with open(os.path.join(root, "meta", "info.json"), "w") as f:
        json.dump(info, f, indent=2)
    state = pa.FixedSizeListArray.from_arrays(pa.array(logged.astype(np.float32).ravel()), 6)
    table = pa.table({"observation.state": state, "action": state, "timestamp": pa.array(t.astype(np.float32)),
                      "frame_index": pa.array(np.arange(rows)), "episode_index": pa.array(np.zeros(rows, np.int64))})
    pq.write_table(table, os.path.join(root, "data", "chunk-000", "file-000.parquet"))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("dataset", nargs="?", default=None)
    p.add_argument("--rows", type=int, default=3000, help="rows of the generated dataset")
    a = p.parse_args()
    chain = kc.load(ROBOT)
    with tempfile.TemporaryDirectory() as tmp:
        root = a.dataset or os.path.join(tmp, "so101_demo")
        if not os.path.exists(root):
            write_dataset(root, chain, a.rows)
        lo, hi = chain.lower[5], chain.upper[5]
        # Degrees for the joints; the gripper's 0-100 % mapped onto its range in radians.
        out = kc.logs.lerobot(root, chain, units="deg", calibration={"gripper": ((hi - lo) / 100.0, lo)},
                              links=["gripper_frame_link"], columns=["timestamp", "frame_index"])
        xyz = np.column_stack([out.column(f"gripper_frame_link.{c}").to_numpy() for c in "xyz"])
        print(f"{out.num_rows} rows of {root}")
        print(f"gripper frame: x {xyz[:, 0].min():.3f}..{xyz[:, 0].max():.3f} m, "
              f"y {xyz[:, 1].min():.3f}..{xyz[:, 1].max():.3f} m, z {xyz[:, 2].min():.3f}..{xyz[:, 2].max():.3f} m")


if __name__ == "__main__":
    main()
