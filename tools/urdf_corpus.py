#!/usr/bin/env python3
"""Loads every public URDF that installed Python packages ship, with kinechain and with Pinocchio,
and compares every link's pose at seeded configurations.

Setup (a virtual environment of its own; nothing here is needed by the tests):
    python3 -m venv /tmp/corpus && /tmp/corpus/bin/pip install -r tools/corpus-requirements.txt
    cargo build --release
    /tmp/corpus/bin/python tools/urdf_corpus.py [--samples 8] [--json report.json]

Files come from `example-robot-data` (its cmeel prefix), `pybullet_data` and `rtbdata` (the
Robotics Toolbox's data, whose `.xacro` files are expanded with the `xacro` package where they
need no ROS package). None of them is written here; they are read where pip put them.

For each file it prints one line per disagreement and a summary: how many files each of the two
loads, which only one loads (with kinechain's message), and the largest position error (m) and
rotation error (rad) between the two over every link of every sample. Configurations are drawn
uniformly within kinechain's limits (±π without limits), mimic joints set from their primary as
kinechain reads them; Pinocchio's continuous joints take (cos θ, sin θ).
"""
import argparse
import json
import math
import os
import random
import subprocess
import sys
import tempfile
import warnings

import numpy as np

try:
    import pinocchio as pin
except ImportError:  # pragma: no cover
    sys.exit("pinocchio is missing: pip install -r tools/corpus-requirements.txt")


def site_dirs():
    """Directories of the installed packages that ship robot files."""
    found = []
    for module in ("pybullet_data", "rtbdata"):
        try:
            m = __import__(module)
            found.append((module, os.path.dirname(m.__file__)))
        except ImportError:
            print(f"note: {module} is not installed; its files are left out", file=sys.stderr)
    prefix = os.path.join(sys.prefix, "lib")
    for root, dirs, _ in os.walk(prefix):
        if "cmeel.prefix" in dirs:
            share = os.path.join(root, "cmeel.prefix", "share", "example-robot-data")
            if os.path.isdir(share):
                found.append(("example-robot-data", share))
            break
    return found


def robot_files():
    files = []
    for package, top in site_dirs():
        for root, _, names in os.walk(top):
            for name in sorted(names):
                if name.endswith(".urdf") or name.endswith(".xacro"):
                    files.append((package, os.path.join(root, name)))
    return sorted(files)


def expand_xacro(path, scratch):
    """The URDF a xacro file expands to, or None when it needs what is not here (ROS packages)."""
    try:
        import xacro  # noqa: F401
    except ImportError:
        return None
    out = os.path.join(scratch, os.path.basename(path).replace(".xacro", "") + ".expanded.urdf")
    if not out.endswith(".urdf"):
        out += ".urdf"
    run = subprocess.run(
        [sys.executable, "-m", "xacro", path, "-o", out],
        capture_output=True, text=True, timeout=60,
    )
    return out if run.returncode == 0 and os.path.exists(out) else None


def kinechain_info(binary, path):
    run = subprocess.run([binary, "info", path], capture_output=True, text=True, timeout=60)
    if run.returncode != 0:
        return None, run.stderr.strip().splitlines()[-1] if run.stderr.strip() else "failed"
    return json.loads(run.stdout), run.stderr.count("warning:")


def kinechain_poses(binary, path, qs):
    lines = "\n".join(json.dumps({"q": q}) for q in qs) + "\n"
    run = subprocess.run(
        [binary, "fk", path, "--batch", "-", "--ignore-limits"],
        input=lines, capture_output=True, text=True, timeout=120,
    )
    if run.returncode != 0:
        raise RuntimeError(run.stderr.strip())
    return [json.loads(l) for l in run.stdout.splitlines()]


def samples(info, count, rng):
    qs = []
    for _ in range(count):
        q = []
        for j in info["joints"]:
            limits = j.get("limits")
            pairs = [limits] if j["dof"] == 1 else [limits["theta"], limits["d"]] if limits else [None, None]
            for l in pairs:
                lo, hi = (l if l else (-math.pi, math.pi))
                q.append(rng.uniform(lo, hi))
        qs.append(q)
    return qs


def joint_values(info, q):
    """Each joint's value by name: the independent ones from q, mimic joints from their primary."""
    values, k = {}, 0
    for j in info["joints"]:
        values[j["name"]] = q[k]
        k += j["dof"]
    for j in info.get("passive_joints", []):
        m = j.get("mimic")
        if m:
            values[j["name"]] = m["multiplier"] * values[m["joint"]] + m["offset"]
    return values


def pin_configuration(model, values):
    q = pin.neutral(model)
    for jid in range(1, model.njoints):
        name = model.names[jid]
        joint = model.joints[jid]
        x = values.get(name, 0.0)
        if joint.nq == 2 and joint.nv == 1:  # continuous: (cos, sin)
            q[joint.idx_q] = math.cos(x)
            q[joint.idx_q + 1] = math.sin(x)
        elif joint.nq == 1:
            q[joint.idx_q] = x
    return q


