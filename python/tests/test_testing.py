"""kinechain.testing: the regression assertions, as a pytest suite uses them."""

import os

import pytest

import kinechain as kc
from kinechain.testing import assert_matches_golden, assert_same_kinematics, record_golden

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def robot(name):
    return kc.load(os.path.join(ROOT, "robots", name))


def panda_text():
    with open(os.path.join(ROOT, "robots", "panda.urdf")) as f:
        return f.read()


def test_a_recorded_robot_matches_its_golden_file(tmp_path):
    chain = robot("panda.urdf")
    path = tmp_path / "panda.jsonl"
    record_golden(chain, path, samples=20, level="acc")
    first = path.read_bytes()
    record_golden(chain, path, samples=20, level="acc")
    assert path.read_bytes() == first, "the same inputs give the same bytes"
    report = assert_matches_golden(chain, path)
    assert report["verdict"] == "pass" and report["samples"] == 22
    assert {l["link"] for l in report["links"]} == set(chain.link_names)


def test_a_moved_joint_origin_fails_naming_its_child_link(tmp_path):
    path = tmp_path / "golden.jsonl"
    record_golden(robot("panda.urdf"), path)
    moved = kc.Chain.from_urdf_string(
        panda_text().replace('xyz="0.0825 0 0"/>', 'xyz="0.082501 0 0"/>', 1)
    )
    with pytest.raises(AssertionError) as info:
        assert_matches_golden(moved, path)
    message = str(info.value)
    assert "'panda_link4' below joint 'panda_joint4'" in message, message
    with pytest.raises(AssertionError, match="panda_link4"):
        assert_same_kinematics(robot("panda.urdf"), moved)
    assert assert_matches_golden(moved, path, tol=2e-6)["verdict"] == "pass"


def test_standard_and_modified_dh_agree_at_the_tool_only():
    a, b = robot("puma560.yaml"), robot("puma560_modified.yaml")
    report = assert_same_kinematics(a, b, links=["tool"], level="acc")
    assert report["links"][0]["link"] == "tool"
    with pytest.raises(AssertionError, match="first along the chain is 'link1'"):
        assert_same_kinematics(a, b)


def test_impossible_checks_raise_kinechain_errors(tmp_path):
    path = tmp_path / "golden.jsonl"
    record_golden(robot("ur5.yaml"), path, samples=3)
    renamed = kc.Chain.from_file(os.path.join(ROOT, "robots", "ur5.yaml"))
    text = open(os.path.join(ROOT, "robots", "ur5.yaml")).read().replace("name: elbow,", "name: elbow_joint,")
    assert text != open(os.path.join(ROOT, "robots", "ur5.yaml")).read()
    with pytest.raises(kc.Error, match="'elbow'.*'elbow_joint'"):
        assert_matches_golden(kc.Chain.from_yaml_string(text), path)
    lines = path.read_text().splitlines(keepends=True)
    damaged = tmp_path / "damaged.jsonl"
    damaged.write_text("".join(lines[:2]) + lines[2][:40])
    with pytest.raises(kc.Error, match=r"damaged.jsonl:3: the last line has no line end"):
        assert_matches_golden(renamed, damaged)
    with pytest.raises(kc.Error, match="level"):
        assert_same_kinematics(renamed, renamed, level="position")
    with pytest.raises(kc.Error, match="tolerance"):
        assert_same_kinematics(renamed, renamed, tol=-1.0)
