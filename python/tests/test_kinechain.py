"""The Python package: loading, shapes, agreement with the 50-digit reference data, batches
against single evaluations bit for bit, Jacobians against velocities, errors as exceptions,
pickling."""

import glob
import json
import os
import pickle

import numpy as np
import pytest

import kinechain as kc

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
ROBOTS = sorted(glob.glob(os.path.join(ROOT, "robots", "*.yaml")) + glob.glob(os.path.join(ROOT, "robots", "*.urdf")))
REFERENCE = sorted(glob.glob(os.path.join(ROOT, "tests", "data", "reference", "*", "*.hp.json")))


def random_q(chain, n, seed=1):
    rng = np.random.default_rng(seed)
    lo = np.where(np.isfinite(chain.lower), chain.lower, -np.pi)
    hi = np.where(np.isfinite(chain.upper), chain.upper, np.pi)
    return lo + (hi - lo) * rng.random((n, chain.dof))


@pytest.mark.parametrize("path", ROBOTS, ids=os.path.basename)
def test_every_bundled_robot_loads_and_evaluates(path):
    chain = kc.load(path)
    assert chain.dof == len(chain.joint_names) > 0
    assert len(chain.link_names) == len(set(chain.link_names))
    assert repr(chain) == f"Chain(name='{chain.name}', dof={chain.dof}, links={len(chain.link_names)})"
    n = chain.neutral()
    assert np.all(chain.lower <= n) and np.all(n <= chain.upper)
    r = chain.fk(n)
    assert r.poses.shape == (len(chain.link_names), 4, 4)
    assert r.links == chain.link_names
    assert np.array_equal(r.poses[:, 3, :], np.tile([0.0, 0.0, 0.0, 1.0], (len(r.links), 1)))
    for pose in r.poses:
        rot = pose[:3, :3]
        assert np.abs(rot @ rot.T - np.eye(3)).max() < 1e-14


def model_yaml(ref):
    """The DH YAML of a reference file's DH or axis-form model (as tests/common/mod.rs writes it)."""
    m = ref["model"]

    def f(x):
        return repr(float(x))

    def matrix(v):
        return "[" + ", ".join("[" + ", ".join(f(x) for x in row) + "]" for row in v) + "]"

    out = [f"name: {ref['robot']}"]
    if m["kind"] == "dh":
        out += [f"convention: {m['convention']}", f"base: {{name: link0, matrix: {matrix(m['base'])}}}",
                f"tool: {{name: tool, matrix: {matrix(m['tool'])}}}", "joints:"]
        for j in m["joints"]:
            assert not j["flip"]
            theta, d = (j["offset"], j["d"]) if j["type"] == "revolute" else (j["theta"], j["offset"])
            lo, hi = j["qlim"]
            out.append(f"  - {{name: {j['name']}, link: {j['link']}, type: {j['type']}, a: {f(j['a'])}, "
                       f"alpha: {f(j['alpha'])}, d: {f(d)}, theta: {f(theta)}, limits: [{f(lo)}, {f(hi)}]}}")
    else:
        assert m["kind"] == "axis", m["kind"]
        out += ["convention: axis", f"base: {{name: {m['base_link']}}}", "joints:"]
        for j in m["joints"]:
            out += [f"  - name: {j['name']}", f"    link: {j['link']}", f"    type: {j['type']}",
                    f"    origin: {{matrix: {matrix(j['origin'])}}}",
                    "    axis: [" + ", ".join(f(x) for x in j["axis"]) + "]"]
    return "\n".join(out) + "\n"


