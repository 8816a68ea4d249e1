"""MJCF files against MuJoCo itself: every named body's and site's pose from ``mj_kinematics``
at ``qpos0``, every keyframe and random ``qpos``, on the feature files of the test data and the
MuJoCo Menagerie models bundled with the tests (the whole Menagerie corpus with
``KINECHAIN_MJCF_CORPUS=DIR``, see the README)."""

import csv
import os
import pathlib
import pickle
import xml.dom.minidom

import numpy as np
import pytest

import kinechain as kc
import mjcf_oracle

DATA = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "mjcf"
MENAGERIE = sorted(p for p in (DATA / "menagerie").glob("*/*.xml") if not p.name.startswith(("joint_", "keyframe_")))

# MuJoCo is installed in CI (KINECHAIN_REQUIRE_PEERS=1 there: a missing one fails the run);
# elsewhere these tests are skipped without it.
if os.environ.get("KINECHAIN_REQUIRE_PEERS"):
    import mujoco
else:
    mujoco = pytest.importorskip("mujoco")

# Position error over the model's size, and rotation-matrix entries.
TOLERANCE = 1e-12


# Scenes and the constructs MuJoCo's own models use: several free bodies, frames around joints,
# unnamed elements, alignfree, <replicate>, <attach>, an included <mujocoinclude>.
SCENES = sorted(p for p in (DATA / "scene").glob("*.xml") if p.name not in ("legacy_bodies.xml", "attach_child.xml"))


@pytest.mark.parametrize("path", [DATA / "features.xml", DATA / "free.xml", DATA / "ball.xml"] + SCENES + MENAGERIE, ids=lambda p: p.stem)
def test_every_body_and_site_is_where_mujoco_puts_it(path):
    worst, compared, _ = mjcf_oracle.worst_error(path)
    assert compared > 0
    assert worst < TOLERANCE, f"{path.name}: {worst:.3g}"


@pytest.mark.parametrize("path", [DATA / "features.xml", DATA / "ball.xml"] + SCENES + MENAGERIE, ids=lambda p: p.stem)
def test_q_is_qpos_and_keyframes_are_the_files(path):
    model = mjcf_oracle.compile_model(path)
    chain = kc.load(path)
    assert chain.nq == model.nq and chain.nv == model.nv
    for j, name in enumerate(mjcf_oracle.joint_names(model)):
        a = model.jnt_qposadr[j]
        first = chain.q_names[a]
        assert first == name or first.startswith(name + "."), (first, name)
    keys = chain.keyframes
    assert len(keys) == model.nkey
    for k, (name, q) in enumerate(keys.items()):
        want = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}"
        assert name == want
        # The same numbers; a free body that alignfree moves onto principal axes within the
        # rounding of the two eigen-solves (up to 2.8e-15 seen on alignfree.xml).
        np.testing.assert_allclose(q, model.key_qpos[k], rtol=0, atol=1e-14)


def test_includes_and_pickling():
    path = DATA / "menagerie" / "aloha" / "aloha.xml"
    chain = kc.load(path)
    assert len(chain.keyframes) == 1  # from the included keyframe_ctrl.xml
    copy = pickle.loads(pickle.dumps(chain))
    q = chain.random(seed=4)
    np.testing.assert_array_equal(copy.fk(q).poses, chain.fk(q).poses)
    text = path.read_text()
    from_string = kc.Chain.from_mjcf_string(text, base_dir=str(path.parent))
    np.testing.assert_array_equal(from_string.fk(q).poses, chain.fk(q).poses)
    with pytest.raises(kc.LoadError, match="joint_position_actuators.xml' is not found"):
        kc.Chain.from_mjcf_string(text, base_dir=str(DATA))


def test_errors_are_load_errors_with_the_line():
    with pytest.raises(kc.LoadError, match="line 2 column 23: joint 'j' has type 'screw'"):
        kc.Chain.from_mjcf_string('<mujoco><worldbody>\n<body><joint name="j" type="screw"/></body></worldbody></mujoco>')
    with pytest.raises(kc.LoadError, match="not well-formed"):
        kc.Chain.from_mjcf_string("<mujoco><worldbody></mujoco>")


