"""TF out (``kinechain.logs.write_tf``): the files are read back with two independent readers,
``mcap-ros2-support`` and ``rosbags``, each decoding the CDR with the schema text the file
carries; the transforms composed from the root give kinechain's world poses."""

import os

import numpy as np
import pytest

import kinechain as kc
from test_logs import Bag, joint_state, panda_log

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
G1 = os.path.join(ROOT, "robots", "g1.urdf")

mcap_ros2_reader = pytest.importorskip("mcap_ros2.reader")


def matrix(t):
    """The 4 × 4 matrix of a geometry_msgs/Transform (fields by attribute)."""
    x, y, z, w = t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = r
    m[:3, 3] = [t.translation.x, t.translation.y, t.translation.z]
    return m


def world_poses(edges):
    """Each child frame's pose in the root frame, composing parent → child transforms."""
    out = {}

    def pose(frame):
        if frame not in edges:
            return np.eye(4)
        if frame not in out:
            parent, m = edges[frame]
            out[frame] = pose(parent) @ m
        return out[frame]

    for frame in edges:
        pose(frame)
    return out


def read_mcap_ros2(path):
    """Messages by topic: (log_time, channel metadata, decoded message)."""
    topics = {}
    for m in mcap_ros2_reader.read_ros2_messages(path):
        topics.setdefault(m.channel.topic, []).append((m.log_time_ns, dict(m.channel.metadata), m.ros_msg))
    return topics


def read_rosbags(path):
    from pathlib import Path

    from rosbags.highlevel import AnyReader

    topics = {}
    with AnyReader([Path(path)]) as reader:
        for connection, t, raw in reader.messages():
            topics.setdefault(connection.topic, []).append((t, connection, reader.deserialize(raw, connection.msgtype)))
    return topics


def check_poses(chain, static, messages, qs, times, prefix="", world="world"):
    """Every /tf message composed with /tf_static gives chain.fk of its row, to rounding."""
    assert len(messages) == len(qs)
    fixed = {s.child_frame_id: (s.header.frame_id, matrix(s.transform)) for s in static}
    worst = 0.0
    for msg, q, t in zip(messages, qs, times):
        edges = dict(fixed)
        for s in msg.transforms:
            assert s.header.stamp.sec * 10**9 + s.header.stamp.nanosec == t
            edges[s.child_frame_id] = (s.header.frame_id, matrix(s.transform))
        poses = world_poses(edges)
        fk = chain.fk(q)
        for k, name in enumerate(chain.link_names):
            got = poses.get(prefix + name, np.eye(4))
            worst = max(worst, np.abs(got - fk[name]).max())
    return worst


def test_a_bag_becomes_the_tf_robot_state_publisher_would_publish(tmp_path):
    bag = str(tmp_path / "run.mcap")
    chain, qs, times = panda_log(bag, 40)
    before = open(bag, "rb").read()
    out = str(tmp_path / "tf.mcap")
    summary = kc.logs.write_tf(chain, bag, out)
    assert open(bag, "rb").read() == before
    import xml.etree.ElementTree as XML

    kinds = [j.get("type") for j in XML.parse(os.path.join(ROOT, "robots", "panda.urdf")).getroot().iter("joint")]
    assert summary == {"messages": len(qs), "moving": sum(k != "fixed" for k in kinds), "fixed": kinds.count("fixed")}

    topics = read_mcap_ros2(out)
    assert sorted(topics) == ["/robot_description", "/tf", "/tf_static"]
    assert [t for t, _, _ in topics["/tf"]] == list(times)
    assert len(topics["/tf_static"]) == 1 and len(topics["/robot_description"]) == 1
    # Latched topics are recorded transient local (durability 1), /tf volatile (2).
    for topic, durability in (("/tf_static", 1), ("/robot_description", 1), ("/tf", 2)):
        assert f"durability: {durability}" in topics[topic][0][1]["offered_qos_profiles"]
    assert topics["/robot_description"][0][2].data == open(os.path.join(ROOT, "robots", "panda.urdf")).read()
    static = topics["/tf_static"][0][2].transforms
    assert len(static) == summary["fixed"]
    worst = check_poses(chain, static, [m for _, _, m in topics["/tf"]], qs, times)
    assert worst <= 2e-15, worst

    # The same file through rosbags, decoding with the schema the file carries.
    pytest.importorskip("rosbags")
    again = read_rosbags(out)
    assert sorted(again) == ["/robot_description", "/tf", "/tf_static"]
    assert again["/tf"][0][1].msgtype == "tf2_msgs/msg/TFMessage"
    worst = check_poses(chain, again["/tf_static"][0][2].transforms, [m for _, _, m in again["/tf"]], qs, times)
    assert worst <= 2e-15, worst


def test_a_table_of_a_floating_robot_with_a_prefix(tmp_path):
    chain = kc.load(G1, floating_base=True)
    qs = chain.random(12, seed=4)
    times = 1_000_000_000 * np.arange(12, dtype=np.int64) + 17
    pd = pytest.importorskip("pandas")
    table = pd.DataFrame({"time": times, **{name: qs[:, k] for k, name in enumerate(chain.q_names)}})
    out = str(tmp_path / "g1.mcap")
    summary = kc.logs.write_tf(chain, table, out, frame_prefix="g1/", world_frame="map")
    assert summary["messages"] == 12
    topics = read_mcap_ros2(out)
    first = topics["/tf"][0][2].transforms
    base = [s for s in first if s.header.frame_id == "map"]
    assert len(base) == 1 and base[0].child_frame_id == "g1/" + chain.link_names[0] or base[0].child_frame_id.startswith("g1/")
    assert all(s.child_frame_id.startswith("g1/") for s in first)
    worst = check_poses(chain, topics["/tf_static"][0][2].transforms, [m for _, _, m in topics["/tf"]], qs, times, "g1/", "map")
    assert worst <= 1e-14 * max(1.0, np.abs(qs[:, :3]).max()), worst


