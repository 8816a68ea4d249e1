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
    # body without a geom gives them some without moving any frame (a body with geoms keeps
    # them alone, so that the inertial frame alignfree gives it stays MuJoCo's).
    for body in spec.bodies[1:]:
        if not body.geoms:
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


def joint_names(model) -> list[str]:
    """The names kinechain gives MuJoCo's joints, by id: the model's, or ``joint#ID`` (one ``#``
    more while the model uses that name)."""
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or "" for j in range(model.njnt)]

    def fresh(j: int) -> str:
        hashes = "#"
        while f"joint{hashes}{j}" in names:
            hashes += "#"
        return f"joint{hashes}{j}"

    return [n or fresh(j) for j, n in enumerate(names)]


def link_names(model) -> tuple[list[str], list[str]]:
    """The links kinechain makes of every body but the world and of every site, by MuJoCo id:
    the model's names, ``body#ID`` and ``site#ID`` for unnamed ones (one ``#`` more while the
    file uses that name), ``site:NAME`` for a site that has a body's name."""
    bodies = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in range(model.nbody)]
    sites = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_SITE, s) or "" for s in range(model.nsite)]
    taken = set(bodies) | set(sites)

    def fresh(kind: str, i: int) -> str:
        hashes = "#"
        while f"{kind}{hashes}{i}" in taken:
            hashes += "#"
        return f"{kind}{hashes}{i}"

    def site(name: str, i: int) -> str:
        if not name:
            return fresh("site", i)
        if name in bodies:
            colons = ":"
            while f"site{colons}{name}" in taken:
                colons += ":"
            return f"site{colons}{name}"
        return name

    body_links = [n or fresh("body", b) for b, n in enumerate(bodies)][1:]
    return body_links, [site(n, i) for i, n in enumerate(sites)]


def compile_model(path: str):
    """The MuJoCo model of ``path`` as MuJoCo compiles the file, or, when it cannot (mesh files
    absent from the corpus, bodies without mass), :func:`compile_without_assets`'s."""
    try:
        return mujoco.MjModel.from_xml_path(os.fspath(path))
    except ValueError:
        return compile_without_assets(path)


def worst_error(path: str, random_configurations: int = 8, seed: int = 7, model=None):
    """The largest pose difference (position over ``max(1 m, farthest body)``, rotation matrix entries)
    between kinechain and MuJoCo over ``qpos0``, every keyframe and random configurations, for
    every body and site (unnamed ones by kinechain's names for them), and how many poses were
    compared."""
    model = compile_model(path) if model is None else model
    data = mujoco.MjData(model)
    chain = kc.load(path)
    assert chain.nq == model.nq, (chain.nq, model.nq)
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(model.njnt)]
    rng = np.random.default_rng(seed)
    configurations = [model.qpos0.copy()]
    configurations += [model.key_qpos[k].copy() for k in range(model.nkey)]
    configurations += [random_qpos(model, rng) for _ in range(random_configurations)]
    body_links, site_links = link_names(model)
    bodies = list(zip(body_links, range(1, model.nbody)))
    sites = list(zip(site_links, range(model.nsite)))
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