@pytest.mark.parametrize("path", REFERENCE, ids=lambda p: os.path.relpath(p, os.path.join(ROOT, "tests", "data", "reference")))
def test_the_reference_data_within_1e_10(path):
    """Every model of the reference data: poses, velocities and accelerations of every link."""
    with open(path) as f:
        ref = json.load(f)
    if ref["model"]["kind"] == "urdf":
        chain = kc.load(os.path.join(os.path.dirname(path), ref["model"]["file"]))
    else:
        chain = kc.Chain.from_yaml_string(model_yaml(ref))
    names = chain.joint_names
    samples = ref["samples"]
    def vector(values):
        # A cylindrical joint's entries are NAME.theta and NAME.d, its value [theta, d].
        return [values[n[:-6]][0] if n.endswith(".theta") and n[:-6] in values
                else values[n[:-2]][1] if n.endswith(".d") and n[:-2] in values
                else values[n] for n in names]

    q = np.array([vector(s["q"]) for s in samples])
    qd = np.array([vector(s["qd"]) for s in samples])
    qdd = np.array([vector(s["qdd"]) for s in samples])
    r = chain.fk(q, qd, qdd, check_limits=False)
    for i, s in enumerate(samples):
        for link, want in s["links"].items():
            k = r.links.index(link)
            pose = np.array([[float(x) for x in row] for row in want["pose"]])
            assert np.abs(r.poses[i, k] - pose).max() < 1e-10, (link, i)
            for field in ("omega", "v", "alpha", "a"):
                got = getattr(r, field)[i, k]
                exp = np.array([float(x) for x in want[field]])
                assert np.abs(got - exp).max() < 1e-10 * max(1.0, np.abs(exp).max()), (link, field, i)
    # Poses alone go through the batch kernels; they equal the poses computed with the rates.
    poses = chain.fk(q, check_limits=False).poses
    assert np.array_equal(poses, r.poses)


@pytest.mark.parametrize("name", ["panda.urdf", "ur5.yaml", "puma560.yaml", "cylindrical.yaml"])
def test_batches_equal_single_evaluations_bit_for_bit(name):
    chain = kc.load(os.path.join(ROOT, "robots", name))
    # Batches run in blocks of configurations (512 with rates): several blocks and a partial one.
    q = random_q(chain, 1100)
    qd = random_q(chain, 1100, seed=2)
    qdd = random_q(chain, 1100, seed=3)
    for args in [(q,), (q, qd), (q, qd, qdd)]:
        batch = chain.fk(*args)
        one_thread = chain.fk(*args, threads=1)
        for field in ("poses", "omega", "v", "alpha", "a"):
            b = getattr(batch, field)
            assert (b is None) == (getattr(one_thread, field) is None)
            if b is not None:
                assert np.array_equal(b, getattr(one_thread, field))
        for i in (0, 7, 150, 511, 512, 1023, 1099):
            single = chain.fk(*(a[i] for a in args))
            for field in ("poses", "omega", "v", "alpha", "a"):
                if getattr(single, field) is not None:
                    assert np.array_equal(getattr(single, field), getattr(batch, field)[i]), field
    # Chosen links: the same numbers, in the order asked for, only those computed.
    pick = [chain.link_names[-1], chain.link_names[1]]
    sub = chain.fk(q, links=pick)
    assert sub.links == pick
    full = chain.fk(q)
    assert np.array_equal(sub.poses[:, 0], full[pick[0]])
    assert np.array_equal(sub[pick[1]], full[pick[1]])
    assert np.array_equal(chain.fk(q, links=pick[0]).poses[:, 0], full[pick[0]])
    assert np.array_equal(chain.fk(q[5], links=[pick[0]]).poses[0], full[pick[0]][5])
    # Requests alternating between link lists (the last one's lookup is reused): each result
    # has the links it asked for, and a changed list or a bad name in it is seen.
    for asked in ([pick[0]], [pick[0]], pick, [pick[1]], [pick[1], pick[0]], [pick[0]]):
        r = chain.fk(q[5], links=asked)
        assert r.links == asked
        for k, name in enumerate(asked):
            assert np.array_equal(r.poses[k], full[name][5])
    with pytest.raises(kc.Error, match="no_such_link"):
        chain.fk(q[5], links=[pick[0], "no_such_link"])
    with pytest.raises(TypeError):
        chain.fk(q[5], links=[pick[0], 3])
    assert chain.fk(q[5], links=[pick[0]]).links == [pick[0]]
    # An empty batch.
    assert chain.fk(q[:0]).poses.shape == (0, len(chain.link_names), 4, 4)


