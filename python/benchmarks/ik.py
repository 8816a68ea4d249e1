"""Inverse kinematics on one stored target set: kinechain against TRAC-IK (``pip install
pytracik``), Robotics Toolbox's ``ik_LM`` (``pip install roboticstoolbox-python``), ikpy
(``pip install ikpy``) and Pinocchio's CLIK loop (``pip install pin``), those installed, in the
same run: ``python python/benchmarks/ik.py [N]``. Prints a markdown table and the CPU.

Targets: ``N`` (default 2000) poses from uniform random ``q`` within the limits (seeded), for the
Panda (``panda_link0`` → ``panda_hand``), the UR5 (±2π limits) and the iiwa 7. Each solver is
first checked to evaluate the same forward kinematics as kinechain (to 1e-12), then solves every
target from random seeds (drawn within the limits, the same for all), one at a time on one thread,
at the shared tolerance (1e-6 m and 1e-6 rad, norms) and a 1 ms budget per target; a solution
counts only if kinechain's FK of it is within that tolerance and it is within the limits. Times
include failures. Each peer runs at the shared tolerance and at its own defaults; the column "its
own test" is the share the peer reports solved (its tolerance, its limits). ikpy (SciPy's
optimiser, milliseconds a solve) runs on the first ``N // 10`` targets. kinechain's batches (tracking seeds: the target's q plus 0.1 rad of noise) on
all cores give the solves per second."""

import os
import platform
import statistics
import subprocess
import sys
import time

import tempfile
import xml.etree.ElementTree as XML

import numpy as np

import kinechain as kc

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
TOL = 1e-6
BUDGET = 1e-3


def cpu():
    info = {}
    with open("/proc/cpuinfo") as f:
        for line in f.read().splitlines():
            if ":" in line:
                k, v = line.split(":", 1)
                info.setdefault(k.strip(), v.strip())
    return f"{info.get('model name')} (family {info.get('cpu family')}, model {info.get('model')}), {os.cpu_count()} logical CPUs"


def urdf_of(path):
    """The URDF text of a robot file (DH tables through ``kinechain convert``)."""
    if path.endswith(".urdf"):
        return open(path).read()
    exe = os.path.join(ROOT, "target", "release", "kinechain")
    if not os.path.exists(exe):
        subprocess.run(["cargo", "build", "--release", "-q"], cwd=ROOT, check=True)
    return subprocess.run([exe, "convert", path], capture_output=True, text=True, check=True).stdout


def quaternion_xyzw(r):
    """The unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method)."""
    t = np.trace(r)
    k = int(np.argmax([t, r[0, 0], r[1, 1], r[2, 2]]))
    if k == 0:
        w = np.sqrt(1 + t) / 2
        return (r[2, 1] - r[1, 2]) / (4 * w), (r[0, 2] - r[2, 0]) / (4 * w), (r[1, 0] - r[0, 1]) / (4 * w), w
    i = k - 1
    j, m = (i + 1) % 3, (i + 2) % 3
    v = np.zeros(3)
    v[i] = np.sqrt(1 + r[i, i] - r[j, j] - r[m, m]) / 2
    v[j] = (r[j, i] + r[i, j]) / (4 * v[i])
    v[m] = (r[m, i] + r[i, m]) / (4 * v[i])
    w = (r[m, j] - r[j, m]) / (4 * v[i])
    return v[0], v[1], v[2], w


def gap(chain, link, q, t):
    p = chain.pose(q, link, check_limits=False)
    dp = np.linalg.norm(p[:3, 3] - t[:3, 3])
    r = t[:3, :3].T @ p[:3, :3]
    c = np.clip((np.trace(r) - 1) / 2, -1, 1)
    s = np.linalg.norm(r - r.T) / (2 * np.sqrt(2))
    return dp, np.arctan2(s, c)


def ok(chain, link, q, t):
    if q is None or not np.all(np.isfinite(q)):
        return False
    if np.any(q < chain.lower) or np.any(q > chain.upper):
        return False
    dp, dr = gap(chain, link, q, t)
    return dp <= TOL * 1.0000001 and dr <= TOL * 1.0000001


def run(name, solve, chain, link, targets, seeds):
    """Times ``solve(target, seed) -> (q or None, its own verdict)`` on every target."""
    times, solved, claimed = [], 0, 0
    for t, s in zip(targets, seeds):
        t0 = time.perf_counter()
        q, says = solve(t, s)
        times.append(time.perf_counter() - t0)
        solved += ok(chain, link, q, t)
        claimed = None if says is None else claimed + bool(says)
    times = np.array(times) * 1e6
    own = "no verdict" if claimed is None else f"{100 * claimed / len(targets):.2f} %"
    return [name, f"{len(targets)}", f"{100 * solved / len(targets):.2f} %", own,
            f"{np.median(times):.1f}", f"{np.percentile(times, 99):.1f}", f"{times.mean():.1f}", f"{1e6 / times.mean():,.0f}"]


