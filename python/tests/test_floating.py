"""Floating bases against Pinocchio with a free-flyer root joint (``pip install pin``): every
link's pose, velocity, classical acceleration and Jacobian of the Unitree G1 and Go2 and of
TALOS, at seeded random configurations converted with ``to_layout("pinocchio")``; the layouts
both ways against MuJoCo's free joint; names, sizes, the sampler, pickling and the errors."""

import os
import pickle

import numpy as np
import pytest

import kinechain as kc

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
FLOATING = [
    os.path.join(ROOT, "robots", "g1.urdf"),
    os.path.join(ROOT, "robots", "go2.urdf"),
    os.path.join(ROOT, "tests", "data", "floating", "talos_full_v2.urdf"),
]

# The peers are installed in CI (KINECHAIN_REQUIRE_PEERS=1 there: a missing one fails the run
# instead of skipping its tests); elsewhere their tests are skipped without them.
def peer(name):
    if os.environ.get("KINECHAIN_REQUIRE_PEERS"):
        return __import__(name)
    return pytest.importorskip(name)


pin = peer("pinocchio")


def pinocchio_model(path):
    model = pin.buildModelFromUrdf(path, pin.JointModelFreeFlyer())
    return model, model.createData()


@pytest.mark.parametrize("path", FLOATING, ids=os.path.basename)
def test_poses_rates_and_jacobians_agree_with_pinocchios_free_flyer(path):
    chain = kc.load(path, floating_base=True)
    model, data = pinocchio_model(path)
    assert chain.to_layout(chain.neutral(), layout="pinocchio")[0].shape == (model.nq,)
    assert chain.q_names[:7] == ["root_joint.x", "root_joint.y", "root_joint.z", "root_joint.qw", "root_joint.qx", "root_joint.qy", "root_joint.qz"]
    assert chain.v_names[:6] == ["root_joint.vx", "root_joint.vy", "root_joint.vz", "root_joint.wx", "root_joint.wy", "root_joint.wz"]
    assert (chain.nq, chain.nv, chain.dof) == (len(chain.q_names), len(chain.v_names), chain.nv)
    rng = np.random.default_rng(7)
    qs = chain.random(20, seed=3, base=(-2.0, 2.0))
    qds = rng.uniform(-1, 1, (20, chain.nv))
    qdds = rng.uniform(-1, 1, (20, chain.nv))
    frames = {model.frames[i].name: i for i in range(model.nframes) if model.frames[i].type == pin.FrameType.BODY}
    links = [name for name in chain.link_names if name in frames]
    assert len(links) >= len(chain.link_names) - 2  # all but the world link
    worst = {"pose": 0.0, "v": 0.0, "a": 0.0, "J": 0.0}
    for q, qd, qdd in zip(qs, qds, qdds):
        pq, pv, pa = chain.to_layout(q, qd, qdd, layout="pinocchio")
        pin.forwardKinematics(model, data, pq, pv, pa)
        pin.updateFramePlacements(model, data)
        pin.computeJointJacobians(model, data, pq)
        r = chain.fk(q, qd, qdd, links=links)
        for k, name in enumerate(links):
            fid = frames[name]
            worst["pose"] = max(worst["pose"], np.abs(data.oMf[fid].homogeneous - r.poses[k]).max())
            vel = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            worst["v"] = max(worst["v"], np.abs(vel.linear - r.v[k]).max(), np.abs(vel.angular - r.omega[k]).max())
            acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            worst["a"] = max(worst["a"], np.abs(acc.linear - r.a[k]).max(), np.abs(acc.angular - r.alpha[k]).max())
            # The two Jacobians map their own rates to the same twist.
            J = chain.jacobian(q, name)
            Jp = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            worst["J"] = max(worst["J"], np.abs(J @ qd - Jp @ pv).max())
    # Random configurations of a metre-scale robot with rates of order 1: differences are
    # rounding (Pinocchio and kinechain compose in different orders).
    assert worst["pose"] < 1e-13, worst
    assert worst["v"] < 1e-12, worst
    assert worst["a"] < 1e-11, worst
    assert worst["J"] < 1e-12, worst


