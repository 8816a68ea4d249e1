"""MuJoCo as the oracle of MJCF kinematics: compile a model (meshes and other assets replaced,
since body poses do not depend on them), run ``mj_kinematics`` and compare every named body's
and site's pose with kinechain's at the same ``qpos``."""

from __future__ import annotations

import math
import os

import numpy as np

import kinechain as kc

try:
    import mujoco
except ImportError:  # pragma: no cover - the tests that need it are skipped (or fail in CI)
    mujoco = None


def compile_without_assets(path: str):
    """The MuJoCo model of ``path`` with mesh, height-field and other asset-backed geoms made
    small spheres and the assets removed (the XML-only corpus has no mesh files)."""
    spec = mujoco.MjSpec.from_file(os.fspath(path))
    for geom in spec.geoms:
        kinds = (mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_HFIELD, mujoco.mjtGeom.mjGEOM_SDF)
        if geom.type in kinds or geom.meshname or geom.hfieldname:
            geom.type = mujoco.mjtGeom.mjGEOM_SPHERE
            geom.size = [0.01, 0.0, 0.0]
            geom.meshname = ""
            geom.hfieldname = ""
    for group in (spec.meshes, spec.hfields, spec.skins, spec.textures):
        for item in list(group):
            spec.delete(item)
    # Small test files have bodies without mass, which MuJoCo refuses to move; a sphere on each
    # body gives them some without moving any frame.
    for body in spec.bodies[1:]:
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0.0, 0.0], meshname="")
    for material in spec.materials:
        material.textures = [""] * len(material.textures)
    return spec.compile()


def random_qpos(model, rng: np.random.Generator) -> np.ndarray:
    """A ``qpos``: hinge and slide joints uniform within their range (or ±π, ±0.5 m when
    unlimited), free joints at a random position with a uniformly random unit quaternion."""
    q = model.qpos0.copy()
    for j in range(model.njnt):
        a = model.jnt_qposadr[j]
        t = model.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_FREE:
            q[a : a + 3] = rng.uniform(-1.0, 1.0, 3)
            v = rng.normal(size=4)
            q[a + 3 : a + 7] = v / np.linalg.norm(v)
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            v = rng.normal(size=4)
            q[a : a + 4] = v / np.linalg.norm(v)
        else:
            lo, hi = model.jnt_range[j]
            if not model.jnt_limited[j]:
                lo, hi = (-math.pi, math.pi) if t == mujoco.mjtJoint.mjJNT_HINGE else (-0.5, 0.5)
            q[a] = rng.uniform(lo, hi)
    return q


def site_link(chain: kc.Chain, name: str) -> str:
    """The link kinechain gives site ``name``: its name, or ``site:NAME`` when a body has it."""
    links = set(chain.link_names)
    return f"site:{name}" if f"site:{name}" in links else name


def worst_error(path: str, random_configurations: int = 8, seed: int = 7):
    """The largest pose difference (position over ``max(1 m, farthest body)``, rotation matrix entries)
    between kinechain and MuJoCo over ``qpos0``, every keyframe and random configurations, and
    how many poses were compared."""
    model = compile_without_assets(path)
    data = mujoco.MjData(model)
    chain = kc.load(path)
    assert chain.nq == model.nq, (chain.nq, model.nq)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    rng = np.random.default_rng(seed)
    configurations = [model.qpos0.copy()]
    configurations += [model.key_qpos[k].copy() for k in range(model.nkey)]
    configurations += [random_qpos(model, rng) for _ in range(random_configurations)]
    bodies = [
        (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b), b) for b in range(1, model.nbody)
    ]
    sites = [(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, s), s) for s in range(model.nsite)]
    bodies = [(n, i) for n, i in bodies if n]
    sites = [(site_link(chain, n), i) for n, i in sites if n]
    links = [n for n, _ in bodies] + [n for n, _ in sites]
    worst, compared = 0.0, 0
    for q in configurations:
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        # Positions relative to the model's size (its farthest body from the world origin).
        scale = max(1.0, float(np.linalg.norm(data.xpos, axis=1).max()))
        poses = chain.fk(q, links=links, check_limits=False).poses
        for k, (_, b) in enumerate(bodies):
            p, r = data.xpos[b], data.xmat[b].reshape(3, 3)
            worst = max(worst, np.abs(poses[k, :3, 3] - p).max() / scale, np.abs(poses[k, :3, :3] - r).max())
        for k, (_, s) in enumerate(sites, start=len(bodies)):
            p, r = data.site_xpos[s], data.site_xmat[s].reshape(3, 3)
            worst = max(worst, np.abs(poses[k, :3, 3] - p).max() / scale, np.abs(poses[k, :3, :3] - r).max())
        compared += len(links)
    return worst, compared, names
