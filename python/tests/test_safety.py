"""What the package must never do: return numbers from memory nobody wrote, miss an aliased
output, return inf or NaN from finite input without an error, abort on a failed allocation, hang
after ``fork``, lose a chain's name in pickling, hang on a FIFO or ignore Ctrl-C, read a golden
file without bounds, or replace a file it should write through."""

import os
import pickle
import signal
import stat
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import kinechain as kc
import kinechain.testing

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
PANDA = os.path.join(ROOT, "robots", "panda.urdf")
PLANAR3 = os.path.join(ROOT, "robots", "planar3.yaml")

FIXED_ONLY = """<robot name="fixed">
  <link name="a"/><link name="b"/>
  <joint name="mount" type="fixed"><parent link="a"/><child link="b"/><origin xyz="0 0 1"/></joint>
</robot>"""

TWO_SLIDES = """name: slides
convention: standard
joints:
- {name: j1, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}
- {name: j2, type: prismatic, a: 0, alpha: 0, d: 0, theta: 0}
"""


def test_a_chain_without_moving_joints_gives_its_poses_in_every_row():
    chain = kc.Chain.from_urdf_string(FIXED_ONLY)
    for links in (None, ["b"]):
        r = chain.fk(np.zeros((5, 0)), links=links)
        want = chain.fk(np.zeros(0), links=links).poses
        assert r.poses.shape == (5,) + want.shape
        assert np.array_equal(r.poses, np.broadcast_to(want, r.poses.shape))
    r = chain.fk(np.zeros((3, 0)), np.zeros((3, 0)), np.zeros((3, 0)), links=["b"])
    assert np.array_equal(r.v, np.zeros((3, 1, 3)))
    assert np.array_equal(r.a, np.zeros((3, 1, 3)))
    assert chain.jacobian(np.zeros((4, 0)), "b").shape == (4, 6, 0)


def test_an_output_sharing_memory_with_q_is_refused():
    chain = kc.load(PLANAR3)
    n = 4
    buf = bytearray(8 * (n * 4 * 16 + n * 3))
    out = np.frombuffer(buf, dtype=np.float64, count=n * 4 * 16).reshape(n, 4, 4, 4)
    q = np.frombuffer(buf, dtype=np.float64, count=n * 3, offset=8 * 40).reshape(n, 3)
    q[:] = 0.1
    with pytest.raises(kc.StateError, match="out shares memory with q"):
        chain.fk(q, out=out)
    # Apart in the same buffer: written.
    q2 = np.frombuffer(buf, dtype=np.float64, count=n * 3, offset=8 * n * 4 * 16).reshape(n, 3)
    q2[:] = 0.1
    chain.fk(q2, out=out)
    assert np.array_equal(out, chain.fk(np.full((n, 3), 0.1)).poses)


def test_finite_joint_values_whose_poses_overflow_are_an_error():
    chain = kc.Chain.from_yaml_string(TWO_SLIDES)
    q = [1e308, 1e308]
    for links in (None, ["link2"]):
        with pytest.raises(kc.StateError, match="pose of link 'link2' overflows f64"):
            chain.fk(q, links=links)
        qs = np.zeros((3000, 2))
        qs[2500] = q
        for threads in (1, None):
            with pytest.raises(kc.StateError, match="configuration 2500: pose of link 'link2' overflows"):
                chain.fk(qs, links=links, threads=threads)
    with pytest.raises(kc.StateError, match="overflows"):
        chain.fk([0.0, 0.0], [1e308, 1e308])
    with pytest.raises(kc.StateError, match="configuration 1: v of link 'link2' overflows"):
        chain.fk(np.zeros((2, 2)), np.array([[0.0, 0.0], [1e308, 1e308]]))


def test_a_table_row_whose_poses_overflow_is_named_or_null():
    pd = pytest.importorskip("pandas")
    chain = kc.Chain.from_yaml_string(TWO_SLIDES)
    df = pd.DataFrame({"j1": [0.0, 1e308, 0.5], "j2": [0.0, 1e308, 0.5]})
    with pytest.raises(kc.StateError, match="row 1: pose of link 'link2' overflows"):
        kc.table.poses(df, chain, links=["link2"])
    out = kc.table.poses(df, chain, links=["link2"], on_error="null")
    assert np.isnan(out["link2.z"][1]) and out["link2.z"][2] == 1.0