def test_a_free_joint_agrees_with_mujoco_velocity_layout():
    # The free joint of MJCF is kinechain's floating joint: MuJoCo's layout converts its qvel.
    chain = kc.load(DATA / "free.xml")
    model = mjcf_oracle.compile_without_assets(DATA / "free.xml")
    data = mujoco.MjData(model)
    rng = np.random.default_rng(3)
    q = mjcf_oracle.random_qpos(model, rng)
    qvel = rng.normal(size=model.nv)
    data.qpos[:], data.qvel[:] = q, qvel
    mujoco.mj_forward(model, data)
    q_kc, qd_kc, _ = chain.from_layout(q, qvel, layout="mujoco")
    r = chain.fk(q_kc, qd_kc, links=["foot"], check_limits=False)
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "foot")
    v = np.zeros(6)
    mujoco.mj_objectVelocity(model, data, mujoco.mjtObj.mjOBJ_SITE, site, v, 0)
    np.testing.assert_allclose(r.omega[0], v[:3], atol=1e-12)
    np.testing.assert_allclose(r.v[0], v[3:], atol=1e-12)


def test_ball_joints_move_bodies_and_sites_as_mujoco_does():
    # Velocities and classical accelerations of every body and site (mj_objectVelocity and
    # mj_objectAcceleration, world axes, without gravity) at random qpos, qvel, qacc, given to
    # kinechain through the MuJoCo layout: the ball joints' rates are in their bodies' axes there.
    path = DATA / "ball.xml"
    chain = kc.load(path)
    assert chain.q_names[:5] == ["waist.qw", "waist.qx", "waist.qy", "waist.qz", "lift"]
    assert chain.v_names[:4] == ["waist.wx", "waist.wy", "waist.wz", "lift"]
    model = mjcf_oracle.compile_without_assets(path)
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    # XBODY: the body's own frame (BODY would be its inertial frame).
    objects = [(mujoco.mjtObj.mjOBJ_XBODY, n) for n in ("torso", "upper", "lower", "hand", "pendulum", "bob")]
    objects += [(mujoco.mjtObj.mjOBJ_SITE, n) for n in ("tip", "head")]
    links = [mjcf_oracle.site_link(chain, n) if t == mujoco.mjtObj.mjOBJ_SITE else n for t, n in objects]
    rng = np.random.default_rng(9)
    worst = 0.0
    for _ in range(10):
        q = mjcf_oracle.random_qpos(model, rng)
        qvel, qacc = rng.normal(size=model.nv), rng.normal(size=model.nv)
        data.qpos[:], data.qvel[:], data.qacc[:] = q, qvel, qacc
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_rnePostConstraint(model, data)
        q_kc, qd_kc, qdd_kc = chain.from_layout(q, qvel, qacc, layout="mujoco")
        r = chain.fk(q_kc, qd_kc, qdd_kc, links=links, check_limits=False)
        for k, (kind, name) in enumerate(objects):
            i = mujoco.mj_name2id(model, kind, name)
            v, a = np.zeros(6), np.zeros(6)
            mujoco.mj_objectVelocity(model, data, kind, i, v, 0)
            mujoco.mj_objectAcceleration(model, data, kind, i, a, 0)
            for got, want in ((r.omega[k], v[:3]), (r.v[k], v[3:]), (r.alpha[k], a[:3]), (r.a[k], a[3:])):
                worst = max(worst, np.abs(got - want).max())
        # And back: kinechain's rates in MuJoCo's layout are the qvel and qacc given.
        _, qvel_back, qacc_back = chain.to_layout(q_kc, qd_kc, qdd_kc, layout="mujoco")
        np.testing.assert_allclose(qvel_back, qvel, atol=1e-14)
        np.testing.assert_allclose(qacc_back, qacc, atol=1e-14)
    assert worst < 1e-12, worst