def test_jacobians_map_joint_rates_to_link_velocities():
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    q, qd = random_q(chain, 40), random_q(chain, 40, seed=5)
    link = "panda_hand"
    j = chain.jacobian(q, link)
    assert j.shape == (40, 6, chain.dof)
    r = chain.fk(q, qd, links=[link])
    twist = np.einsum("nij,nj->ni", j, qd)
    assert np.abs(twist[:, :3] - r.v[:, 0]).max() < 1e-13
    assert np.abs(twist[:, 3:] - r.omega[:, 0]).max() < 1e-13
    assert np.array_equal(chain.jacobian(q[3], link), j[3])
    assert np.array_equal(chain.jacobian(q, link, threads=1), j)
    # In the link's axes: the world rows turned by the rotation's transpose.
    rt = np.swapaxes(r.poses[:, 0, :3, :3], -1, -2)
    local = chain.jacobian(q, link, frame="link")
    assert np.abs(local[:, :3] - rt @ j[:, :3]).max() < 1e-13
    assert np.abs(local[:, 3:] - rt @ j[:, 3:]).max() < 1e-13
    assert np.array_equal(chain.jacobian(q[7], link, frame="link"), local[7])
    # At a point fixed on the link: v + omega x (R u).
    u = np.array([0.0, 0.0, 0.1034])
    at = chain.jacobian(q, link, point=u)
    ru = r.poses[:, 0, :3, :3] @ u
    expected = twist[:, :3] + np.cross(twist[:, 3:], ru)
    assert np.abs(np.einsum("nij,nj->ni", at, qd)[:, :3] - expected).max() < 1e-13
    assert np.array_equal(chain.jacobian(q[5], link, point=u), at[5])
    for bad in [dict(frame="body"), dict(frame="link", point=u), dict(point=[np.nan, 0, 0])]:
        with pytest.raises(kc.Error):
            chain.jacobian(q, link, **bad)


def test_array_likes_and_views_give_the_same_numbers():
    chain = kc.load(os.path.join(ROOT, "robots", "ur5.yaml"))
    q = random_q(chain, 10)
    want = chain.fk(q).poses
    assert np.array_equal(chain.fk(q.tolist()).poses, want)
    assert np.array_equal(chain.fk(np.asfortranarray(q)).poses, want)
    wide = np.zeros((10, 2 * chain.dof))
    wide[:, ::2] = q
    assert np.array_equal(chain.fk(wide[:, ::2]).poses, want)
    assert np.array_equal(chain.fk(q.astype(np.float32).astype(np.float64)).poses, chain.fk(q.astype(np.float32)).poses)
    ints = np.zeros((2, chain.dof), dtype=np.int64)
    assert np.array_equal(chain.fk(ints).poses[0], chain.fk(np.zeros(chain.dof)).poses)


def test_bad_input_raises_exceptions_naming_what_is_wrong():
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    n = chain.neutral()
    cases = [
        (lambda: chain.fk(n[:3]), kc.StateError, "3 entries"),
        (lambda: chain.fk(np.zeros((2, 2, chain.dof))), kc.StateError, "shape"),
        (lambda: chain.fk(np.zeros(())), kc.StateError, "shape"),
        (lambda: chain.fk(np.where(np.arange(chain.dof) == 2, np.nan, n)), kc.StateError, "panda_joint3"),
        (lambda: chain.fk(np.where(np.arange(chain.dof) == 0, np.inf, n)), kc.StateError, "panda_joint1"),
        (lambda: chain.fk(np.where(np.arange(chain.dof) == 3, 1.0, n)), kc.StateError, "panda_joint4"),
        (lambda: chain.fk(np.tile(n, (5, 1)), np.zeros((4, chain.dof))), kc.StateError, "shape"),
        (lambda: chain.fk(n, None, n), kc.StateError, "qdd needs qd"),
        (lambda: chain.fk(n, np.where(np.arange(chain.dof) == 1, np.nan, 0.0)), kc.StateError, "panda_joint2"),
        (lambda: chain.fk(["a"] * chain.dof), kc.StateError, "float64"),
        (lambda: chain.fk(n, links=["panda_hnd"]), kc.Error, "panda_hand"),
        (lambda: chain.jacobian(n, "nowhere"), kc.Error, "nowhere"),
        (lambda: chain.fk(n, threads=0), kc.Error, "threads"),
        (lambda: chain.fk(np.tile(n, (100, 1)), threads=-2), kc.Error, "threads"),
        (lambda: kc.load(os.path.join(ROOT, "robots", "missing.urdf")), kc.LoadError, "missing.urdf"),
        (lambda: kc.Chain.from_urdf_string("<robot name='r'><link name='a'/><joint name='j' type='revolute'><parent link='a'/><child link='b'/></joint></robot>"), kc.LoadError, "line 1"),
        (lambda: kc.Chain.from_yaml_string("name: x\njoints: 3\n"), kc.LoadError, "joints"),
    ]
    for call, kind, says in cases:
        with pytest.raises(kind) as info:
            call()
        assert isinstance(info.value, ValueError) and isinstance(info.value, kc.Error)
        assert says in str(info.value), str(info.value)
    # A batch names the configuration at fault.
    qs = np.tile(n, (1000, 1))
    qs[617, 3] = 1.0
    with pytest.raises(kc.StateError, match="configuration 617: joint 'panda_joint4'"):
        chain.fk(qs)
    with pytest.raises(kc.StateError, match="configuration 617"):
        chain.fk(qs, np.zeros_like(qs))
    with pytest.raises(kc.StateError, match="configuration 617"):
        chain.jacobian(qs, "panda_hand")
    # One-link batches run in blocks of configurations: a fault past the first block, on one
    # thread and on all, and the first of two faults in different blocks.
    many = np.tile(n, (5000, 1))
    many[4321, 0] = np.nan
    many[2500, 1] = 9.0
    for threads in (1, None):
        with pytest.raises(kc.StateError, match="configuration 2500: joint 'panda_joint2'"):
            chain.fk(many, links=["panda_hand"], threads=threads)
    many[2500, 1] = 0.0
    with pytest.raises(kc.StateError, match="configuration 4321"):
        chain.fk(many, links="panda_hand")
    # With the limits unchecked the values are evaluated.
    assert chain.fk(qs, check_limits=False).poses.shape[0] == 1000
    with pytest.raises(KeyError, match="no link named 'x'"):
        chain.fk(n)["x"]
    # A result's list of links is its own: changing it changes no other result.
    r = chain.fk(n)
    r.links.append("x")
    r.links.clear()
    assert chain.fk(n).links == chain.link_names == r.links and len(r) == len(chain.link_names)