def test_layouts_agree_with_mujocos_free_joint():
    mujoco = peer("mujoco")
    # A free body with a hinge below it, as MuJoCo reads it, and the same robot in URDF.
    xml = """<mujoco><worldbody><body name="base"><freejoint name="root_joint"/>
        <geom size="0.1" mass="1"/>
        <body name="arm" pos="0.3 0 0"><joint name="hinge" axis="0 1 0" range="-1 1"/>
        <geom size="0.05" mass="1"/></body></body></worldbody></mujoco>"""
    urdf = """<robot name="m"><link name="world"/><link name="base"/><link name="arm"/>
        <joint name="root_joint" type="floating"><parent link="world"/><child link="base"/></joint>
        <joint name="hinge" type="revolute"><parent link="base"/><child link="arm"/>
        <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    chain = kc.Chain.from_urdf_string(urdf)
    rng = np.random.default_rng(2)
    for q in chain.random(10, seed=5):
        qd = rng.uniform(-1, 1, chain.nv)
        mq, mv, _ = chain.to_layout(q, qd, layout="mujoco")
        data.qpos[:] = mq
        data.qvel[:] = mv
        mujoco.mj_forward(model, data)
        r = chain.fk(q, qd)
        for name in ("base", "arm"):
            body = model.body(name).id
            k = r.links.index(name)
            assert np.allclose(data.xpos[body], r.poses[k][:3, 3], atol=1e-14)
            assert np.allclose(data.xmat[body].reshape(3, 3), r.poses[k][:3, :3], atol=1e-14)
            # MuJoCo's body velocity: [ω; v] of the body origin, in world axes.
            vel = np.zeros(6)
            mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_BODY, body, vel, 0)
            assert np.allclose(vel[:3], r.omega[k], atol=1e-13)
            assert np.allclose(vel[3:], r.v[k], atol=1e-13)
        back = chain.from_layout(mq, mv, layout="mujoco")
        assert np.allclose(back[0], q, atol=1e-15) and np.allclose(back[1], qd, atol=1e-15)


def test_batches_layouts_and_pickles_of_a_floating_chain():
    chain = kc.load(FLOATING[1], floating_base=True)
    qs = chain.random(100, seed=1)
    assert qs.shape == (100, chain.nq)
    assert np.allclose(np.linalg.norm(qs[:, 3:7], axis=1), 1.0)
    assert np.array_equal(qs, chain.random(100, seed=1))
    assert not np.array_equal(qs, chain.random(100, seed=2))
    assert np.all(np.abs(qs[:, :3]) <= 1.0)
    assert chain.random().shape == (chain.nq,)
    # Batches equal single evaluations bit for bit, on every thread count.
    qds = np.random.default_rng(0).uniform(-1, 1, (100, chain.nv))
    batch = chain.fk(qs, qds, threads=2)
    one = chain.fk(qs, qds, threads=1)
    assert np.array_equal(batch.poses, one.poses) and np.array_equal(batch.v, one.v)
    for i in (0, 37, 99):
        r = chain.fk(qs[i], qds[i])
        assert np.array_equal(batch.poses[i], r.poses) and np.array_equal(batch.omega[i], r.omega)
    J = chain.jacobian(qs, "base", threads=2)
    assert J.shape == (100, 6, chain.nv)
    assert np.array_equal(J[5], chain.jacobian(qs[5], "base"))
    # Layouts of rows of configurations, and back.
    pq, pv, pa = chain.to_layout(qs, qds, layout="pinocchio")
    assert pa is None and pq.shape == (100, chain.nq) and pv.shape == (100, chain.nv)
    back = chain.from_layout(pq, pv, layout="pinocchio")
    assert np.allclose(back[0], qs, atol=1e-15) and np.allclose(back[1], qds, atol=1e-14)
    # Pickling keeps the floating base.
    again = pickle.loads(pickle.dumps(chain))
    assert again == chain and again.nq == chain.nq
    assert again != kc.load(FLOATING[1])


def test_floating_errors_name_the_joint_and_what_makes_up_q():
    chain = kc.load(FLOATING[1], floating_base=True)
    q = chain.neutral()
    assert list(q[3:7]) == [1.0, 0.0, 0.0, 0.0]
    with pytest.raises(kc.StateError, match="the chain 'go2_description' takes 19: 7 for the floating joint 'root_joint', 12 for the others"):
        chain.fk(q[:-1])
    with pytest.raises(kc.StateError, match="qd has 19 entries per configuration; the chain 'go2_description' takes 18: 6 for the floating joint"):
        chain.fk(q, np.zeros(19))
    bad = q.copy()
    bad[3:7] = 0.0
    with pytest.raises(kc.StateError, match="quaternion of floating joint 'root_joint'"):
        chain.fk(bad)
    with pytest.raises(kc.StateError, match="configuration 4"):
        qs = chain.random(10, seed=0)
        qs[4, 3] = 3.0
        chain.fk(qs)
    with pytest.raises(kc.Error, match="layout must be"):
        chain.to_layout(q, layout="drake")
    with pytest.raises(kc.StateError, match="pinocchio layout has 18 entries"):
        chain.from_layout(q[:-1], layout="pinocchio")
    with pytest.raises(kc.Error, match="base must be"):
        chain.random(3, base=(1.0, -1.0))
    with pytest.raises(kc.LoadError, match="two floating joints in a row"):
        kc.Chain.from_urdf_string(
            '<robot name="r"><link name="w"/><link name="b"/><joint name="f" type="floating"><parent link="w"/><child link="b"/></joint></robot>',
            floating_base=True,
        )


def test_tables_read_a_floating_base_by_its_column_names():
    pd = pytest.importorskip("pandas")
    chain = kc.load(FLOATING[0], floating_base=True)
    qs = chain.random(300, seed=9)
    frame = pd.DataFrame(qs, columns=chain.q_names).iloc[:, ::-1]  # any column order
    frame["stamp"] = np.arange(300)
    out = kc.table.poses(frame, chain, links=["pelvis", "left_ankle_roll_link"], orientation="matrix")
    want = chain.fk(qs, links=["pelvis", "left_ankle_roll_link"]).poses
    assert np.array_equal(out["pelvis.x"].to_numpy(), want[:, 0, 0, 3])
    assert np.array_equal(out["left_ankle_roll_link.r12"].to_numpy(), want[:, 1, 1, 2])
    assert list(out["stamp"]) == list(range(300))
    # A base column missing is named.
    with pytest.raises(kc.StateError, match="root_joint.qw"):
        kc.table.poses(frame.drop(columns=["root_joint.qw"]), chain, links=["pelvis"])


def test_a_planar_joint_agrees_with_pinocchios():
    # URDF's planar joint with the usual axis z: Pinocchio's planar joint (x, y, cos θ, sin θ),
    # kinechain's three entries drive.x, drive.y, drive.theta.
    path = os.path.join(ROOT, "tests", "data", "planar", "mobile_arm.urdf")
    chain = kc.load(path)
    assert chain.q_names == ["drive.x", "drive.y", "drive.theta", "shoulder", "elbow"]
    model = pin.buildModelFromUrdf(path)
    data = model.createData()
    assert model.joints[1].shortname() == "JointModelPlanar"
    frames = {model.frames[i].name: i for i in range(model.nframes) if model.frames[i].type == pin.FrameType.BODY}
    links = [n for n in chain.link_names if n in frames]
    assert {"base", "upper", "tool"} <= set(links)
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(20):
        q = np.concatenate([rng.uniform(-2, 2, 2), rng.uniform(-np.pi, np.pi, 1), rng.uniform(-2, 2, 2)])
        pq = chain.to_layout(q, layout="pinocchio")[0]
        np.testing.assert_allclose(pq[:4], [q[0], q[1], np.cos(q[2]), np.sin(q[2])], atol=0, rtol=0)
        pin.framesForwardKinematics(model, data, pq)
        poses = chain.fk(q, links=links).poses
        for k, name in enumerate(links):
            worst = max(worst, np.abs(data.oMf[frames[name]].homogeneous - poses[k]).max())
    assert worst < 1e-14, worst


BALL_ARM = """name: ballarm
convention: axis
joints:
  - {name: base, type: revolute, origin: {xyz: [0, 0, 0.3]}, axis: [0, 0, 1], limits: [-3, 3]}
  - {name: shoulder, type: ball, origin: {xyz: [0.1, 0.2, 0.4], rpy: [0.3, 0.2, 0.1]}}
  - {name: elbow, type: revolute, origin: {xyz: [0, 0, 0.35]}, axis: [0, 1, 0], limits: [-2, 2]}
  - {name: wrist, type: ball, origin: {xyz: [0.05, 0, 0.3], rpy: [-0.4, 1.2, 0.7]}}