def test_free_bodies_of_a_scene_move_as_mujoco_moves_them():
    # Velocities and classical accelerations of every body and site of the pick scene (two arms
    # and ten free boxes, MuJoCo's qvel and qacc of each free joint: world linear, body-frame
    # angular) through the MuJoCo layout, and back.
    path = DATA / "scene" / "pick.xml"
    chain = kc.load(path)
    model = mjcf_oracle.compile_model(path)
    assert (chain.nq, chain.nv) == (model.nq, model.nv) == (9 + 6 + 70, 9 + 6 + 60)
    model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    bodies, sites = mjcf_oracle.link_names(model)
    # XBODY: the body's own frame (BODY would be its inertial frame).
    objects = [(mujoco.mjtObj.mjOBJ_XBODY, b) for b in range(1, model.nbody)] + [(mujoco.mjtObj.mjOBJ_SITE, s) for s in range(model.nsite)]
    links = bodies + sites
    rng = np.random.default_rng(4)
    worst = 0.0
    for _ in range(5):
        q = mjcf_oracle.random_qpos(model, rng)
        qvel, qacc = rng.normal(size=model.nv), rng.normal(size=model.nv)
        data.qpos[:], data.qvel[:], data.qacc[:] = q, qvel, qacc
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_rnePostConstraint(model, data)
        q_kc, qd_kc, qdd_kc = chain.from_layout(q, qvel, qacc, layout="mujoco")
        r = chain.fk(q_kc, qd_kc, qdd_kc, links=links, check_limits=False)
        for k, (kind, i) in enumerate(objects):
            v, a = np.zeros(6), np.zeros(6)
            mujoco.mj_objectVelocity(model, data, kind, i, v, 0)
            mujoco.mj_objectAcceleration(model, data, kind, i, a, 0)
            for got, want in ((r.omega[k], v[:3]), (r.v[k], v[3:]), (r.alpha[k], a[:3]), (r.a[k], a[3:])):
                worst = max(worst, np.abs(got - want).max())
        _, qvel_back, qacc_back = chain.to_layout(q_kc, qd_kc, qdd_kc, layout="mujoco")
        np.testing.assert_allclose(qvel_back, qvel, atol=1e-14)
        np.testing.assert_allclose(qacc_back, qacc, atol=1e-14)
    assert worst < 1e-12, worst


def test_scene_names_batches_and_jacobians():
    chain = kc.load(DATA / "scene" / "pick.xml")
    # Each free box's seven entries where MuJoCo's qpos has them, named by replicate's suffix.
    assert chain.q_names[15:22] == [f"box_00.{c}" for c in ("x", "y", "z", "qw", "qx", "qy", "qz")]
    assert chain.q_names[-7] == "box_09.x"
    assert "left/hand" in chain.link_names and "right/wrist_3_link" in chain.link_names
    assert list(chain.keyframes) == ["left/home", "right/home"]
    qs = chain.random(64, seed=2)
    one = np.stack([chain.fk(q, links=["left/hand", "top_07"]).poses for q in qs])
    np.testing.assert_array_equal(chain.fk(qs, links=["left/hand", "top_07"]).poses, one)
    J = chain.jacobian(qs[0], "top_07")
    # The box's own six columns move its site; nothing else does.
    box = chain.v_names.index("box_07.vx")
    assert np.count_nonzero(np.abs(J).sum(axis=0)) == 6
    np.testing.assert_array_equal(J[:3, box : box + 3], np.eye(3))


def test_a_ball_joints_range_is_reported_not_checked():
    chain = kc.load(DATA / "ball.xml")
    assert any("ball joint 'wrist' has a range" in w for w in chain.warnings), chain.warnings
    assert np.isinf(chain.lower[chain.q_names.index("wrist.qw")])


@pytest.mark.skipif(not os.environ.get("KINECHAIN_MJCF_CORPUS"), reason="set KINECHAIN_MJCF_CORPUS to the Menagerie corpus")
def test_the_menagerie_corpus():
    root = pathlib.Path(os.environ["KINECHAIN_MJCF_CORPUS"])
    rows = list(csv.DictReader(open(root / "MANIFEST.tsv"), delimiter="\t"))
    agree, worst, failed = 0, 0.0, []
    for row in rows:
        path = root / row["model_dir"] / row["main_xml"]
        try:
            w, _, _ = mjcf_oracle.worst_error(path, random_configurations=4)
        except (kc.LoadError, AssertionError) as e:
            failed.append(f"{row['model_dir']}: {str(e).splitlines()[-1]}")
            continue
        worst = max(worst, w)
        if w < TOLERANCE:
            agree += 1
        else:
            failed.append(f"{row['model_dir']}: {w:.3g}")
    print(f"\n{agree} of {len(rows)} models agree with MuJoCo; worst error {worst:.3g}")
    for f in failed:
        print("  " + f)
    assert agree == len(rows), failed