def test_an_empty_topic_gives_the_static_frames_and_bad_input_raises(tmp_path):
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    bag = str(tmp_path / "empty.mcap")
    b = Bag(bag)
    b.channel("/joint_states")
    b.close()
    out = str(tmp_path / "tf.mcap")
    summary = kc.logs.write_tf(chain, bag, out)
    assert summary["messages"] == 0
    topics = read_mcap_ros2(out)
    assert "/tf" not in topics and len(topics["/tf_static"][0][2].transforms) == summary["fixed"] > 0

    # Never over the input; a log without one of the joints; a row out of the limits.
    with pytest.raises(kc.Error):
        kc.logs.write_tf(chain, bag, bag)
    assert os.path.getsize(bag) > 0
    pd = pytest.importorskip("pandas")
    with pytest.raises(kc.StateError, match="panda_joint7"):
        kc.logs.write_tf(chain, pd.DataFrame({"time": [1], **{f"panda_joint{i}": [0.0] for i in range(1, 7)}}), out)
    q = chain.random(1, seed=1)
    q[0, 3] = 5.0
    table = pd.DataFrame({"time": [5], **{n: q[:, k] for k, n in enumerate(chain.q_names)}})
    with pytest.raises(kc.StateError, match="row 0"):
        kc.logs.write_tf(chain, table, out)
    # A LeRobot-style episode: float seconds, a list column in degrees.
    pa = pytest.importorskip("pyarrow")
    arm = chain.random(3, seed=5)
    episode = pa.table({
        "timestamp": pa.array([0.0, 0.5, 1.0]),
        "observation.state": pa.FixedSizeListArray.from_arrays(
            pa.array(np.where(np.array(chain.q_units) == "rad", np.rad2deg(arm), arm).ravel()), chain.nq),
    })
    summary = kc.logs.write_tf(chain, episode, out, time="timestamp", q_column="observation.state", units="deg")
    topics = read_mcap_ros2(out)
    assert [t for t, _, _ in topics["/tf"]] == [0, 500_000_000, 1_000_000_000]
    assert check_poses(chain, topics["/tf_static"][0][2].transforms, [m for _, _, m in topics["/tf"]], arm,
                       [0, 500_000_000, 1_000_000_000]) <= 2e-15
    # A bag whose messages carry subsets of the joints: rows before all are known are left out.
    partial = str(tmp_path / "partial.mcap")
    b = Bag(partial)
    c = b.channel("/joint_states")
    names, v = chain.q_names, chain.random(1, seed=2)[0]
    b.write(c, joint_state(10, names[:4], v[:4]), 10)
    b.write(c, joint_state(20, names[4:], v[4:]), 20)
    b.write(c, joint_state(30, names[:1], v[:1]), 30)
    b.close()
    summary = kc.logs.write_tf(chain, partial, out)
    assert summary["messages"] == 2
    assert [t for t, _, _ in read_mcap_ros2(out)["/tf"]] == [20, 30]


def rotation(axis, angle):
    a = np.asarray(axis, dtype=float)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


@pytest.mark.parametrize("robot", ["panda.urdf", "puma560.yaml", "ur5.yaml", "so101.urdf"])
def test_the_tree_composes_to_the_poses(robot):
    """chain.joints and chain.parents describe the tree: composing parent · origin · M(θ, d) ·
    post from the root (eq. 2.119) gives chain.fk's poses."""
    chain = kc.load(os.path.join(ROOT, "robots", robot))
    q = chain.random(1, seed=3)[0]
    joints = chain.joints
    assert {j["child"]: j["parent"] for j in joints} == {k: v for k, v in chain.parents.items() if v is not None}
    poses = {name: np.eye(4) for name, parent in chain.parents.items() if parent is None}
    by_child = {j["child"]: j for j in joints}
    fk = chain.fk(q)

    def pose(link):
        if link not in poses:
            j = by_child[link]
            theta, d = j["theta"], j["d"]
            x = 0.0
            if j["mimic"] is not None:
                primary = next(k for k in joints if k["name"] == j["mimic"]["joint"])
                x = q[primary["q"]] * j["mimic"]["multiplier"] + j["mimic"]["offset"]
            elif j["q"] is not None:
                x = q[j["q"]]
            if j["type"] in ("revolute", "continuous"):
                theta += x
            elif j["type"] == "prismatic":
                d += x
            elif j["type"] != "fixed":
                pytest.skip(f"joint type {j['type']}")
            m = np.eye(4)
            m[:3, :3] = rotation(j["axis"], theta)
            m[:3, 3] = d * np.asarray(j["axis"])
            poses[link] = pose(j["parent"]) @ np.array(j["origin"]) @ m @ np.array(j["post"])
        return poses[link]

    for link in chain.link_names:
        assert np.abs(pose(link) - fk[link]).max() < 1e-14, link
