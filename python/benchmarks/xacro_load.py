"""Expanding and loading a xacro description: kinechain against xacrodoc (ROS 2's xacro without
ROS, ``pip install xacrodoc``) in the same run, on the UR5e description bundled with the tests:
``python python/benchmarks/xacro_load.py``. Prints a markdown table and the CPU.

kinechain's row is ``kc.load(path, args=...)`` (expansion in Rust, then the URDF reader);
xacrodoc's is ``XacroDoc.from_file(...).to_urdf_string()`` (expansion only: loading the text
would come on top). Each row is the median of seven rounds of at least 0.2 s, the two in
alternation."""

import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from panda import cpu, per_call  # noqa: E402

import kinechain as kc  # noqa: E402

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
PACKAGES = os.path.join(ROOT, "tests", "data", "xacro", "packages")
UR = os.path.join(PACKAGES, "ur_description", "urdf", "ur.urdf.xacro")
ARGS = {"name": "ur", "ur_type": "ur5e"}


def main():
    import xacrodoc
    from xacrodoc import packages

    packages.look_in([os.path.abspath(PACKAGES)])

    def theirs():
        xacrodoc.XacroDoc.from_file(UR, subargs=ARGS, resolve_packages=False).to_urdf_string()

    def ours():
        kc.load(UR, args=ARGS, package_paths=[PACKAGES])

    rounds = {"kinechain": [], "xacrodoc": []}
    for _ in range(7):
        rounds["kinechain"].append(per_call(ours, rounds=1))
        rounds["xacrodoc"].append(per_call(theirs, rounds=1))
    k = statistics.median(rounds["kinechain"])
    x = statistics.median(rounds["xacrodoc"])
    print(f"CPU: {cpu()}")
    print("| UR5e description | time per load | ratio |")
    print("|---|---|---|")
    print(f"| kinechain `kc.load` (expand + load) | {k * 1e3:.2f} ms | 1 |")
    print(f"| xacrodoc (expand only) | {x * 1e3:.2f} ms | {x / k:.1f}× kinechain |")


if __name__ == "__main__":
    main()