def test_an_output_too_large_for_memory_is_a_memory_error():
    try:
        overcommit = open("/proc/sys/vm/overcommit_memory").read().strip()
    except OSError:
        overcommit = None
    if overcommit == "1":
        pytest.skip("the system grants any allocation (vm.overcommit_memory = 1)")
    chain = kc.load(PANDA)
    # 2.2 GB of q that is never touched (calloc'd pages), for 66 GB of poses.
    q = np.zeros((40_000_000, chain.dof))
    with pytest.raises(MemoryError):
        chain.fk(q)
    with pytest.raises(MemoryError):
        chain.jacobian(np.zeros((200_000_000, chain.dof)), "panda_hand")


def test_a_forked_child_runs_batches():
    chain = kc.load(PANDA)
    qs = np.tile(chain.neutral(), (20_000, 1))
    want = chain.fk(qs, links=["panda_hand"]).poses  # starts the pool in the parent
    pid = os.fork()
    if pid == 0:
        # The child: a batch on the default threads, then exit with its verdict.
        ok = False
        try:
            ok = np.array_equal(chain.fk(qs, links=["panda_hand"]).poses, want)
        finally:
            os._exit(0 if ok else 1)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0
            return
        time.sleep(0.05)
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    pytest.fail("the forked child's batch hung")


def test_pickling_keeps_a_name_that_came_from_the_file_name(tmp_path):
    text = open(PLANAR3).read()
    unnamed = "\n".join(line for line in text.splitlines() if not line.startswith("name:")) + "\n"
    path = tmp_path / "my_arm.yaml"
    path.write_text(unnamed)
    chain = kc.load(path)
    assert chain.name == "my_arm"
    again = pickle.loads(pickle.dumps(chain))
    assert again.name == "my_arm" and again == chain


def _fifo(tmp_path, name):
    path = tmp_path / name
    os.mkfifo(path)
    return path


def test_a_fifo_with_a_writer_loads(tmp_path):
    path = _fifo(tmp_path, "arm.yaml")
    text = open(PLANAR3).read()
    writer = threading.Thread(target=lambda: path.write_text(text))
    writer.start()
    chain = kc.load(path)
    writer.join(10)
    assert not writer.is_alive()
    assert chain.name == "planar3" and chain.link_names == kc.load(PLANAR3).link_names


def test_ctrl_c_stops_a_load_from_a_fifo_without_a_writer(tmp_path):
    path = _fifo(tmp_path, "arm.yaml")
    script = textwrap.dedent(f"""
        import kinechain as kc, sys
        print("ready", flush=True)
        try:
            kc.load({str(path)!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(0)
        sys.exit(1)
    """)
    _interrupt(script)


def _interrupt(script, wait=0.5):
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "ready"
    time.sleep(wait)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    try:
        out, _ = child.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        child.kill()
        pytest.fail("Ctrl-C did not stop the call")
    assert child.returncode == 0 and "interrupted" in out
    return time.monotonic() - sent


@pytest.mark.parametrize("threads", [1, None])
def test_ctrl_c_stops_a_long_batch(threads):
    script = textwrap.dedent(f"""
        import kinechain as kc, numpy as np, sys, time
        chain = kc.load({PANDA!r})
        qs = np.tile(chain.neutral(), (200_000, 1))
        print("ready", flush=True)
        start = time.monotonic()
        try:
            for _ in range(10_000):
                chain.fk(qs, threads={threads!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(0)
        sys.exit(1)
    """)
    took = _interrupt(script, wait=1.0)
    assert took < 5, f"stopped {took:.2f} s after Ctrl-C"


def test_a_golden_file_is_read_with_bounds():
    chain = kc.load(PLANAR3)
    with pytest.raises(kc.Error, match="line 1 is longer than the 33554432 bytes"):
        kc.testing.assert_matches_golden(chain, "/dev/zero")


