"""Inverse kinematics on one stored target set: kinechain against TRAC-IK (``pip install
pytracik``) and Pinocchio's CLIK loop (``pip install pin``) when they are installed, in the same
run: ``python python/benchmarks/ik.py [N]``. Prints a markdown table and the CPU.

Targets: ``N`` (default 2000) poses from uniform random ``q`` within the limits (seeded), for the
Panda (``panda_link0`` → ``panda_hand``), the UR5 (±2π limits) and the iiwa 7. Each solver is
first checked to evaluate the same forward kinematics as kinechain (to 1e-12), then solves every
target from random seeds (drawn within the limits, the same for all), one at a time on one thread,
at the shared tolerance (1e-6 m and 1e-6 rad, norms) and a 1 ms budget per target; a solution
counts only if kinechain's FK of it is within that tolerance and it is within the limits. Times
include failures. kinechain's batches (tracking seeds: the target's q plus 0.1 rad of noise) on
all cores give the solves per second."""

import os
import platform
import statistics
import subprocess
import sys
import time

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
    times, solved = [], 0
    for t, s in zip(targets, seeds):
        t0 = time.perf_counter()
        q = solve(t, s)
        times.append(time.perf_counter() - t0)
        solved += ok(chain, link, q, t)
    times = np.array(times) * 1e6
    return [name, f"{100 * solved / len(targets):.2f} %", f"{np.median(times):.1f}", f"{np.percentile(times, 99):.1f}",
            f"{times.mean():.1f}", f"{1e6 / times.mean():,.0f}"]


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
                return out
            j = pin.computeFrameJacobian(model, data, q, fid)
            j = -pin.Jlog6(i_m_d.inverse()) @ j
            v = -j.T @ np.linalg.solve(j @ j.T + 1e-12 * np.eye(6), err)
            q = np.clip(pin.integrate(model, q, v * 0.1), lo, hi)
        return None

    return solve


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    robots = [("panda", "robots/panda.urdf", "panda_link0", "panda_hand"),
              ("ur5", "robots/ur5.yaml", "base_link", "tool0"),
              ("iiwa7", "robots/iiwa7.yaml", None, None)]
    print(f"CPU: {cpu()}; Python {platform.python_version()}; {n} targets per robot, tolerance {TOL} m and rad, budget {BUDGET * 1e3:g} ms\n")
    print("| robot | solver | solved | median µs | p99 µs | mean µs | solves/s (1 thread) |")
    print("|---|---|---|---|---|---|---|")
    for label, path, base, tip in robots:
        chain = kc.load(os.path.join(ROOT, path))
        tip = tip or chain.link_names[-1]
        base = base or chain.link_names[0]
        qs = chain.random(n, seed=1)
        targets = chain.pose(qs, tip)
        seeds = chain.random(n, seed=2)
        rows = []
        rows.append(run("kinechain", lambda t, s: chain.ik(t, tip, s, time_limit=BUDGET).q, chain, tip, targets, seeds))
        try:
            import pytracik
        except ImportError:
            pytracik = None
        if pytracik is not None:
            solver = pytracik.TRAC_IK(base, tip, urdf_of(os.path.join(ROOT, path)), BUDGET, TOL / np.sqrt(3), pytracik.SolveType.Speed)
            nj = pytracik.get_num_joints(solver)
            # pytracik 0.0.3 reads the Panda's limits as 0 (its URDF has safety_controller soft
            # limits): the file's limits, set explicitly for every robot.
            pytracik.set_joint_limits(solver, chain.lower[:nj], chain.upper[:nj])
            assert np.array_equal(pytracik.get_joint_lower_bounds(solver), chain.lower[:nj])
            fk_gap = max(np.abs(pytracik.fk(solver, q[:nj]) - chain.pose(q, tip)).max() for q in qs[:50])
            assert fk_gap < 1e-12, f"TRAC-IK's FK differs from kinechain's by {fk_gap}"

            def tracik(t, s):
                x, y, z, w = quaternion_xyzw(t[:3, :3])
                # [status, q...]: a negative status is a failure.
                r = np.asarray(pytracik.ik(solver, s[:nj], t[0, 3], t[1, 3], t[2, 3], x, y, z, w))
                if r[0] < 0:
                    return None
                q = r[1:]
                out = s.copy()
                out[:nj] = q
                return out
            rows.append(run("TRAC-IK (pytracik, Speed, eps 1e-6/√3 per component)", tracik, chain, tip, targets, seeds))
        try:
            import pinocchio as pin
        except ImportError:
            pin = None
        if pin is not None:
            rows.append(run("Pinocchio CLIK (its example: DT 0.1, damping 1e-12, limits clipped)", clik(pin, chain, tip, urdf_of(os.path.join(ROOT, path))), chain, tip, targets, seeds))
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
            print(f"| {label} | kinechain batch, {os.cpu_count()} threads, {what} seeds | {100 * r.success.mean():.2f} % | | | | {n / min(best):,.0f} |")


if __name__ == "__main__":
    main()