def test_chains_pickle_and_compare_equal():
    for path in ROBOTS:
        chain = kc.load(path)
        back = pickle.loads(pickle.dumps(chain))
        assert back == chain and hash(back) == hash(chain)
        assert back.joint_names == chain.joint_names
        q = chain.neutral()
        assert np.array_equal(back.fk(q).poses, chain.fk(q).poses)
    a, b = kc.load(ROBOTS[0]), kc.load(ROBOTS[1])
    assert a != b and a != "a chain"


def test_strings_load_like_files():
    path = os.path.join(ROOT, "robots", "planar3.yaml")
    with open(path) as f:
        chain = kc.Chain.from_yaml_string(f.read())
    assert chain == kc.Chain.from_file(path)
    r = chain.fk([0.3, -0.2, 0.5], [1.0, 0.5, -0.2])
    x = 4 * np.cos(0.3) + 3 * np.cos(0.1) + 2 * np.cos(0.6)
    assert abs(r["link3"][0, 3] - x) < 1e-14
    assert np.array_equal(r.omega[-1], [0.0, 0.0, 1.3])
    with open(os.path.join(ROOT, "robots", "panda.urdf")) as f:
        assert kc.Chain.from_urdf_string(f.read()).dof == 8
    assert kc.__version__


@pytest.mark.parametrize("page", ["README.md", os.path.join("docs", "python.md")])
def test_the_documented_python_examples_run(page, monkeypatch):
    with open(os.path.join(ROOT, page)) as f:
        text = f.read()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    assert blocks, page
    monkeypatch.chdir(ROOT)
    for block in blocks:
        exec(compile(block, page, "exec"), {})


