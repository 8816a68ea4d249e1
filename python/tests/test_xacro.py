"""xacro: kinechain's expansion against the reference expander (`xacrodoc`, which carries ROS 2's
xacro and resolves packages without ROS), loaded both ways with kinechain's URDF reader: the
same joints in the same order, the same limits, and every link pose equal bit for bit at seeded
configurations. The feature file and the bundled vendor descriptions run here; the whole corpus
with ``KINECHAIN_XACRO_CORPUS=path/to/corpus/xacro pytest -k corpus``."""

import os
import pickle
import time

import numpy as np
import pytest

import kinechain as kc

xacrodoc = pytest.importorskip("xacrodoc")

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "tests", "data", "xacro")
FEATURES = os.path.join(DATA, "features", "features.urdf.xacro")


def reference_urdf(path, args=None, package_dirs=()):
    """The URDF that xacrodoc writes for `path` (it compiles the text from the file's directory,
    so relative includes resolve as xacro resolves them)."""
    from xacrodoc import packages

    packages.reset()
    for d in package_dirs:
        packages.look_in([os.path.abspath(d)])
    cwd = os.getcwd()
    os.chdir(os.path.dirname(os.path.abspath(path)))
    try:
        doc = xacrodoc.XacroDoc.from_file(os.path.abspath(path), subargs=args or {}, resolve_packages=False)
        return doc.to_urdf_string()
    finally:
        os.chdir(cwd)


def assert_same(a, b, what):
    assert a.q_names == b.q_names, what
    assert a.joint_names == b.joint_names, what
    assert np.array_equal(a.lower, b.lower) and np.array_equal(a.upper, b.upper), what
    assert a.link_names == b.link_names, what
    qs = [np.zeros(a.nq)] + list(a.random(6, seed=3))
    for q in qs:
        ra, rb = a.fk(q, check_limits=False), b.fk(q, check_limits=False)
        for link in a.link_names:
            assert np.array_equal(ra[link], rb[link]), f"{what}: {link} at {q}"


def test_features_match_xacrodoc(monkeypatch):
    for args in [{}, {"prefix": "left_", "reach": "0.35"}, {"gripper": "false", "reach": "0.2"}]:
        ours = kc.load(FEATURES, args=args)
        theirs = kc.Chain.from_urdf_string(
            reference_urdf(FEATURES, args, [os.path.join(DATA, "features")])
        )
        assert_same(ours, theirs, f"features {args}")


def test_expand_xacro_and_its_keywords():
    text = kc.expand_xacro(FEATURES, args={"prefix": "p_", "gripper": False})
    assert '<joint name="p_j1" type="revolute">' in text
    assert "finger" not in text
    # A package found through package_paths, for a file that is not beside it.
    ur = os.path.join(DATA, "packages", "ur_description", "urdf", "ur.urdf.xacro")
    chain = kc.load(ur, args={"name": "ur", "ur_type": "ur5e"}, package_paths=[os.path.join(DATA, "packages")])
    assert chain.nq == 6 and "tool0" in chain.link_names
    with pytest.raises(TypeError):
        kc.load(FEATURES, args=["prefix:=x"])


def test_errors_are_load_errors(tmp_path):
    bad = tmp_path / "bad.urdf.xacro"
    bad.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <xacro:macro name="m" params="a"><link name="${a}_${b}"/></xacro:macro>\n'
        '  <xacro:m a="x"/>\n</robot>\n'
    )
    with pytest.raises(kc.LoadError, match=r"bad.urdf.xacro:2:.*in macro `m` called at bad.urdf.xacro:3:3: property `b` is not defined"):
        kc.load(bad)
    with pytest.raises(kc.LoadError, match="is not defined"):
        kc.expand_xacro(bad)
    evil = tmp_path / "evil.urdf.xacro"
    evil.write_text(
        '<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        "  <link name=\"${__import__('os').system('touch pwned')}\"/>\n</robot>\n"
    )
    with pytest.raises(kc.LoadError, match="invalid name '__import__'"):
        kc.load(evil)
    assert not (tmp_path / "pwned").exists()


def test_a_xacro_chain_pickles():
    chain = kc.load(FEATURES, args={"prefix": "a_"})
    copy = pickle.loads(pickle.dumps(chain))
    assert copy == chain
    q = chain.random(1, seed=1)[0]
    assert np.array_equal(copy.fk(q)["a_tip"], chain.fk(q)["a_tip"])


def cases(root):
    out = []
    with open(os.path.join(root, "CASES.tsv")) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            fields = line.rstrip("\n").split("\t")
            folder = os.path.join(root, fields[4] if len(fields) > 4 and fields[4] else "packages")
            args = {} if fields[2] == "-" else dict(a.split(":=", 1) for a in fields[2].split())
            expected = os.path.join(root, "expected", fields[0] + ".urdf")
            out.append((fields[0], os.path.join(folder, fields[1]), args, folder, os.path.isfile(expected)))
    return out


def check_against_xacrodoc(root):
    checked = 0
    for case, path, args, folder, has_reference in cases(root):
        if not has_reference:
            with pytest.raises(kc.LoadError):
                kc.load(path, args=args, package_paths=[folder])
            continue
        ours = kc.load(path, args=args, package_paths=[folder])
        theirs = kc.Chain.from_urdf_string(reference_urdf(path, args, [folder]))
        assert_same(ours, theirs, case)
        checked += 1
    return checked


def test_bundled_vendor_descriptions_match_xacrodoc():
    assert check_against_xacrodoc(DATA) == 6


@pytest.mark.skipif("KINECHAIN_XACRO_CORPUS" not in os.environ, reason="set KINECHAIN_XACRO_CORPUS")
def test_corpus():
    checked = check_against_xacrodoc(os.environ["KINECHAIN_XACRO_CORPUS"])
    print(f"{checked} cases agree with xacrodoc")