def rotation_error(a, b):
    """The angle of the rotation between a and b, accurate for small angles (atan2 of the sine
    from the skew part and the cosine from the trace)."""
    d = a.T @ b
    s = 0.5 * math.sqrt((d[2, 1] - d[1, 2]) ** 2 + (d[0, 2] - d[2, 0]) ** 2 + (d[1, 0] - d[0, 1]) ** 2)
    c = (np.trace(d) - 1.0) / 2.0
    return math.atan2(s, c)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--kinechain", default=os.path.join(os.path.dirname(__file__), "..", "target", "release", "kinechain"))
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--json", help="write the per-file results here")
    args = ap.parse_args()
    binary = os.path.abspath(args.kinechain)
    rng = random.Random(20261128)
    results = []
    worst_p = worst_r = 0.0
    worst_at = None
    with tempfile.TemporaryDirectory() as scratch:
        for package, path in robot_files():
            entry = {"package": package, "file": path}
            target = path
            if path.endswith(".xacro"):
                info, message = kinechain_info(binary, path)
                entry["xacro_refused_with_hint"] = info is None and "xacro" in message
                target = expand_xacro(path, scratch)
                if target is None:
                    entry["skipped"] = "xacro file that cannot be expanded here"
                    results.append(entry)
                    continue
                entry["expanded"] = True
            info, note = kinechain_info(binary, target)
            entry["kinechain"] = info is not None
            if info is None:
                entry["kinechain_error"] = note
            else:
                entry["warnings"] = note
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    model = pin.buildModelFromUrdf(target)
                entry["pinocchio"] = True
            except Exception as e:  # Pinocchio raises several kinds
                entry["pinocchio"] = False
                entry["pinocchio_error"] = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            if entry["kinechain"] and entry["pinocchio"] and info["dof"] > 0:
                data = model.createData()
                qs = samples(info, args.samples, rng)
                try:
                    ours = kinechain_poses(binary, target, qs)
                except RuntimeError as e:
                    entry["fk_error"] = str(e)
                    results.append(entry)
                    continue
                ep = er = 0.0
                for q, result in zip(qs, ours):
                    pq = pin_configuration(model, joint_values(info, q))
                    pin.forwardKinematics(model, data, pq)
                    pin.updateFramePlacements(model, data)
                    for link, value in result["links"].items():
                        if not model.existFrame(link, pin.BODY):
                            continue
                        m = data.oMf[model.getFrameId(link, pin.BODY)]
                        pose = np.array(value["pose"])
                        ep = max(ep, float(np.max(np.abs(pose[:3, 3] - m.translation))))
                        er = max(er, rotation_error(pose[:3, :3], m.rotation))
                entry["position_error_m"] = ep
                entry["rotation_error_rad"] = er
                if ep > 1e-9 or er > 1e-9:
                    print(f"DIFFERS {path}: position {ep:.3e} m, rotation {er:.3e} rad")
                if ep > worst_p:
                    worst_p, worst_at = ep, path
                worst_r = max(worst_r, er)
            elif entry["kinechain"] != entry["pinocchio"]:
                who = "kinechain" if entry["kinechain"] else "Pinocchio"
                why = entry.get("kinechain_error") or entry.get("pinocchio_error")
                print(f"ONLY {who} loads {path}: {why}")
            results.append(entry)
    considered = [r for r in results if "skipped" not in r]
    both = sum(r.get("kinechain") and r.get("pinocchio") for r in considered)
    ours = sum(bool(r.get("kinechain")) for r in considered)
    theirs = sum(bool(r.get("pinocchio")) for r in considered)
    only_ours = sum(bool(r.get("kinechain")) and not r.get("pinocchio") for r in considered)
    only_theirs = sum(bool(r.get("pinocchio")) and not r.get("kinechain") for r in considered)
    compared = sum("position_error_m" in r for r in considered)
    xacros = [r for r in results if r["file"].endswith(".xacro")]
    print(
        f"{len(results)} files ({len(xacros)} xacro, {len(results) - len(considered)} of them not expandable here); "
        f"{len(considered)} read: kinechain loads {ours}, Pinocchio {theirs}, both {both}; "
        f"only kinechain {only_ours}, only Pinocchio {only_theirs}; "
        f"poses compared on {compared} robots with moving joints: worst position {worst_p:.3e} m "
        f"({worst_at}), worst rotation {worst_r:.3e} rad"
    )
    if xacros:
        hinted = sum(bool(r.get("xacro_refused_with_hint")) for r in xacros)
        print(f"xacro files refused with the expand-it-first hint: {hinted} of {len(xacros)}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 1 if only_theirs else 0


if __name__ == "__main__":
    sys.exit(main())