def test_orientation_coordinates_recompose_to_the_matrices():
    from kinechain import orientation as ko

    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    poses = chain.fk(random_q(chain, 50)).poses  # (50, 13, 4, 4)
    rot = poses[..., :3, :3]
    w, x, y, z = np.moveaxis(ko.quaternion_from_matrix(poses), -1, 0)
    assert w.shape == (50, 13) and np.all(w >= 0)
    quat_matrix = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )
    assert np.abs(quat_matrix - rot).max() < 1e-14
    roll, pitch, yaw = np.moveaxis(ko.rpy_from_matrix(rot), -1, 0)

    def rx(a):
        c, s, o, i = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
        return np.stack([np.stack([i, o, o], -1), np.stack([o, c, -s], -1), np.stack([o, s, c], -1)], -2)

    def ry(a):
        c, s, o, i = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
        return np.stack([np.stack([c, o, s], -1), np.stack([o, i, o], -1), np.stack([-s, o, c], -1)], -2)

    def rz(a):
        c, s, o, i = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
        return np.stack([np.stack([c, -s, o], -1), np.stack([s, c, o], -1), np.stack([o, o, i], -1)], -2)

    finite = ~np.isnan(roll)
    assert finite.sum() > 500
    assert np.abs((rz(yaw) @ ry(pitch) @ rx(roll))[finite] - rot[finite]).max() < 1e-13
    phi, theta, psi = np.moveaxis(ko.euler_zxz_from_matrix(rot), -1, 0)
    ok = ~np.isnan(phi)
    assert np.abs((rz(phi) @ rx(theta) @ rz(psi))[ok] - rot[ok]).max() < 1e-13
    aa = ko.axis_angle_from_matrix(rot)
    g = ko.rodrigues_from_matrix(rot)
    ok = ~np.isnan(aa[..., 0]) & ~np.isnan(g[..., 0])
    # Relative: the parameters grow without bound towards a half turn.
    assert (np.abs(np.tan(aa[..., 3] / 2)[..., None] * aa[..., :3] - g) / (1 + np.abs(g)))[ok].max() < 1e-13
    # Undefined coordinates are NaN; bad shapes and kinds are errors.
    assert np.isnan(ko.axis_angle_from_matrix(np.eye(3))).all()
    assert np.isnan(ko.euler_zxz_from_matrix(np.eye(3))).all()
    assert np.array_equal(ko.quaternion_from_matrix(np.eye(3)), [1.0, 0.0, 0.0, 0.0])
    with pytest.raises(kc.StateError, match="shape"):
        ko.rpy_from_matrix(np.eye(2))
    with pytest.raises(kc.StateError, match="not finite"):
        ko.rpy_from_matrix(np.full((3, 3), np.nan))


def test_batches_release_the_gil_while_they_run():
    import threading
    import time

    chain = kc.load(os.path.join(ROOT, "robots", "snake50.yaml"))
    tip = chain.link_names[-1]
    n = 20_000
    while True:
        q = random_q(chain, n)
        start = time.perf_counter()
        chain.fk(q, links=[tip], threads=1)
        took = time.perf_counter() - start
        if took > 0.15 or n >= 2_000_000:
            break
        n *= 4
    done = threading.Event()

    def work():
        chain.fk(q, links=[tip], threads=1)
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    # While the batch runs, this thread keeps running: no pause near the batch's length.
    last, longest = time.perf_counter(), 0.0
    while not done.is_set():
        now = time.perf_counter()
        longest = max(longest, now - last)
        last = now
    worker.join()
    assert longest < 0.5 * took, (longest, took)


def test_poses_can_be_written_into_an_array_of_the_caller():
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    q = random_q(chain, 1000)
    want = chain.fk(q).poses
    out = np.full_like(want, np.nan)
    r = chain.fk(q, out=out)
    assert r.poses is out and np.array_equal(out, want)
    one = np.empty((1, 4, 4))
    assert chain.fk(q[3], links=["panda_hand"], out=one).poses is one
    assert np.array_equal(one[0], want[3, chain.link_names.index("panda_hand")])
    with pytest.raises(kc.StateError, match="shape"):
        chain.fk(q, out=np.empty((1000, 2, 4, 4)))
    with pytest.raises(kc.StateError, match="float64"):
        chain.fk(q, out=np.empty(want.shape, dtype=np.float32))
    frozen = np.empty_like(want)
    frozen.flags.writeable = False
    with pytest.raises(kc.StateError, match="out"):
        chain.fk(q, out=frozen)
    # An output that shares memory with the input is refused.
    buffer = np.zeros(want.size + q.size)
    qv = buffer[: q.size].reshape(q.shape)
    qv[:] = q
    with pytest.raises(kc.StateError, match="out"):
        chain.fk(qv, out=buffer[: want.size].reshape(want.shape))