@pytest.mark.parametrize("path", [DATA / "menagerie" / "aloha" / "aloha.xml", DATA / "menagerie" / "iit_softfoot" / "softfoot.xml", DATA / "features.xml"], ids=lambda p: p.stem)
def test_couplings_make_followers_that_land_where_mujoco_puts_them(path):
    # With couplings=True, q holds the leaders; MuJoCo gets the followers from the coupling's
    # polynomial, y − y0 = a0 + a1 (x − x0).
    model = mjcf_oracle.compile_without_assets(path)
    data = mujoco.MjData(model)
    chain = kc.load(path, couplings=True)
    couplings = [e for e in range(model.neq) if model.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT and model.eq_active0[e]]
    assert couplings and chain.nq == model.nq - len(couplings)
    followers = [model.jnt_qposadr[model.eq_obj1id[e]] for e in couplings]
    leaders = [a for a in range(model.nq) if a not in followers]
    bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody)]
    rng = np.random.default_rng(11)
    for _ in range(5):
        q = mjcf_oracle.random_qpos(model, rng)
        for e in couplings * len(couplings):  # until a follower of a follower is settled too
            y, x = model.jnt_qposadr[model.eq_obj1id[e]], model.jnt_qposadr[model.eq_obj2id[e]]
            a0, a1 = model.eq_data[e][:2]
            q[y] = model.qpos0[y] + a0 + a1 * (q[x] - model.qpos0[x])
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        named = [(n, b) for b, n in enumerate(bodies, start=1) if n]
        poses = chain.fk(q[leaders], links=[n for n, _ in named], check_limits=False).poses
        for k, (_, b) in enumerate(named):
            assert np.abs(poses[k, :3, 3] - data.xpos[b]).max() < 1e-12
            assert np.abs(poses[k, :3, :3] - data.xmat[b].reshape(3, 3)).max() < 1e-12


def _mujoco_model_files(root: pathlib.Path):
    """The files under ``root`` whose root element is ``<mujoco>``."""
    for path in sorted(root.rglob("*.xml")):
        head = path.read_bytes()[:8192].decode("utf-8", "replace")
        if "<mujoco" in head:
            yield path


@pytest.mark.skipif(
    not os.environ.get("KINECHAIN_MUJOCO_MODELS"),
    reason="set KINECHAIN_MUJOCO_MODELS to the folder tools/mujoco_test_models.py makes",
)
def test_mujoco_models():
    # Every model of MuJoCo's own source tree (model/, test/ and the XML strings of its C++ and
    # Python tests) that MuJoCo compiles and that has no deformable object: kinechain loads it
    # and every body and site is where mj_kinematics puts it, at qpos0, every keyframe and
    # random configurations.
    root = pathlib.Path(os.environ["KINECHAIN_MUJOCO_MODELS"])
    agree, skipped, failed, worst = [], {}, [], 0.0
    for path in _mujoco_model_files(root):
        name = str(path.relative_to(root))
        try:
            model = mujoco.MjModel.from_xml_path(str(path))
        except Exception as e:  # MuJoCo refuses it (or needs a plugin or a file it lacks)
            skipped.setdefault("MuJoCo does not compile it", []).append(f"{name}: {str(e).splitlines()[0]}")
            continue
        if model.nflex or model.nskin:
            skipped.setdefault("deformable", []).append(name)
            continue
        try:  # MuJoCo's XML reader takes some files that are not well-formed XML; kinechain does not
            xml.dom.minidom.parse(str(path))
        except Exception as e:
            skipped.setdefault("not well-formed XML", []).append(f"{name}: {e}")
            continue
        try:
            w, _, _ = mjcf_oracle.worst_error(path, random_configurations=3, model=model)
            keys = kc.load(path).keyframes
            want = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}" for k in range(model.nkey)]
            assert list(keys) == want, f"keyframes {list(keys)} and not {want}"
            for k, q in enumerate(keys.values()):
                w = max(w, float(np.abs(q - model.key_qpos[k]).max(initial=0.0)))
        except (kc.LoadError, AssertionError) as e:
            failed.append(f"{name}: {str(e).splitlines()[-1] if str(e) else repr(e)}")
            continue
        worst = max(worst, w)
        (agree.append(name) if w < TOLERANCE else failed.append(f"{name}: {w:.3g}"))
    print(f"\n{len(agree)} models agree with MuJoCo {mujoco.__version__} (worst {worst:.3g}); {len(failed)} do not")
    for why, names in skipped.items():
        print(f"  skipped, {why}: {len(names)}")
    for f in failed:
        print("  " + f)
    assert not failed
