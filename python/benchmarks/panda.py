"""Run time of kinechain from Python on the Panda, with Pinocchio in the same run when it is
installed (``pip install pin``), and pytorch_kinematics on the CPU when it is
(``pip install pytorch_kinematics``): ``python python/benchmarks/panda.py``. Prints a markdown table and the CPU.

Each row is the median of seven rounds of at least 0.2 s; the methods run in alternation, so
that they see the same state of the machine."""

import os
import platform
import statistics
import time
from importlib.metadata import version

import numpy as np

import kinechain as kc

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
URDF = os.path.join(ROOT, "robots", "panda.urdf")


def cpu():
    try:
        with open("/proc/cpuinfo") as f:
            info = {}
            for line in f.read().splitlines():
                if ":" in line:
                    k, v = line.split(":", 1)
                    info.setdefault(k.strip(), v)
        return f"{info['model name'].strip()} (family {info['cpu family'].strip()}, model {info['model'].strip()})"
    except (OSError, KeyError):
        return platform.processor() or "unknown CPU"


def per_call(f, items=1, rounds=7, min_time=0.2):
    """Median seconds per item of `f()` (which handles `items` items)."""
    times = []
    for _ in range(rounds):
        n, start = 0, time.perf_counter()
        while True:
            f()
            n += 1
            elapsed = time.perf_counter() - start
            if elapsed >= min_time:
                break
        times.append(elapsed / (n * items))
    return statistics.median(times)