@pytest.mark.parametrize("batched", [False, True])
def test_rates_and_jacobians_can_be_written_into_arrays_of_the_caller(batched):
    """`out=` takes a result of an earlier call with the same links and quantities (all its
    arrays written again), and `jacobian(..., out=)` an array of the Jacobian's shape."""
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    qs = random_q(chain, 50, seed=5)
    qds, qdds = random_q(chain, 50, seed=6), random_q(chain, 50, seed=7)
    pick = (lambda a: a) if batched else (lambda a: a[0])
    q, qd, qdd = pick(qs), pick(qds), pick(qdds)
    for args, links in (((q, qd), None), ((q, qd, qdd), None), ((q, qd, qdd), ["panda_hand", "panda_link2"])):
        want = chain.fk(*args, links=links)
        r = chain.fk(*(a * 0.5 for a in args), links=links)
        again = chain.fk(*args, links=links, out=r)
        for name in ("poses", "omega", "v", "alpha", "a"):
            got, expect = getattr(again, name), getattr(want, name)
            assert (got is None) == (expect is None)
            if got is not None:
                assert got is getattr(r, name) and np.array_equal(got, expect), name
    # The result of a call with other quantities or other links is refused, unchanged.
    r = chain.fk(q, qd)
    before = r.poses.copy()
    with pytest.raises(kc.StateError, match="holds poses and velocities, this call computes poses, velocities and accelerations"):
        chain.fk(q, qd, qdd, out=r)
    with pytest.raises(kc.StateError, match="other links"):
        chain.fk(q, qd, links=["panda_hand"], out=r)
    with pytest.raises(kc.StateError, match="holds poses and velocities, this call computes poses"):
        chain.fk(q, out=r)
    assert np.array_equal(r.poses, before)
    # An output array that shares memory with an input is refused.
    r = chain.fk(q, qd)
    with pytest.raises(kc.StateError, match="out.omega"):
        chain.fk(q, r.omega.reshape(-1)[: qd.size].reshape(qd.shape), out=r)
    # Jacobians.
    want = chain.jacobian(q, "panda_hand")
    J = np.full_like(want, np.nan)
    assert chain.jacobian(q, "panda_hand", out=J) is J and np.array_equal(J, want)
    with pytest.raises(kc.StateError, match="shape"):
        chain.jacobian(q, "panda_hand", out=np.empty((7,) + want.shape))
    with pytest.raises(kc.StateError, match="float64"):
        chain.jacobian(q, "panda_hand", out=want.astype(np.float32))
    buffer = np.zeros(want.size + q.size)
    qv = buffer[: q.size].reshape(q.shape)
    qv[:] = q
    with pytest.raises(kc.StateError, match="out shares memory with q|out: "):
        chain.jacobian(qv, "panda_hand", out=buffer[: want.size].reshape(want.shape))


def test_the_benchmarks_rust_timing_runs_the_same_batches():
    from kinechain import _kinechain

    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    qs = np.tile(chain.neutral(), (100, 1))
    for kwargs in ({}, {"links": ["panda_hand"]}, {"qd": qs}, {"qd": qs, "qdd": qs}, {"jacobian": "panda_hand"}):
        for fresh in (False, True):
            t = _kinechain._rust_batch(chain, qs, repeats=2, fresh=fresh, **kwargs)
            assert 0.0 < t < 1.0, kwargs
    bad = qs.copy()
    bad[7, 0] = 100.0
    with pytest.raises(kc.StateError, match="configuration 7"):
        _kinechain._rust_batch(chain, bad)
    with pytest.raises(kc.StateError, match="configuration 7"):
        _kinechain._rust_batch(chain, bad, fresh=True)
    with pytest.raises(kc.StateError):
        _kinechain._rust_batch(chain, chain.neutral())


