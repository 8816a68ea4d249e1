"""MJCF files against MuJoCo itself: every named body's and site's pose from ``mj_kinematics``
at ``qpos0``, every keyframe and random ``qpos``, on the feature files of the test data and the
MuJoCo Menagerie models bundled with the tests (the whole Menagerie corpus with
``KINECHAIN_MJCF_CORPUS=DIR``, see the README)."""

import csv
import os
import pathlib
import pickle

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


@pytest.mark.parametrize("path", [DATA / "features.xml", DATA / "free.xml"] + MENAGERIE, ids=lambda p: p.stem)
def test_every_body_and_site_is_where_mujoco_puts_it(path):
    worst, compared, _ = mjcf_oracle.worst_error(path)
    assert compared > 0
    assert worst < TOLERANCE, f"{path.name}: {worst:.3g}"


@pytest.mark.parametrize("path", [DATA / "features.xml"] + MENAGERIE, ids=lambda p: p.stem)
def test_q_is_qpos_and_keyframes_are_the_files(path):
    model = mjcf_oracle.compile_without_assets(path)
    chain = kc.load(path)
    assert chain.nq == model.nq and chain.nv == model.nv
    for j in range(model.njnt):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        if not name:
            continue
        a = model.jnt_qposadr[j]
        first = chain.q_names[a]
        assert first == name or first.startswith(name + "."), (first, name)
    keys = chain.keyframes
    assert len(keys) == model.nkey
    for k, (name, q) in enumerate(keys.items()):
        want = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_KEY, k) or f"key{k}"
        assert name == want
        np.testing.assert_array_equal(q, model.key_qpos[k])


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
    with pytest.raises(kc.LoadError, match="line 2 column 23: joint 'j' is a ball joint"):
        kc.Chain.from_mjcf_string('<mujoco><worldbody>\n<body><joint name="j" type="ball"/></body></worldbody></mujoco>')
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
