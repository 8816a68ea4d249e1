"""``Chain.ik``: poses, positions, masks, several links, relative goals, locked joints, batches
(equal bit for bit to single solves and on any number of threads), checked against ``Chain.pose``;
limits held; unreachable targets as failures; every error raised as an exception."""

import os

import numpy as np
import pytest

import kinechain as kc

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def robot(name, **kw):
    return kc.load(os.path.join(ROOT, "robots", name), **kw)


def angle(a, b):
    """Rotation angle between the rotations of ``a`` and ``b`` (..., 4, 4)."""
    r = np.swapaxes(b[..., :3, :3], -1, -2) @ a[..., :3, :3]
    c = np.clip((np.trace(r, axis1=-2, axis2=-1) - 1) / 2, -1, 1)
    s = np.linalg.norm(r - np.swapaxes(r, -1, -2), axis=(-2, -1)) / (2 * np.sqrt(2))
    return np.arctan2(s, c)


def within_limits(chain, q):
    return bool(np.all((chain.lower <= q) & (q <= chain.upper)))


def test_a_batch_of_panda_poses_from_random_seeds_is_solved_and_checked_by_fk():
    c = robot("panda.urdf")
    qs = c.random(500, seed=1)
    t = c.pose(qs, "panda_hand")
    r = c.ik(t, "panda_hand", c.random(500, seed=2))
    assert r.q.shape == (500, c.nq) and r.success.shape == (500,) and r.position_error.shape == (500,)
    assert r.success.all(), f"{(~r.success).sum()} failed"
    got = c.pose(r.q, "panda_hand")
    assert np.linalg.norm(got[:, :3, 3] - t[:, :3, 3], axis=1).max() <= 1e-6
    assert angle(got, t).max() <= 1e-6
    np.testing.assert_allclose(r.position_error, np.linalg.norm(got[:, :3, 3] - t[:, :3, 3], axis=1), atol=1e-12)
    assert within_limits(c, r.q)


def test_single_batch_and_threads_agree_bit_for_bit():
    c = robot("ur5.yaml")
    t = c.pose(c.random(64, seed=3), "tool0")
    q0 = c.random(64, seed=4)
    a = c.ik(t, "tool0", q0, seed=5)
    b = c.ik(t, "tool0", q0, seed=5, threads=1)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.iterations, b.iterations)
    for i in (0, 17, 63):
        s = c.ik(t[i], "tool0", q0[i], seed=5)
        assert s.q.shape == (c.nq,) and isinstance(s.success, bool)
        assert np.array_equal(s.q, a.q[i])
    assert "solved" in repr(a) and "success=True" in repr(c.ik(t[0], "tool0"))