def test_single_calls_never_change_an_array_still_referred_to():
    """One configuration's poses may be written into an array an earlier call returned, but only
    when nothing refers to it any more (results, views and weak references keep their numbers),
    and only when it is still what a new one would be (shape, type and flags unchanged)."""
    import gc
    import weakref

    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    qs = random_q(chain, 8, seed=3)
    expect = [chain.fk(q.copy()).poses.copy() for q in qs]  # (copies: fresh values to compare with)

    # Results kept alive, and views of them, keep their values through later calls.
    kept = [chain.fk(q) for q in qs[:4]]
    views = [chain.poses(q)[2] for q in qs[4:]]
    for _ in range(3):
        for q in qs:
            chain.fk(q)
            chain.poses(q)
    for r, e in zip(kept, expect[:4]):
        assert np.array_equal(r.poses, e)
    for v, e in zip(views, expect[4:]):
        assert np.array_equal(v, e[2])

    # Jacobians likewise.
    J = [chain.jacobian(q, "panda_hand") for q in qs[:3]]
    want = [j.copy() for j in J]
    for q in qs:
        chain.jacobian(q, "panda_hand", frame="link")
    for j, w in zip(J, want):
        assert np.array_equal(j, w)
    for q, w in zip(qs[:3], want):
        assert np.array_equal(chain.jacobian(q, "panda_hand"), w)

    # Dropped results are reused, each call's numbers its own.
    for _ in range(2):
        for q, e in zip(qs, expect):
            p = chain.poses(q)
            assert np.array_equal(p, e)
            assert np.array_equal(chain.fk(q).poses, e)

    # A weak reference, or an array changed in place, is not reused.
    p = chain.poses(qs[0])
    w = weakref.ref(p)
    del p
    gc.collect()
    for q in qs:
        chain.poses(q)
    if w() is not None:
        assert np.array_equal(w(), expect[0])
    # An array changed in place and dropped is not handed out again as it is: every result is
    # a writeable float64 (13, 4, 4) array.
    for change in (lambda a: setattr(a, "shape", (13, 16)), lambda a: a.setflags(write=False), lambda a: setattr(a, "dtype", np.int64)):
        p = chain.poses(qs[1])
        change(p)
        del p
        for q, e in zip(qs, expect):
            p = chain.poses(q)
            assert p.dtype == np.float64 and p.shape == (13, 4, 4) and p.flags.writeable and p.flags.c_contiguous
            assert np.array_equal(p, e)
            del p


def test_pose_and_poses_are_fk_in_one_call():
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    qs = random_q(chain, 5, seed=4)
    for q in qs:
        r = chain.fk(q)
        assert np.array_equal(chain.poses(q), r.poses)
        assert np.array_equal(chain.poses(q, links=["panda_hand", "panda_link3"]), r.poses[[r.links.index("panda_hand"), r.links.index("panda_link3")]])
        assert chain.pose(q, "panda_hand").shape == (4, 4)
        assert np.array_equal(chain.pose(q, "panda_hand"), r["panda_hand"])
        # Lists and tuples as well as arrays; the same numbers.
        assert np.array_equal(chain.pose(list(q), "panda_hand"), r["panda_hand"])
        assert np.array_equal(chain.poses(tuple(q)), r.poses)
    assert np.array_equal(chain.pose(qs, "panda_hand", threads=1), chain.fk(qs, links=["panda_hand"]).poses[:, 0])
    assert np.array_equal(chain.poses(qs), chain.fk(qs).poses)
    out = np.empty((5, 13, 4, 4))
    assert chain.poses(qs, out=out) is not None and np.array_equal(out, chain.fk(qs).poses)
    with pytest.raises(kc.Error, match="no link named"):
        chain.pose(qs[0], "nope")
    with pytest.raises(kc.StateError, match=f"{chain.dof - 1} entries per configuration"):
        chain.pose(qs[0][:-1], "panda_hand")
    with pytest.raises(kc.StateError, match="above its upper limit|out of|limit"):
        chain.poses(chain.upper + 1.0)
    assert chain.poses(chain.upper + 1.0, check_limits=False).shape == (13, 4, 4)
    with pytest.raises(kc.Error, match="threads"):
        chain.pose(qs[0], "panda_hand", threads=0)
    with pytest.raises(TypeError):
        chain.pose(qs[0], 3)


def test_link_requests_are_recognised_whatever_their_container():
    """The links of the last request are reused when the next names the same ones (a list, a
    tuple or one name; equal strings or the same objects), and never when they differ."""
    chain = kc.load(os.path.join(ROOT, "robots", "panda.urdf"))
    q = chain.neutral()
    full = chain.fk(q)
    for asked in (["panda_hand"], ("panda_hand",), "panda_hand", ["panda_" + "hand"], ["panda_link2", "panda_hand"], ["panda_hand", "panda_link2"], ["panda_hand"]):
        names = [asked] if isinstance(asked, str) else list(asked)
        r = chain.fk(q, links=asked)
        assert r.links == names
        assert np.array_equal(r.poses, np.stack([full[n] for n in names]))
    # A generator is read once, like any iterable.
    r = chain.fk(q, links=(n for n in ["panda_link1", "panda_link4"]))
    assert r.links == ["panda_link1", "panda_link4"]
    with pytest.raises(TypeError):
        chain.fk(q, links=[1])