def path_joints(urdf, base, tip):
    """The URDF's joint elements from ``base`` to ``tip``, in order."""
    root = XML.fromstring(urdf)
    by_child = {j.find("child").get("link"): j for j in root.findall("joint")}
    path, link = [], tip
    while link != base:
        j = by_child[link]
        path.append(j)
        link = j.find("parent").get("link")
    return root, path[::-1]


def origin(joint):
    o = joint.find("origin")
    xyz = [float(v) for v in o.get("xyz", "0 0 0").split()] if o is not None else [0.0] * 3
    rpy = [float(v) for v in o.get("rpy", "0 0 0").split()] if o is not None else [0.0] * 3
    return xyz, rpy


def rtb_ets(rtb, urdf, base, tip):
    """Robotics Toolbox's ETS of the path (its URDF reader needs the meshes' ROS package): each
    joint's origin as translations and Rz·Ry·Rx (URDF's rpy), then the joint about its axis."""
    et = rtb.ET
    ets = rtb.ETS()
    for j in path_joints(urdf, base, tip)[1]:
        xyz, rpy = origin(j)
        for f, v in zip((et.tx, et.ty, et.tz, et.Rz, et.Ry, et.Rx), xyz + rpy[::-1]):
            if v != 0.0:
                ets *= f(v)
        kind = j.get("type")
        if kind in ("revolute", "continuous", "prismatic"):
            a = j.find("axis")
            axis = np.array([float(v) for v in a.get("xyz").split()] if a is not None else [1.0, 0.0, 0.0])
            k = int(np.argmax(np.abs(axis)))
            assert abs(abs(axis[k]) - 1) < 1e-12, f"joint {j.get('name')}: axis {axis} is not a coordinate axis"
            lim = j.find("limit")
            qlim = [float(lim.get("lower")), float(lim.get("upper"))] if kind != "continuous" else [-np.pi, np.pi]
            move = (et.tx, et.ty, et.tz) if kind == "prismatic" else (et.Rx, et.Ry, et.Rz)
            ets *= move[k](flip=bool(axis[k] < 0), qlim=qlim)
    return ets


def rtb_solvers(rtb, chain, tip, urdf, base):
    ets = rtb_ets(rtb, urdf, base, tip)
    nj = ets.n
    gap = max(np.abs(ets.fkine(q[:nj]).A - chain.pose(q, tip)).max() for q in chain.random(20, seed=9))
    assert gap < 1e-12, f"Robotics Toolbox's FK differs from kinechain's by {gap}"

    def solver(**options):
        def solve(t, s):
            # Its tolerance is on E = ½ eᵀ e (e: translation and angle-axis error).
            r = ets.ik_LM(t, q0=s[:nj], joint_limits=True, **options)
            out = s.copy()
            out[:nj] = r.q
            return out, r.success
        return solve
    # E < ½ (1e-6)² puts the whole error vector within the shared tolerance; 30 iterations and 100
    # searches are its defaults, and fit the budget.
    return solver(tol=0.5 * TOL * TOL), solver()


def ikpy_solvers(ikpy_chain, chain, tip, urdf, base):
    """ikpy on a URDF of the path only (its reader follows the first child: the Panda's finger)."""
    root, joints = path_joints(urdf, base, tip)
    keep = {base} | {j.find("child").get("link") for j in joints}
    for e in list(root):
        if (e.tag == "link" and e.get("name") not in keep) or (e.tag == "joint" and e not in joints):
            root.remove(e)
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as f:
        f.write(XML.tostring(root, encoding="unicode"))
    active = [False] + [j.get("type") != "fixed" for j in joints]
    robot = ikpy_chain.Chain.from_urdf_file(f.name, base_elements=[base], active_links_mask=active)
    os.unlink(f.name)
    index = [i for i, a in enumerate(active) if a]

    def full(q):
        x = np.zeros(len(active))
        x[index] = q[: len(index)]
        return x
    gap = max(np.abs(robot.forward_kinematics(full(q)) - chain.pose(q, tip)).max() for q in chain.random(20, seed=9))
    assert gap < 1e-12, f"ikpy's FK differs from kinechain's by {gap}"

    def solve(t, s):
        x = robot.inverse_kinematics_frame(t, initial_position=full(s), orientation_mode="all")
        out = s.copy()
        out[: len(index)] = x[index]
        # ikpy reports no verdict.
        return out, None
    return solve