def test_positions_masks_and_points():
    c = robot("panda.urdf")
    t = c.pose(c.random(50, seed=6), "panda_hand")
    # Positions only: (N, 3) targets.
    r = c.ik(t[:, :3, 3], "panda_hand")
    assert r.success.all() and (r.rotation_error == 0).all()
    np.testing.assert_allclose(c.pose(r.q, "panda_hand")[:, :3, 3], t[:, :3, 3], atol=1e-6)
    # The turn about the hand's z axis free.
    turned = t @ np.array([[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    r = c.ik(turned, "panda_hand", weights=[1, 1, 1, 1, 1, 0])
    got = c.pose(r.q, "panda_hand")
    assert r.success.all()
    np.testing.assert_allclose(got[:, :3, 2], turned[:, :3, 2], atol=1e-6)
    # A point 10 cm along the hand's z axis.
    u = np.array([0.0, 0.0, 0.1])
    tip = t.copy()
    tip[:, :3, 3] += t[:, :3, :3] @ u
    r = c.ik(tip, "panda_hand", point=u)
    assert r.success.all()
    got = c.pose(r.q, "panda_hand")
    np.testing.assert_allclose(got[:, :3, 3] + got[:, :3, :3] @ u, tip[:, :3, 3], atol=1e-6)


def test_several_links_relative_goals_and_locked_joints_on_a_floating_humanoid():
    g1 = robot("g1.urdf", floating_base=True)
    feet_hands = ["left_ankle_roll_link", "right_ankle_roll_link", "left_rubber_hand", "right_rubber_hand"]
    q = g1.random(10, seed=7, base=(-0.3, 0.3))
    targets = [g1.pose(q, name) for name in feet_hands]
    r = g1.ik(targets, feet_hands, start="neutral")
    assert r.position_error.shape == (10, 4)
    assert r.success.all()
    for name, t in zip(feet_hands, targets):
        np.testing.assert_allclose(g1.pose(r.q, name)[:, :3, 3], t[:, :3, 3], atol=1e-6)
    # The left hand in the torso's frame, the waist locked.
    torso, hand = g1.pose(q, "torso_link"), g1.pose(q, "left_rubber_hand")
    rel = np.linalg.inv(torso) @ hand
    q0 = g1.neutral().copy()
    waist = [g1.q_names.index(n) for n in g1.q_names if n.startswith("waist")]
    q0[waist] = q[0, waist]
    r = g1.ik(rel[0], "left_rubber_hand", q0, base="torso_link", locked=[g1.q_names[i] for i in waist])
    assert r.success
    assert np.array_equal(r.q[waist], q0[waist])
    got = np.linalg.inv(g1.pose(r.q, "torso_link")) @ g1.pose(r.q, "left_rubber_hand")
    np.testing.assert_allclose(got, rel[0], atol=1e-6)


def test_unreachable_targets_fail_with_their_residual_within_limits():
    c = robot("planar3.yaml")
    far = np.eye(4)
    far[0, 3] = 12.0
    r = c.ik(far[:3, 3], "link3", max_attempts=3)
    assert not r.success
    assert abs(r.position_error - 3.0) < 1e-6
    assert within_limits(c, r.q)


def test_errors_are_exceptions_naming_what_is_wrong():
    c = robot("ur5.yaml")
    t = c.pose(c.neutral(), "tool0")
    with pytest.raises(kc.Error, match="no_such_link"):
        c.ik(t, "no_such_link")
    with pytest.raises(kc.Error, match="locked"):
        c.ik(t, "tool0", locked=["no_such_joint"])
    with pytest.raises(kc.StateError, match="shape"):
        c.ik(np.eye(2), "tool0")
    bad = t.copy()
    bad[0, 0] = np.nan
    with pytest.raises(kc.StateError, match="non-finite"):
        c.ik(bad, "tool0")
    sheared = t.copy()
    sheared[0, 1] += 0.2
    with pytest.raises(kc.StateError, match="orthonormal"):
        c.ik(sheared, "tool0")
    with pytest.raises(kc.StateError, match="q0"):
        c.ik(t, "tool0", np.zeros(5))
    with pytest.raises(kc.StateError, match="shoulder_pan"):
        c.ik(t, "tool0", np.full(6, 7.0))
    with pytest.raises(kc.Error, match="closest"):
        c.ik(t, "tool0", closest="l3")
    with pytest.raises(kc.Error, match="position_tolerance"):
        c.ik(t, "tool0", position_tolerance=-1)
    with pytest.raises(kc.Error, match="threads"):
        c.ik(np.stack([t, t]), "tool0", threads=0)
    with pytest.raises(kc.StateError, match="rows"):
        c.ik([t, np.stack([t, t])], ["tool0", "wrist_3_link"])
    with pytest.raises(kc.Error, match="list of 2"):
        c.ik(t, ["tool0", "wrist_3_link"])


def test_fk_and_jacobian_relative_to_a_base_link_agree_with_world_quantities():
    g1 = robot("g1.urdf", floating_base=True)
    q = g1.random(5, seed=11, base=(-0.3, 0.3))
    rng = np.random.default_rng(12)
    qd, qdd = rng.standard_normal((5, g1.nv)), rng.standard_normal((5, g1.nv))
    links = ["left_rubber_hand", "right_ankle_roll_link"]
    rel = g1.fk(q, qd, qdd, links=links, base="torso_link")
    world = g1.fk(q, qd, qdd, links=links + ["torso_link"])
    tb = world.poses[:, 2]
    assert rel.links == links and rel.poses.shape == (5, 2, 4, 4) and rel.a.shape == (5, 2, 3)
    np.testing.assert_allclose(rel.poses, np.linalg.inv(tb)[:, None] @ world.poses[:, :2], atol=1e-12)
    # Velocities: finite differences of the relative pose along q + qd t (no floating motion
    # in qd for this check: the base's position and quaternion rates follow qd's convention).
    qd[:, :6] = 0.0
    qdd[:, :6] = 0.0
    rel = g1.fk(q, qd, qdd, links=links, base="torso_link")
    h = 1e-6
    plus = g1.fk(q + h * np.pad(qd, ((0, 0), (1, 0))), links=links, base="torso_link").poses
    minus = g1.fk(q - h * np.pad(qd, ((0, 0), (1, 0))), links=links, base="torso_link").poses
    np.testing.assert_allclose(rel.v, (plus - minus)[..., :3, 3] / (2 * h), atol=1e-6)
    # The relative Jacobian maps qd to the relative twist.
    j = g1.jacobian(q, "left_rubber_hand", base="torso_link")
    assert j.shape == (5, 6, g1.nv)
    twist = np.einsum("nij,nj->ni", j, qd)
    np.testing.assert_allclose(twist[:, :3], rel.v[:, 0], atol=1e-12)
    np.testing.assert_allclose(twist[:, 3:], rel.omega[:, 0], atol=1e-12)
    single = g1.jacobian(q[0], "left_rubber_hand", base="torso_link")
    np.testing.assert_array_equal(single, j[0])
    with pytest.raises(kc.Error, match="no_such"):
        g1.fk(q, links=links, base="no_such")
    with pytest.raises(kc.Error, match="frame"):
        g1.jacobian(q, "left_rubber_hand", base="torso_link", frame="link")


def test_options_out_of_range_raise_kinechain_errors():
    c = robot("ur5.yaml")
    t = c.pose(c.neutral(), "tool0")
    for kw in (dict(seed=-1), dict(seed=2**64), dict(seed=1.5), dict(weights=[0] * 6), dict(time_limit=-1),
               dict(iterations=0), dict(max_attempts=0), dict(start="zero")):
        with pytest.raises(kc.Error):
            c.ik(t, "tool0", **kw)
    with pytest.raises(kc.StateError, match="NaN") as e:
        c.ik(t, "tool0", np.full(6, np.nan))
    assert str(e.value).count("is NaN") == 1, "the cause is said once"
    r = c.ik(np.zeros((0, 4, 4)), "tool0")
    assert r.q.shape == (0, 6) and r.success.shape == (0,)