def main():
    chain = kc.load(URDF)
    rng = np.random.default_rng(1)
    q1 = chain.neutral()
    n = 100_000
    qs = rng.uniform(chain.lower, chain.upper, (n, chain.dof))
    rows = []

    rows.append(("kinechain `chain.fk(q)`, all links, one configuration", per_call(lambda: chain.fk(q1)), "13 × 4×4 numpy"))
    rows.append(("kinechain `chain.fk(q, links=[hand])`, one configuration", per_call(lambda: chain.fk(q1, links=["panda_hand"])), "1 × 4×4 numpy"))
    hand = ["panda_hand"]
    rows.append(("kinechain `chain.fk(q, links=hand)`, the list made once, one configuration", per_call(lambda: chain.fk(q1, links=hand)), "1 × 4×4 numpy"))
    rows.append(("kinechain `chain.poses(q)`, all links, one configuration", per_call(lambda: chain.poses(q1)), "(13, 4, 4) numpy"))
    rows.append(("kinechain `chain.pose(q, \"panda_hand\")`, one configuration", per_call(lambda: chain.pose(q1, "panda_hand")), "(4, 4) numpy"))
    rows.append(("kinechain batch of 100 000, end link, 1 thread", per_call(lambda: chain.fk(qs, links=["panda_hand"], threads=1), n, rounds=5), "per configuration"))
    rows.append(("kinechain batch of 100 000, end link, all threads", per_call(lambda: chain.fk(qs, links=["panda_hand"]), n, rounds=5), "per configuration"))
    rows.append(("kinechain batch of 100 000, all links, 1 thread", per_call(lambda: chain.fk(qs, threads=1), n, rounds=5), "per configuration"))
    rows.append(("kinechain batch of 100 000, all links, all threads", per_call(lambda: chain.fk(qs), n, rounds=5), "per configuration"))
    out = chain.fk(qs).poses
    rows.append(("kinechain batch of 100 000, all links, 1 thread, `out=` reused", per_call(lambda: chain.fk(qs, threads=1, out=out), n, rounds=5), "per configuration"))
    rows.append(("kinechain batch of 100 000, all links, all threads, `out=` reused", per_call(lambda: chain.fk(qs, out=out), n, rounds=5), "per configuration"))
    # What writing memory allows: numpy filling the same (N, 13, 4, 4) array (1.7 KB per
    # configuration), with nothing computed.
    rows.append(("numpy `out.fill(1.0)` of that array, 1 thread", per_call(lambda: out.fill(1.0), n, rounds=5), "per configuration"))
    out1 = chain.fk(qs, links=["panda_hand"]).poses
    rows.append(("kinechain batch of 100 000, end link, 1 thread, `out=` reused", per_call(lambda: chain.fk(qs, links=["panda_hand"], threads=1, out=out1), n, rounds=5), "per configuration"))
    rows.append(("kinechain `chain.fk(q, check_limits=True)`, one configuration", per_call(lambda: chain.fk(q1, check_limits=True)), "the default, passed by keyword"))
    rows.append(("kinechain Jacobian of the hand, one configuration", per_call(lambda: chain.jacobian(q1, "panda_hand")), "6 × 8 numpy"))
    rows.append(("kinechain Jacobian of the hand, batch of 100 000, 1 thread", per_call(lambda: chain.jacobian(qs, "panda_hand", threads=1), n, rounds=5), "per configuration"))
    rows.append(("kinechain Jacobian of the hand, batch of 100 000, all threads", per_call(lambda: chain.jacobian(qs, "panda_hand"), n, rounds=5), "per configuration"))
    # The binding's cost: each batch from Python against the core doing the same work timed
    # from Rust in this process, one thread, alternated: new arrays against numpy arrays made
    # by Rust inside its timed run; `out=` against buffers written before its clock starts.
    from kinechain import _kinechain

    qds = rng.uniform(-1.0, 1.0, qs.shape)
    qdds = rng.uniform(-1.0, 1.0, qs.shape)
    rv = chain.fk(qs, qds, threads=1)
    ra = chain.fk(qs, qds, qdds, threads=1)
    jac = chain.jacobian(qs, "panda_hand", threads=1)
    cases = [
        ("end-link poses", lambda: chain.fk(qs, links=["panda_hand"], threads=1), lambda: chain.fk(qs, links=["panda_hand"], threads=1, out=out1), {"links": ["panda_hand"]}),
        ("all-links poses", lambda: chain.fk(qs, threads=1), lambda: chain.fk(qs, threads=1, out=out), {}),
        ("the hand's Jacobian", lambda: chain.jacobian(qs, "panda_hand", threads=1), lambda: chain.jacobian(qs, "panda_hand", threads=1, out=jac), {"jacobian": "panda_hand"}),
        ("velocities, all links", lambda: chain.fk(qs, qds, threads=1), lambda: chain.fk(qs, qds, threads=1, out=rv), {"qd": qds}),
        ("accelerations, all links", lambda: chain.fk(qs, qds, qdds, threads=1), lambda: chain.fk(qs, qds, qdds, threads=1, out=ra), {"qd": qds, "qdd": qdds}),
    ]
    ratios = []
    for name, new, into, kwargs in cases:
        times = {k: [] for k in ("py", "rust", "py_out", "rust_out")}
        for _ in range(5):
            times["py"].append(per_call(new, n, rounds=1))
            times["rust"].append(_kinechain._rust_batch(chain, qs, repeats=1, fresh=True, **kwargs) / n)
            times["py_out"].append(per_call(into, n, rounds=1))
            times["rust_out"].append(_kinechain._rust_batch(chain, qs, repeats=1, **kwargs) / n)
        ratios.append((name, *(min(times[k]) for k in ("py", "rust", "py_out", "rust_out"))))
    try:
        import pytorch_kinematics as pk
        import torch
    except ImportError:
        pk = None
    if pk is not None:
        # The serial chain to the hand (the arm's seven joints; the fingers are not on it), in
        # float64 on the CPU, as the project's other figures.
        with open(URDF) as f:
            serial = pk.build_serial_chain_from_urdf(f.read(), "panda_hand").to(dtype=torch.float64)
        th = torch.tensor(qs[:, :7])
        th1 = torch.tensor(q1[:7])
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        rows.append(("pytorch_kinematics, one configuration, hand", per_call(lambda: serial.forward_kinematics(th1, end_only=True).get_matrix()), "1 × 4×4 tensor"))
        rows.append(("pytorch_kinematics batch of 100 000, hand, 1 thread", per_call(lambda: serial.forward_kinematics(th, end_only=True).get_matrix(), n, rounds=3), "per configuration"))
        rows.append(("pytorch_kinematics Jacobian of the hand, batch of 100 000, 1 thread", per_call(lambda: serial.jacobian(th), n, rounds=3), "per configuration"))
        torch.set_num_threads(threads)
        rows.append(("pytorch_kinematics batch of 100 000, hand, all threads", per_call(lambda: serial.forward_kinematics(th, end_only=True).get_matrix(), n, rounds=3), "per configuration"))
    try:
        import pinocchio as pin
    except ImportError:
        pin = None
    if pin is not None:
        model = pin.buildModelFromUrdf(URDF)
        data = model.createData()
        pq = pin.neutral(model)
        rows.append(("Pinocchio `forwardKinematics`, one configuration", per_call(lambda: pin.forwardKinematics(model, data, pq)), "poses not read"))

        def with_poses():
            pin.forwardKinematics(model, data, pq)
            pin.updateFramePlacements(model, data)
            return [f.homogeneous for f in data.oMf]

        rows.append(("Pinocchio `forwardKinematics` + `updateFramePlacements` + every frame as numpy", per_call(with_poses), "frames as 4×4 numpy"))
        m = 2_000
        pqs = [pin.randomConfiguration(model) for _ in range(m)]

        def loop():
            for x in pqs:
                pin.forwardKinematics(model, data, x)
                pin.updateFramePlacement(model, data, model.getFrameId("panda_hand"))

        rows.append(("Pinocchio, Python loop over 2 000 configurations, hand frame", per_call(loop, m, rounds=5), "per configuration"))
    print(f"CPU: {cpu()}; {os.cpu_count()} logical CPUs; kinechain {kc.__version__}" + (f", Pinocchio {pin.__version__}" if pin else ", Pinocchio not installed") + (f", pytorch_kinematics {version('pytorch_kinematics')} (torch {torch.__version__}, CPU)" if pk else ", pytorch_kinematics not installed"))
    print()
    print("| method | time | result |")
    print("|---|---:|---|")
    for name, t, what in rows:
        unit = f"{t * 1e9:.1f} ns" if t < 1e-6 else f"{t * 1e6:.2f} µs"
        print(f"| {name} | {unit} | {what} |")
    print()
    print(f"Batches of {n:,} configurations, one thread, ns per configuration (fastest of five alternated runs): from Python against the core called from Rust in this process, into new numpy arrays (made by Rust inside its timed run) and into arrays written before (`out=`; Rust: buffers written before its clock starts)")
    print()
    print("| work | Python, new arrays | Rust, new arrays | ratio | Python, `out=` | Rust, written before | ratio |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, py, rust, py_out, rust_out in ratios:
        print(f"| {name} | {py * 1e9:.1f} | {rust * 1e9:.1f} | {py / rust:.2f}× | {py_out * 1e9:.1f} | {rust_out * 1e9:.1f} | {py_out / rust_out:.2f}× |")


if __name__ == "__main__":
    main()