def clik(pin, chain, tip, urdf):
    """Pinocchio's closed-loop IK example (damped least squares on log6 of the frame error,
    Jlog6, integrate), with the joint limits clipped after each step, until the shared tolerance
    or the budget. Its model is checked to give kinechain's poses first."""
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    fid = model.getFrameId(tip, pin.BODY)
    nj = sum(1 for n in chain.q_names)  # kinechain's q; Pinocchio's is as long, or longer (mimic)
    k = min(nj, model.nq)

    def to_pin(q):
        qp = pin.neutral(model)
        qp[:k] = q[:k]
        return qp

    for q in chain.random(20, seed=9):
        pin.framesForwardKinematics(model, data, to_pin(q))
        gap = np.abs(data.oMf[fid].homogeneous - chain.pose(q, tip)).max()
        assert gap < 1e-12, f"Pinocchio's FK differs from kinechain's by {gap}"
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit

    def solve(t, s):
        goal = pin.SE3(t[:3, :3], t[:3, 3])
        q = to_pin(s)
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < BUDGET:
            pin.framesForwardKinematics(model, data, q)
            i_m_d = data.oMf[fid].actInv(goal)
            err = pin.log(i_m_d).vector
            if np.linalg.norm(err[:3]) < TOL / 2 and np.linalg.norm(err[3:]) < TOL / 2:
                out = s.copy()
                out[:k] = q[:k]
                return out, True
            j = pin.computeFrameJacobian(model, data, q, fid)
            j = -pin.Jlog6(i_m_d.inverse()) @ j
            v = -j.T @ np.linalg.solve(j @ j.T + 1e-12 * np.eye(6), err)
            q = np.clip(pin.integrate(model, q, v * 0.1), lo, hi)
        return None, False

    return solve


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    robots = [("panda", "robots/panda.urdf", "panda_link0", "panda_hand"),
              ("ur5", "robots/ur5.yaml", "base_link", "tool0"),
              ("iiwa7", "robots/iiwa7.yaml", None, None)]
    print(f"CPU: {cpu()}; Python {platform.python_version()}; {n} targets per robot, tolerance {TOL} m and rad, budget {BUDGET * 1e3:g} ms\n")
    print("| robot | solver | targets | solved (1e-6) | its own test | median µs | p99 µs | mean µs | solves/s (1 thread) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for label, path, base, tip in robots:
        chain = kc.load(os.path.join(ROOT, path))
        tip = tip or chain.link_names[-1]
        base = base or chain.link_names[0]
        qs = chain.random(n, seed=1)
        targets = chain.pose(qs, tip)
        seeds = chain.random(n, seed=2)
        rows = []
        urdf = urdf_of(os.path.join(ROOT, path))

        def kinechain(t, s):
            r = chain.ik(t, tip, s, time_limit=BUDGET)
            return r.q, r.success
        rows.append(run("kinechain", kinechain, chain, tip, targets, seeds))
        try:
            import pytracik
        except ImportError:
            pytracik = None
        if pytracik is not None:
            def tracik(eps, budget):
                solver = pytracik.TRAC_IK(base, tip, urdf, budget, eps, pytracik.SolveType.Speed)
                nj = pytracik.get_num_joints(solver)
                # pytracik 0.0.3 reads the Panda's limits as 0 (its URDF has safety_controller
                # soft limits): the file's limits, set explicitly for every robot.
                pytracik.set_joint_limits(solver, chain.lower[:nj], chain.upper[:nj])
                assert np.array_equal(pytracik.get_joint_lower_bounds(solver), chain.lower[:nj])
                fk_gap = max(np.abs(pytracik.fk(solver, q[:nj]) - chain.pose(q, tip)).max() for q in qs[:50])
                assert fk_gap < 1e-12, f"TRAC-IK's FK differs from kinechain's by {fk_gap}"

                def solve(t, s):
                    x, y, z, w = quaternion_xyzw(t[:3, :3])
                    # [status, q...]: a negative status is a failure.
                    r = np.asarray(pytracik.ik(solver, s[:nj], t[0, 3], t[1, 3], t[2, 3], x, y, z, w))
                    out = s.copy()
                    out[:nj] = r[1:]
                    return out, r[0] >= 0
                return solve
            rows.append(run("TRAC-IK (pytracik, Speed, eps 1e-6/√3 per component)", tracik(TOL / np.sqrt(3), BUDGET), chain, tip, targets, seeds))
            rows.append(run("TRAC-IK at its defaults (eps 1e-5, 5 ms)", tracik(1e-5, 5e-3), chain, tip, targets, seeds))
        try:
            import roboticstoolbox as rtb
        except ImportError:
            rtb = None
        if rtb is not None:
            shared, default = rtb_solvers(rtb, chain, tip, urdf, base)
            rows.append(run("Robotics Toolbox ik_LM (C++, Chan; E < ½·1e-12)", shared, chain, tip, targets, seeds))
            rows.append(run("Robotics Toolbox ik_LM at its defaults (E < 1e-6)", default, chain, tip, targets, seeds))
        try:
            import ikpy.chain as ikpy_chain
        except ImportError:
            ikpy_chain = None
        if ikpy_chain is not None:
            few = max(1, n // 10)
            rows.append(run("ikpy (its defaults; orientation_mode='all')", ikpy_solvers(ikpy_chain, chain, tip, urdf, base), chain, tip, targets[:few], seeds[:few]))
        try:
            import pinocchio as pin
        except ImportError:
            pin = None
        if pin is not None:
            rows.append(run("Pinocchio CLIK (its example: DT 0.1, damping 1e-12, limits clipped)", clik(pin, chain, tip, urdf), chain, tip, targets, seeds))
        for r in rows:
            print(f"| {label} | " + " | ".join(r) + " |")
        # Batches on all cores from tracking seeds, and from random seeds.
        track = np.clip(qs + 0.1 * np.random.default_rng(3).standard_normal(qs.shape), chain.lower, chain.upper)
        for what, s in (("tracking", track), ("random", seeds)):
            best = []
            for _ in range(3):
                t0 = time.perf_counter()
                r = chain.ik(targets, tip, s)
                best.append(time.perf_counter() - t0)
            print(f"| {label} | kinechain batch, {os.cpu_count()} threads, {what} seeds | {n} | {100 * r.success.mean():.2f} % | | | | | {n / min(best):,.0f} |")
        # Unreachable: reachable poses pushed outward from the shoulder (the origin of the link
        # after the first joint) to 5 cm beyond the farthest of 20 000 random configurations.
        shoulder = chain.pose(chain.neutral(), chain.link_names[1])[:3, 3]
        sample = chain.pose(chain.random(20_000, seed=11), tip)[:, :3, 3]
        reach = np.max(np.linalg.norm(sample - shoulder, axis=1))
        far = targets[: max(1, n // 2)].copy()
        out = far[:, :3, 3] - shoulder
        far[:, :3, 3] = shoulder + out / np.linalg.norm(out, axis=1, keepdims=True) * (reach + 0.05)
        times, failed, residual = [], 0, []
        for t, s in zip(far, seeds):
            t0 = time.perf_counter()
            r = chain.ik(t, tip, s, time_limit=BUDGET)
            times.append(time.perf_counter() - t0)
            failed += not r.success
            residual.append(float(np.ravel(r.position_error)[0]))
        times = np.array(times) * 1e6
        print(f"| {label} | kinechain, unreachable (5 cm beyond the reach) | {len(far)} | {100 * (1 - failed / len(far)):.2f} % "
              f"(residual {min(residual):.3f}–{max(residual):.3f} m) | | {np.median(times):.1f} | {np.percentile(times, 99):.1f} | {times.mean():.1f} | |")
    # The G1 humanoid (floating base): both feet and both hands as four world targets, from the
    # neutral pose.
    g1 = kc.load(os.path.join(ROOT, "robots", "g1.urdf"), floating_base=True)
    feet_hands = ["left_ankle_roll_link", "right_ankle_roll_link", "left_rubber_hand", "right_rubber_hand"]
    qs = g1.random(max(1, n // 10), seed=9)
    goals = [g1.pose(qs, link) for link in feet_hands]
    times, solved = [], 0
    for i in range(len(qs)):
        t0 = time.perf_counter()
        r = g1.ik([g[i] for g in goals], feet_hands, time_limit=10 * BUDGET, start="neutral")
        times.append(time.perf_counter() - t0)
        solved += bool(r.success)
    times = np.array(times) * 1e6
    print(f"| g1 | kinechain, four targets (feet, hands), from neutral, 10 ms budget | {len(qs)} | {100 * solved / len(qs):.2f} % | | "
          f"{np.median(times):.1f} | {np.percentile(times, 99):.1f} | {times.mean():.1f} | |")


if __name__ == "__main__":
    main()