def test_record_golden_follows_links_keeps_modes_and_never_overwrites_the_robot(tmp_path):
    chain = kc.load(PLANAR3)
    target = tmp_path / "target.jsonl"
    target.write_text("old")
    target.chmod(0o600)
    link = tmp_path / "link.jsonl"
    link.symlink_to(target)
    kc.testing.record_golden(chain, link, samples=3)
    assert link.is_symlink()
    assert stat.S_IMODE(target.stat().st_mode) == 0o600
    kc.testing.assert_matches_golden(chain, target)
    # The chain's own file, by path or through a link: refused, unchanged.
    robot = tmp_path / "arm.yaml"
    robot.write_text(open(PLANAR3).read())
    mine = kc.load(robot)
    to_robot = tmp_path / "to_robot.jsonl"
    to_robot.symlink_to(robot)
    for path in (robot, to_robot):
        with pytest.raises(kc.Error, match="refusing to overwrite"):
            kc.testing.record_golden(mine, path, samples=3)
    assert robot.read_text() == open(PLANAR3).read()
    # A FIFO is written in place.
    fifo = _fifo(tmp_path, "g.jsonl")
    got = []
    reader = threading.Thread(target=lambda: got.append(open(fifo).read()))
    reader.start()
    kc.testing.record_golden(chain, fifo, samples=3)
    reader.join(10)
    assert got and got[0] == target.read_text()
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    with pytest.raises(kc.Error, match="it is a directory"):
        kc.testing.record_golden(chain, tmp_path, samples=3)


def test_assert_same_kinematics_refuses_a_renamed_joint_unless_mapped():
    chain = kc.load(PANDA)
    renamed = kc.Chain.from_urdf_string(open(PANDA).read().replace('"panda_joint4"', '"elbow_joint"'))
    with pytest.raises(kc.Error, match="only in the first: 'panda_joint4'; only in the second: 'elbow_joint'"):
        kc.testing.assert_same_kinematics(chain, renamed, samples=5)
    report = kc.testing.assert_same_kinematics(chain, renamed, samples=5, rename={"panda_joint4": "elbow_joint"})
    assert report["samples"] > 0
    with pytest.raises(kc.Error, match="the second robot has no joint 'nope'"):
        kc.testing.assert_same_kinematics(chain, renamed, rename={"panda_joint4": "nope"})


@pytest.mark.parametrize("value,error", [(-1, ValueError), (1.5, TypeError), (True, TypeError), (2**64, ValueError)])
def test_counts_are_checked_by_name(value, error):
    chain = kc.load(PLANAR3)
    with pytest.raises(error, match="samples"):
        kc.testing.assert_same_kinematics(chain, chain, samples=value)
    with pytest.raises(error, match="seed"):
        kc.testing.assert_same_kinematics(chain, chain, seed=value)


def test_complex_and_masked_joint_values_are_refused():
    chain = kc.load(PLANAR3)
    with pytest.raises(TypeError, match="q holds complex numbers"):
        chain.fk(np.array([0.1 + 1j, 0.2, 0.3]))
    with pytest.raises(TypeError, match="qd holds complex numbers"):
        chain.fk([0.1, 0.2, 0.3], np.zeros(3, dtype=complex))
    masked = np.ma.masked_array([[0.1, 0.2, 0.3]] * 2, mask=[[0, 1, 0], [0, 0, 0]])
    with pytest.raises(kc.StateError, match="q is a masked array with masked entries"):
        chain.fk(masked)
    clear = np.ma.masked_array([0.1, 0.2, 0.3], mask=[0, 0, 0])
    assert np.array_equal(chain.fk(clear).poses, chain.fk([0.1, 0.2, 0.3]).poses)


def test_tables_are_checked_by_type_and_columns():
    pd = pytest.importorskip("pandas")
    chain = kc.load(PLANAR3)
    with pytest.raises(TypeError, match="pandas DataFrame or a pyarrow Table, not ndarray"):
        kc.table.poses(np.zeros((3, 3)), chain)
    df = pd.DataFrame([[0.1, 0.2, 0.3, 0.4]], columns=["j1", "j2", "j3", "j1"])
    with pytest.raises(kc.StateError, match="more than one column for joints 'j1'"):
        kc.table.poses(df, chain)
    pa = pytest.importorskip("pyarrow")
    t = pa.table([pa.array([0.1]), pa.array([0.2]), pa.array([0.3]), pa.array([0.4])], names=["j1", "j2", "j3", "j3"])
    with pytest.raises(kc.StateError, match="more than one column for joints 'j3'"):
        kc.table.poses(t, chain)
