"""Rows per second from joint logs to link poses: ``python python/benchmarks/logs.py [ROWS]``.

1. A list column (``fixed_size_list<float32>[6]``, SO-101 in degrees) read into joint values by
   ``kinechain.table`` (no row loop), against the per-row Python loop it replaces, same run.
2. An MCAP bag of 1 M ``JointState`` messages (the Panda's 7 arm joints, CDR, zstd chunks) to
   ``panda_hand`` poses: ``kc.logs.joint_states`` then ``kc.table.poses``, one core; against
   ``mcap-ros2-support``'s decoder on the first 100 000 messages; and to TF
   (``kc.logs.write_tf``). ``python python/benchmarks/logs.py N bag`` runs this part alone on N
   messages.
3. A LeRobot-layout dataset of ROWS rows (default 2 M; 16 Parquet files) to end-effector poses:
   ``kc.logs.lerobot`` on one core, and ``dask_poses.py``'s ``map_partitions`` (to Parquet) on
   a LocalCluster of two worker processes.

Needs pandas, pyarrow, dask[distributed], mcap and mcap-ros2-support.
"""

import json
import os
import struct
import sys
import tempfile

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

import kinechain as kc

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from table import best  # noqa: E402  (the shortest of a few rounds, as the table benchmark times)

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
SO101 = os.path.join(ROOT, "robots", "so101.urdf")
PANDA = os.path.join(ROOT, "robots", "panda.urdf")
NAMES = ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos"]
JOINT_STATE = ("std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n"
               "================================================================================\nMSG: std_msgs/Header\n"
               "builtin_interfaces/Time stamp\nstring frame_id\n"
               "================================================================================\n"
               "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n")


def cpu():
    try:
        with open("/proc/cpuinfo") as f:
            info = dict(line.split(":", 1) for line in f if ":" in line and line.split(":")[0].strip() in ("model name", "cpu family", "model"))
    except OSError:
        return "unknown CPU"
    return " ".join(f"{k.strip()} {v.strip()}" for k, v in info.items())


def list_column(chain, n):
    q = chain.random(n, seed=1)
    logged = np.rad2deg(q).astype(np.float32)
    return pa.table({"observation.state": pa.FixedSizeListArray.from_arrays(pa.array(logged.ravel()), 6)})


def lists(n):
    chain = kc.load(SO101)
    table = list_column(chain, n)
    names = [x[:-4] for x in NAMES]
    args = (table, chain, "observation.state", True, names, "deg", None, None)
    fast = best(lambda: kc.table._joint_values(*args))

    m = min(n, 500_000)
    head = table.slice(0, m)

    def loop():
        # What q_column= did before: one numpy row per table row (timed on the first m rows).
        values = head.column("observation.state").to_pylist()
        q = np.empty((len(values), 6))
        for i, row in enumerate(values):
            q[i] = np.deg2rad(np.asarray(row, dtype=np.float64))
        return q

    slow = best(loop, rounds=1) * n / m
    poses = best(lambda: kc.table.poses(table, chain, ["gripper_frame_link"], q_column="observation.state",
                                        names=names, units="deg", threads=1))
    print(f"1. list column, {n} rows of 6 (float32, degrees): read {n / fast / 1e6:.1f} M rows/s; "
          f"the per-row loop {n / slow / 1e6:.2f} M rows/s ({slow / fast:.0f}x slower); "
          f"with poses and quaternions, 1 thread: {n / poses / 1e6:.2f} M rows/s")