"""


FREE_ARM = """name: freearm
convention: axis
joints:
  - {name: base, type: revolute, origin: {xyz: [0, 0, 0.3]}, axis: [0, 0, 1], limits: [-3, 3]}
  - {name: carried, type: floating, origin: {xyz: [0.1, 0.2, 0.4], rpy: [0.3, 0.2, 0.1]}}
  - {name: elbow, type: revolute, origin: {xyz: [0, 0, 0.35]}, axis: [0, 1, 0], limits: [-2, 2]}
  - {name: wrist, type: ball, origin: {xyz: [0.05, 0, 0.3], rpy: [-0.4, 1.2, 0.7]}}
"""


def _compare_with_pinocchio_joint_by_joint(text, kinds, sizes):
    # The same arm built in Pinocchio joint by joint (JointModelSpherical for a ball, whose q is
    # x y z w; JointModelFreeFlyer for a floating joint below a moving one, x y z then x y z w;
    # both with v and a in the joint's own axes): each joint frame's pose, velocity and classical
    # acceleration, Jacobians, through to_layout("pinocchio"), and back.
    chain = kc.Chain.from_yaml_string(text)
    assert (chain.nq, chain.nv) == sizes
    model = pin.Model()
    parent = 0
    placements = [([0, 0, 0.3], [0, 0, 0]), ([0.1, 0.2, 0.4], [0.3, 0.2, 0.1]), ([0, 0, 0.35], [0, 0, 0]), ([0.05, 0, 0.3], [-0.4, 1.2, 0.7])]
    joints = []
    for (xyz, rpy), kind, name in zip(placements, kinds, ["base", "shoulder", "elbow", "wrist"]):
        parent = model.addJoint(parent, kind, pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz, dtype=float)), name)
        joints.append(parent)
    data = model.createData()
    assert (model.nq, model.nv) == (chain.nq, chain.nv)
    links = ["link1", "link2", "link3", "link4"]
    qs = chain.random(20, seed=5)
    rng = np.random.default_rng(2)
    worst = {"pose": 0.0, "v": 0.0, "a": 0.0, "J": 0.0}
    for q in qs:
        qd, qdd = rng.uniform(-1, 1, chain.nv), rng.uniform(-1, 1, chain.nv)
        pq, pv, pa = chain.to_layout(q, qd, qdd, layout="pinocchio")
        pin.forwardKinematics(model, data, pq, pv, pa)
        pin.computeJointJacobians(model, data, pq)
        r = chain.fk(q, qd, qdd, links=links)
        for k, j in enumerate(joints):
            m = data.oMi[j]
            worst["pose"] = max(worst["pose"], np.abs(m.homogeneous - r.poses[k]).max())
            v, a = data.v[j], data.a[j]
            omega, lin = m.rotation @ v.angular, m.rotation @ v.linear
            alpha = m.rotation @ a.angular
            acc = m.rotation @ (a.linear + np.cross(v.angular, v.linear))
            worst["v"] = max(worst["v"], np.abs(omega - r.omega[k]).max(), np.abs(lin - r.v[k]).max())
            worst["a"] = max(worst["a"], np.abs(alpha - r.alpha[k]).max(), np.abs(acc - r.a[k]).max())
            J = chain.jacobian(q, links[k])
            Jp = pin.getJointJacobian(model, data, j, pin.LOCAL_WORLD_ALIGNED)
            worst["J"] = max(worst["J"], np.abs(J @ qd - Jp @ pv).max())
        back = chain.from_layout(pq, pv, pa, layout="pinocchio")
        for got, want in zip(back, (q, qd, qdd)):
            np.testing.assert_allclose(got, want, atol=1e-14)
    assert worst["pose"] < 1e-14, worst
    assert worst["v"] < 1e-14, worst
    assert worst["a"] < 1e-13, worst
    assert worst["J"] < 1e-14, worst
    return chain


def test_ball_joints_agree_with_pinocchios_spherical_joint():
    kinds = [pin.JointModelRZ(), pin.JointModelSpherical(), pin.JointModelRY(), pin.JointModelSpherical()]
    chain = _compare_with_pinocchio_joint_by_joint(BALL_ARM, kinds, (10, 8))
    q = chain.random(1, seed=1)[0]
    np.testing.assert_array_equal(chain.to_layout(q, layout="pinocchio")[0][1:5], [q[2], q[3], q[4], q[1]])


def test_a_floating_joint_below_a_moving_one_agrees_with_pinocchios_free_flyer():
    kinds = [pin.JointModelRZ(), pin.JointModelFreeFlyer(), pin.JointModelRY(), pin.JointModelSpherical()]
    chain = _compare_with_pinocchio_joint_by_joint(FREE_ARM, kinds, (13, 11))
    assert chain.q_names[1:8] == [f"carried.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    q = chain.random(1, seed=1)[0]
    np.testing.assert_array_equal(chain.to_layout(q, layout="pinocchio")[0][1:8], q[[1, 2, 3, 5, 6, 7, 4]])


def test_ball_joint_errors_name_the_joint():
    chain = kc.Chain.from_yaml_string(BALL_ARM)
    q = chain.neutral()
    q[6:10] = [0.0, 0.0, 0.0, 0.0]
    with pytest.raises(kc.StateError, match=r"ball joint 'wrist' \(q\[6\.\.10\]"):
        chain.fk(q)
    with pytest.raises(kc.StateError, match="4 for the ball joint 'shoulder', 4 for the ball joint 'wrist', 2 for the others"):
        chain.fk(np.zeros(8))
    qs = chain.random(4, seed=1)
    qs[2, 1:5] *= 3.0
    with pytest.raises(kc.StateError, match="configuration 2"):
        chain.fk(qs)
