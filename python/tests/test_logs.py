"""Joint logs: ROS 2 bags written here with the ``mcap`` / ``mcap-ros2-support`` writer,
LeRobot-layout datasets written here with pyarrow, list columns, names, units and calibration;
every pose equal to ``chain.fk`` on the same joint values, bit for bit."""

import json
import os
import warnings

import numpy as np
import pytest

import kinechain as kc

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
pd = pytest.importorskip("pandas")
# The ROS 2 message writer is installed in CI (KINECHAIN_REQUIRE_PEERS=1 there: a missing one
# fails the run); elsewhere these tests are skipped without it.
if os.environ.get("KINECHAIN_REQUIRE_PEERS"):
    import mcap.writer as mcap_writer
    import mcap_ros2._dynamic as mcap_ros2_dynamic
else:
    mcap_writer = pytest.importorskip("mcap.writer")
    mcap_ros2_dynamic = pytest.importorskip("mcap_ros2._dynamic")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PANDA = os.path.join(ROOT, "robots", "panda.urdf")
SO101 = os.path.join(ROOT, "robots", "so101.urdf")

JOINT_STATE = """std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def joint_state(t_ns, names, position, velocity=(), effort=()):
    return {
        "header": {"stamp": {"sec": int(t_ns // 10**9), "nanosec": int(t_ns % 10**9)}, "frame_id": ""},
        "name": list(names),
        "position": [float(x) for x in position],
        "velocity": [float(x) for x in velocity],
        "effort": [float(x) for x in effort],
    }


class Bag:
    """An MCAP file of ROS 2 messages: ``channel(topic, type, text, publisher)`` then ``write``."""

    def __init__(self, path, compression="zstd"):
        from mcap.writer import CompressionType

        self.f = open(path, "wb")
        kind = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, None: CompressionType.NONE}[compression]
        self.w = mcap_writer.Writer(self.f, compression=kind, chunk_size=1 << 16)
        self.w.start(profile="ros2", library="kinechain tests")
        self.schemas = {}
        self.encoders = {}

    def channel(self, topic, datatype="sensor_msgs/msg/JointState", text=JOINT_STATE, publisher="a"):
        if datatype not in self.schemas:
            self.schemas[datatype] = self.w.register_schema(name=datatype, encoding="ros2msg", data=text.encode())
            self.encoders[datatype] = mcap_ros2_dynamic.serialize_dynamic(datatype, text)[datatype]
        cid = self.w.register_channel(topic=topic, message_encoding="cdr", schema_id=self.schemas[datatype],
                                      metadata={"publisher": publisher})
        return cid, self.encoders[datatype]

    def write(self, channel, message, log_time):
        cid, encode = channel
        self.w.add_message(channel_id=cid, log_time=log_time, publish_time=log_time, data=encode(message))

    def close(self):
        self.w.finish()
        self.f.close()


ARM = [f"panda_joint{i}" for i in range(1, 8)]


def panda_log(path, n, seed=0, compression="zstd"):
    """``n`` arm messages (names in a shuffled order each time, velocities) from one publisher,
    and gripper messages from another after every third, on one topic; a camera topic beside.
    Returns the q of each message as the chain takes it (the gripper held)."""
    chain = kc.load(PANDA)
    rng = np.random.default_rng(seed)
    qs = chain.random(n, seed=seed)
    bag = Bag(path, compression)
    arm = bag.channel("/joint_states", publisher="arm")
    hand = bag.channel("/joint_states", publisher="gripper")
    camera = bag.channel("/camera/info", "std_msgs/msg/String", "string data\n")
    expected, times, finger = [], [], None
    t = 1_700_000_000_000_000_000
    for i, q in enumerate(qs):
        order = rng.permutation(7)
        bag.write(arm, joint_state(t, [ARM[k] for k in order], q[order], velocity=order * 0.1), t + 5)
        if finger is not None:
            expected.append(np.r_[q[:7], finger])
            times.append(t)
        t += 1_000_000
        if i % 3 == 0:
            finger = q[7]
            bag.write(hand, joint_state(t, ["panda_finger_joint1"], [finger]), t + 5)
            expected.append(np.r_[q[:7], finger])
            times.append(t)
            bag.write(camera, {"data": "x"}, t + 6)
            t += 1_000_000
    bag.close()
    return chain, np.array(expected), np.array(times)


def test_bag_rows_map_names_and_hold_values_and_give_the_poses_of_chain_fk(tmp_path):
    path = tmp_path / "panda.mcap"
    chain, expected, times = panda_log(path, 60)
    log = kc.logs.joint_states(path)
    assert isinstance(log, pa.Table)
    assert log.column_names[0] == "time" and log.schema.field("time").type == pa.int64()
    assert set(log.column_names[1:]) == set(chain.q_names)
    # The first arm message comes before any gripper value: null there, then held.
    finger = log.column("panda_finger_joint1")
    assert finger.null_count == 1 and not finger[0].is_valid
    out = kc.table.poses(log.slice(1), chain, ["panda_hand"])
    assert np.array_equal(out.column("time").to_numpy(), times)
    q = np.column_stack([out.column(j).to_numpy() for j in chain.q_names])
    assert np.array_equal(q, expected)
    p = chain.fk(expected, links=["panda_hand"]).poses[:, 0]
    assert np.array_equal(out.column("panda_hand.x").to_numpy(), p[:, 0, 3])
    assert np.array_equal(out.column("panda_hand.z").to_numpy(), p[:, 2, 3])


def test_bag_options_log_time_nulls_velocities_pandas(tmp_path):
    path = tmp_path / "panda.mcap"
    panda_log(path, 9, compression=None)
    nulls = kc.logs.joint_states(path, time="log", missing="null", velocities=True, efforts=True, to="pandas")
    assert isinstance(nulls, pd.DataFrame)
    assert nulls["time"].dtype == np.int64 and (nulls["time"] % 1_000_000 == 5).all()
    # Each arm row has no gripper value, each gripper row no arm value.
    arm_rows = nulls["panda_joint1"].notna()
    assert (arm_rows == nulls["panda_finger_joint1"].isna()).all()
    v = nulls.loc[arm_rows, [f"{j}.velocity" for j in ARM]].to_numpy()
    assert np.array_equal(np.sort(v, axis=1), np.tile(np.arange(7) * 0.1, (len(v), 1)))
    assert nulls[[f"{j}.effort" for j in ARM]].isna().all().all()


def test_cut_bags_wrong_topics_and_types_are_errors_naming_them(tmp_path):
    path = tmp_path / "panda.mcap"
    panda_log(path, 300, compression=None)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(kc.LogError, match=r"cut.mcap: the file ends in the middle of a record, after \d+ messages of topic /joint_states"):
        kc.logs.joint_states(cut)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        head = kc.logs.joint_states(cut, truncated="keep")
    assert any("before the cut" in str(w.message) for w in caught)
    whole = kc.logs.joint_states(path)
    assert 0 < head.num_rows < whole.num_rows
    assert head.equals(whole.slice(0, head.num_rows).select(head.column_names))
    with pytest.raises(kc.LogError, match=r"no topic /arm/joint_states; the bag has /joint_states \(sensor_msgs/msg/JointState\), /camera/info \(std_msgs/msg/String\)"):
        kc.logs.joint_states(path, topic="/arm/joint_states")
    with pytest.raises(kc.LogError, match=r"topic /camera/info carries std_msgs/msg/String messages"):
        kc.logs.joint_states(path, topic="/camera/info")
    with pytest.raises(kc.LogError, match="not a readable MCAP file"):
        kc.logs.joint_states(os.path.join(ROOT, "robots", "panda.urdf"))
    with pytest.raises(ValueError, match="missing 'carry'"):
        kc.logs.joint_states(path, missing="carry")
    assert issubclass(kc.LogError, kc.Error)


def test_a_malformed_message_is_named_by_index_and_log_time(tmp_path):
    path = tmp_path / "bad.mcap"
    bag = Bag(path)
    js = bag.channel("/joint_states")
    bag.write(js, joint_state(0, ["a", "b"], [1.0, 2.0]), 10)
    bag.write(js, joint_state(0, ["a", "b"], [1.0]), 20)
    bag.close()
    with pytest.raises(kc.LogError, match=r"message 1 of topic /joint_states \(log time 20 ns\): 2 names but 1 position values"):
        kc.logs.joint_states(path)


# --- list columns, names, units -------------------------------------------------------------

def so101_rows(n, seed=3):
    chain = kc.load(SO101)
    q = chain.random(n, seed=seed)
    return chain, q


@pytest.mark.parametrize("kind", ["fixed32", "fixed64", "list32", "list64", "large64", "chunked", "sliced", "pandas"])
def test_list_columns_of_every_kind_read_without_a_row_loop(kind):
    chain, q = so101_rows(1000)
    dtype = np.float32 if kind.endswith("32") else np.float64
    values = q.astype(dtype)
    flat = pa.array(values.ravel())
    if kind.startswith("fixed"):
        col = pa.FixedSizeListArray.from_arrays(flat, 6)
    elif kind.startswith("large"):
        col = pa.LargeListArray.from_arrays(pa.array(np.arange(0, 6001, 6), pa.int64()), flat)
    else:
        col = pa.ListArray.from_arrays(pa.array(np.arange(0, 6001, 6), pa.int32()), flat)
    table = pa.table({"frame": np.arange(1000), "state": col})
    expected_q = values.astype(np.float64)
    if kind == "chunked":
        table = pa.concat_tables([table.slice(0, 300), table.slice(300)])
    if kind == "sliced":
        table, expected_q = table.slice(250, 500), expected_q[250:750]
    if kind == "pandas":
        table = pd.DataFrame({"frame": np.arange(1000), "state": list(q)})
    out = kc.table.poses(table, chain, ["gripper_frame_link"], q_column="state")
    got = np.column_stack([np.asarray(out["gripper_frame_link.x"]), np.asarray(out["gripper_frame_link.qz"])])
    p = chain.fk(expected_q, links=["gripper_frame_link"]).poses[:, 0]
    assert np.array_equal(got[:, 0], p[:, 0, 3])
    ref = kc.table.poses(pd.DataFrame(expected_q, columns=chain.q_names), chain, ["gripper_frame_link"])
    assert np.array_equal(got[:, 1], ref["gripper_frame_link.qz"].to_numpy())


def test_bad_list_rows_are_errors_naming_the_row_or_null_rows():
    chain, q = so101_rows(5)
    rows = [list(r) for r in q]
    rows[2] = rows[2][:5]
    table = pa.table({"state": pa.array(rows, pa.list_(pa.float64()))})
    with pytest.raises(kc.StateError, match=r"row 2: state has 5 values; 6 expected"):
        kc.table.poses(table, chain, ["gripper_frame_link"], q_column="state")
    out = kc.table.poses(table, chain, ["gripper_frame_link"], q_column="state", on_error="null")
    assert out.column("gripper_frame_link.x").null_count == 1 and not out.column("gripper_frame_link.x")[2].is_valid
    assert out.column("gripper_frame_link.x")[3].as_py() == chain.fk(q[3], links=["gripper_frame_link"]).poses[0, 0, 3]
    rows = [list(r) for r in q]
    rows[1] = None
    rows[4] = [None if k == 2 else x for k, x in enumerate(rows[4])]
    table = pa.table({"state": pa.array(rows, pa.list_(pa.float64(), 6))})
    with pytest.raises(kc.StateError, match=r"row 1: state is null"):
        kc.table.poses(table, chain, q_column="state")
    out = kc.table.poses(table, chain, ["gripper_frame_link"], q_column="state", on_error="null")
    assert [v.is_valid for v in out.column("gripper_frame_link.x")] == [True, False, True, True, False]
    with pytest.raises(kc.StateError, match=r"row 0 \(index 10\): state has 2 values"):
        kc.table.poses(pd.DataFrame({"state": [[0.0, 1.0]]}, index=[10]), chain, q_column="state")
    with pytest.raises(kc.StateError, match="holds string, not lists of numbers"):
        kc.table.poses(pa.table({"state": ["a"]}), chain, q_column="state")


def test_names_units_calibration_and_fixed_values():
    chain, q = so101_rows(200)
    deg = np.rad2deg(q)
    # A log's order, an extra entry that is not a joint, the gripper in percent.
    order = ["elbow_flex.pos", "shoulder_pan.pos", "shoulder_lift.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos", "force"]
    joint_of = {"elbow_flex.pos": 2, "shoulder_pan.pos": 0, "shoulder_lift.pos": 1, "wrist_flex.pos": 3, "wrist_roll.pos": 4}
    lo, hi = chain.lower[5], chain.upper[5]
    percent = (q[:, 5] - lo) / (hi - lo) * 100.0
    cols = [deg[:, joint_of[n]] for n in order[:5]] + [percent, np.full(200, 7.0)]
    log = pa.table({"state": pa.FixedSizeListArray.from_arrays(pa.array(np.column_stack(cols).ravel()), 7)})
    names = [n.removesuffix(".pos") for n in order]
    scale = (hi - lo) / 100.0
    out = kc.table.poses(log, chain, ["gripper_frame_link"], q_column="state", names=names, units="deg",
                         calibration={"gripper": (scale, lo)})
    q_read = np.column_stack([np.deg2rad(deg[:, :5]), percent * scale + lo])
    p = chain.fk(q_read, links=["gripper_frame_link"]).poses[:, 0]
    assert np.array_equal(out.column("gripper_frame_link.y").to_numpy(), p[:, 1, 3])
    assert np.allclose(q_read, q, atol=1e-12)
    # The gripper left out: an error naming it, or held by fixed=.
    names[5] = None
    with pytest.raises(kc.StateError, match=r"no entry of 'state' is named joints 'gripper'.*fixed="):
        kc.table.poses(log, chain, q_column="state", names=names, units="deg")
    held = kc.table.poses(log, chain, ["gripper_frame_link"], q_column="state", names=names, units="deg", fixed={"gripper": 0.25})
    p = chain.fk(np.column_stack([np.deg2rad(deg[:, :5]), np.full(200, 0.25)]), links=["gripper_frame_link"]).poses[:, 0]
    assert np.array_equal(held.column("gripper_frame_link.x").to_numpy(), p[:, 0, 3])
    # Columns named otherwise, mapped by names={column: joint}; degrees never touch metres.
    panda = kc.load(PANDA)
    qp = panda.random(50, seed=1)
    frame = pd.DataFrame({f"j{k}": np.rad2deg(qp[:, k]) for k in range(7)})
    frame["finger"] = qp[:, 7]
    mapping = {f"j{k}": f"panda_joint{k + 1}" for k in range(7)} | {"finger": "panda_finger_joint1"}
    assert panda.q_units == ["rad"] * 7 + ["m"]
    out = kc.table.poses(frame, panda, ["panda_hand"], names=mapping, units="deg")
    p = panda.fk(np.column_stack([np.deg2rad(np.rad2deg(qp[:, :7])), qp[:, 7]]), links=["panda_hand"]).poses[:, 0]
    assert np.array_equal(out["panda_hand.x"].to_numpy(), p[:, 0, 3])
    with pytest.raises(kc.StateError, match="no column 'j9'"):
        kc.table.poses(frame, panda, names={"j9": "panda_joint1"})
    with pytest.raises(kc.StateError, match="not entries of q"):
        kc.table.poses(frame, panda, names=mapping, fixed={"elbow": 0.0})
    with pytest.raises(ValueError, match="units 'grad'"):
        kc.table.poses(frame, panda, names=mapping, units="grad")


# --- LeRobot ---------------------------------------------------------------------------------

def write_lerobot(root, q_deg_like, names, files=2, v2=False):
    """A LeRobot v3-layout dataset: ``meta/info.json`` and ``data/chunk-000/file-00K.parquet``."""
    n, width = q_deg_like.shape
    os.makedirs(os.path.join(root, "meta"))
    info = {
        "codebase_version": "v2.1" if v2 else "v3.0",
        "robot_type": "so101_follower",
        "fps": 30,
        "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
        "features": {
            "observation.state": {"dtype": "float32", "shape": [width],
                                  "names": {"motors": names} if v2 else names},
            "action": {"dtype": "float32", "shape": [width], "names": names},
            "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        },
    }
    with open(os.path.join(root, "meta", "info.json"), "w") as f:
        json.dump(info, f)
    os.makedirs(os.path.join(root, "data", "chunk-000"))
    bounds = np.linspace(0, n, files + 1).astype(int)
    for k in range(files):
        a, b = bounds[k], bounds[k + 1]
        state = pa.FixedSizeListArray.from_arrays(pa.array(q_deg_like[a:b].astype(np.float32).ravel()), width)
        table = pa.table({
            "observation.state": state,
            "action": state,
            "timestamp": pa.array(np.arange(a, b, dtype=np.float32) / 30),
            "frame_index": pa.array(np.arange(a, b)),
            "episode_index": pa.array(np.zeros(b - a, dtype=np.int64)),
        })
        pq.write_table(table, os.path.join(root, "data", "chunk-000", f"file-{k:03d}.parquet"))


SO101_NAMES = ["shoulder_pan.pos", "shoulder_lift.pos", "elbow_flex.pos", "wrist_flex.pos", "wrist_roll.pos", "gripper.pos"]


@pytest.mark.parametrize("v2", [False, True])
def test_a_lerobot_dataset_in_degrees_gives_the_poses_of_chain_fk(tmp_path, v2):
    chain, q = so101_rows(500)
    lo, hi = chain.lower[5], chain.upper[5]
    logged = np.column_stack([np.rad2deg(q[:, :5]), (q[:, 5] - lo) / (hi - lo) * 100.0]).astype(np.float32)
    write_lerobot(tmp_path / "ds", logged, SO101_NAMES, v2=v2)
    scale = (hi - lo) / 100.0
    out = kc.logs.lerobot(tmp_path / "ds", chain, units="deg", calibration={"gripper": (scale, lo)}, links=["gripper_frame_link"])
    assert out.num_rows == 500 and out.column_names[:5] == ["observation.state", "action", "timestamp", "frame_index", "episode_index"]
    x = logged.astype(np.float64)
    q_read = np.column_stack([np.deg2rad(x[:, :5]), x[:, 5] * scale + lo])
    p = chain.fk(q_read, links=["gripper_frame_link"]).poses[:, 0]
    assert np.array_equal(out.column("gripper_frame_link.z").to_numpy(), p[:, 2, 3])
    # The gripper entry ignored and held; names from the mapping.
    held = kc.logs.lerobot(tmp_path / "ds", chain, names={"gripper.pos": None}, units="deg", fixed={"gripper": 0.0},
                           links=["gripper_frame_link"], columns=["frame_index"], to="pandas")
    assert list(held.columns[:2]) == ["frame_index", "observation.state"]
    p = chain.fk(np.column_stack([np.deg2rad(x[:, :5]), np.zeros(500)]), links=["gripper_frame_link"]).poses[:, 0]
    assert np.array_equal(held["gripper_frame_link.x"].to_numpy(), p[:, 0, 3])
    # Degrees read as radians are out of limits: the error names the row and joint.
    with pytest.raises(kc.StateError, match=r"row \d+: joint '\w+'"):
        kc.logs.lerobot(tmp_path / "ds", chain, calibration={"gripper": (scale, lo)})
    assert kc.logs.lerobot_names(tmp_path / "ds", chain) == [n[:-4] for n in SO101_NAMES]


def test_lerobot_errors_name_the_dataset_and_feature(tmp_path):
    chain = kc.load(SO101)
    with pytest.raises(kc.LogError, match="not a LeRobot dataset: no meta/info.json"):
        kc.logs.lerobot(tmp_path, chain)
    write_lerobot(tmp_path / "ds", np.zeros((4, 6)), SO101_NAMES, files=1)
    with pytest.raises(kc.LogError, match="no feature 'observation.images'"):
        kc.logs.lerobot(tmp_path / "ds", chain, column="observation.images")
    with pytest.raises(kc.LogError, match="renames 'elbow'"):
        kc.logs.lerobot(tmp_path / "ds", chain, names={"elbow": "elbow_flex"})


def test_the_examples_read_a_lerobot_dataset(tmp_path):
    import subprocess
    import sys

    pytest.importorskip("dask.distributed")
    chain, q = so101_rows(400)
    write_lerobot(tmp_path / "ds", np.rad2deg(q), SO101_NAMES)
    script = os.path.join(ROOT, "python", "examples", "dask_poses.py")
    result = subprocess.run(
        [sys.executable, script, SO101, str(tmp_path / "ds"), str(tmp_path / "out"), "--links", "gripper_frame_link",
         "--units", "deg", "--workers", "2"], capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    written = pd.read_parquet(tmp_path / "out", dtype_backend="pyarrow").sort_values("frame_index")
    local = kc.logs.lerobot(tmp_path / "ds", chain, units="deg", links=["gripper_frame_link"], to="pandas")
    assert np.array_equal(written["gripper_frame_link.qx"].to_numpy(np.float64), local["gripper_frame_link.qx"].to_numpy())
    example = os.path.join(ROOT, "python", "examples", "lerobot_poses.py")
    result = subprocess.run([sys.executable, example, str(tmp_path / "demo"), "--rows", "300"],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("300 rows of ") and "gripper frame: x " in result.stdout