def cdr_joint_state(t_ns, names_block, position):
    """A JointState message's CDR bytes (little-endian XCDR1), as Fast-CDR lays them out."""
    head = struct.pack("<4siI", b"\x00\x01\x00\x00", t_ns // 10**9, t_ns % 10**9) + struct.pack("<I", 1) + b"\x00\x00\x00\x00"
    body = head + names_block
    body += b"\x00" * ((-(len(body) - 4)) % 4) + struct.pack("<I", len(position))
    body += b"\x00" * ((-(len(body) - 4)) % 8) + struct.pack(f"<{len(position)}d", *position)
    return body + struct.pack("<II", 0, 0)


def write_bag(path, n):
    from mcap.writer import CompressionType, Writer

    chain = kc.load(PANDA)
    q = chain.random(n, seed=2)[:, :7]
    names = [f"panda_joint{i}" for i in range(1, 8)]
    block = struct.pack("<I", len(names))
    for name in names:
        text = name.encode() + b"\x00"
        block += b"\x00" * ((-len(block) - 24) % 4) + struct.pack("<I", len(text)) + text
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start(profile="ros2", library="kinechain benchmark")
        schema = w.register_schema(name="sensor_msgs/msg/JointState", encoding="ros2msg", data=JOINT_STATE.encode())
        channel = w.register_channel(topic="/joint_states", message_encoding="cdr", schema_id=schema)
        t = 1_700_000_000_000_000_000
        for i in range(n):
            w.add_message(channel_id=channel, log_time=t + i * 1_000_000, publish_time=t + i * 1_000_000,
                          data=cdr_joint_state(t + i * 1_000_000, block, q[i]))
        w.finish()
    return q


def bag(n):
    path = os.path.join(tempfile.gettempdir(), f"kinechain-bench-{n}.mcap")
    q = write_bag(path, n)
    chain = kc.load(PANDA)
    log = kc.logs.joint_states(path)
    assert np.array_equal(np.column_stack([log.column(f"panda_joint{i}").to_numpy() for i in range(1, 8)]), q)
    read = best(lambda: kc.logs.joint_states(path))
    fixed = {"panda_finger_joint1": 0.0}
    poses = best(lambda: kc.table.poses(log, chain, ["panda_hand"], fixed=fixed, threads=1))
    from mcap_ros2.reader import read_ros2_messages

    m = min(n, 100_000)

    def python_decoder():
        for k, _ in enumerate(read_ros2_messages(path, topics=["/joint_states"])):
            if k + 1 >= m:
                break

    slow = best(python_decoder, rounds=1) * n / m
    # TF out: the log (with the gripper's value) to /tf, /tf_static and /robot_description.
    out = path + ".tf.mcap"
    table = log.append_column("panda_finger_joint1", pa.array(np.zeros(log.num_rows)))
    tf = best(lambda: kc.logs.write_tf(chain, table, out), rounds=2)
    tf_size = os.path.getsize(out) / 2**20
    os.remove(out)
    size = os.path.getsize(path) / 2**20
    os.remove(path)
    print(f"   TF out (kc.logs.write_tf: 9 moving joints a message, LZ4 chunks), 1 thread: {n / tf / 1e6:.2f} M msgs/s "
          f"({tf_size:.0f} MiB); read + TF: {n / (read + tf) / 1e6:.2f} M msgs/s")
    print(f"2. MCAP bag, {n} JointState messages of 7 joints ({size:.0f} MiB, zstd): read {n / read / 1e6:.2f} M msgs/s; "
          f"mcap-ros2-support's decoder {n / slow / 1e6:.3f} M msgs/s ({slow / read:.0f}x slower); "
          f"read + panda_hand poses, 1 thread: {n / (read + poses) / 1e6:.2f} M rows/s")


def lerobot(n):
    from dask.distributed import Client, LocalCluster
    import dask.dataframe as dd

    chain = kc.load(SO101)
    with tempfile.TemporaryDirectory() as root:
        table = list_column(chain, n)
        feature = {"dtype": "float32", "shape": [6], "names": NAMES}
        os.makedirs(os.path.join(root, "meta"))
        os.makedirs(os.path.join(root, "data", "chunk-000"))
        with open(os.path.join(root, "meta", "info.json"), "w") as f:
            json.dump({"codebase_version": "v3.0", "features": {"observation.state": feature}}, f)
        table = table.append_column("frame_index", pa.array(np.arange(n)))
        for k in range(16):
            part = table.slice(k * n // 16, (k + 1) * n // 16 - k * n // 16)
            pq.write_table(part, os.path.join(root, "data", "chunk-000", f"file-{k:03d}.parquet"))
        links = ["gripper_frame_link"]
        one = best(lambda: kc.logs.lerobot(root, chain, units="deg", links=links, threads=1))
        print(f"3. LeRobot dataset, {n} rows in 16 Parquet files: kc.logs.lerobot, 1 thread: {n / one / 1e6:.2f} M rows/s", end="")
        names = kc.logs.lerobot_names(root, chain)
        options = dict(q_column="observation.state", names=names, units="deg", threads=1)
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c, Client(c):
            ddf = dd.read_parquet(kc.logs.lerobot_files(root), dtype_backend="pyarrow")
            meta = kc.table.poses_meta(ddf._meta, chain, links, **options)
            # (Written to Parquet, as dask_poses.py does: a reduction of one column could be
            # optimised into less than the whole computation.)
            out = os.path.join(root, "out")
            run = lambda: ddf.map_partitions(kc.table.poses, chain, links, meta=meta, **options).to_parquet(out, overwrite=True)  # noqa: E731
            run()
            two = best(run)
        print(f"; Dask, 2 worker processes, Parquet out: {n / two / 1e6:.2f} M rows/s")


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2_000_000
    if len(sys.argv) > 2 and sys.argv[2] == "bag":
        return bag(n)
    print(f"CPU: {cpu()}, {os.cpu_count()} logical cores")
    lists(n)
    bag(1_000_000)
    lerobot(n)


if __name__ == "__main__":
    main()
