#!/usr/bin/env python3
"""Gathers the MJCF models of a MuJoCo source tree into one folder, for the MJCF corpus test
(``KINECHAIN_MUJOCO_MODELS=DIR pytest python/tests -k mujoco_models``):

- every ``.xml`` file under ``model/`` and ``test/`` whose root element is ``<mujoco>``, copied
  with the folder it sits in (its includes, meshes and attached models resolve as in the tree);
- every XML model written as a string in MuJoCo's C++ tests (``R"( ... )"`` raw strings holding
  ``<mujoco``) and Python tests (triple-quoted strings holding ``<mujoco``), each written to
  ``strings/FILE-N.xml`` beside a copy of that test file's ``testdata/`` folder when it has one.

Usage: ``python tools/mujoco_test_models.py MUJOCO_SOURCE_DIR OUT_DIR``. The models are MuJoCo's
(Apache-2.0); they are read by the tests, not kept in this repository.
"""

import pathlib
import re
import shutil
import sys

RAW = re.compile(r'R"([^()\s]{0,16})\((.*?)\)\1"', re.S)
PY = re.compile(r'("""|\'\'\')(.*?)\1', re.S)


def strings(source: pathlib.Path):
    text = source.read_text(errors="replace")
    pattern = RAW if source.suffix in (".cc", ".h") else PY
    for m in pattern.finditer(text):
        body = m.group(2)
        if "<mujoco" in body and "</mujoco>" in body:
            # Only the document: C++ tests format some strings with printf-style holes.
            start, end = body.index("<mujoco"), body.rindex("</mujoco>") + len("</mujoco>")
            doc = body[start:end]
            if "%" in re.sub(r"%[^sdfgi]", "", doc) and re.search(r"%[sdfgi]|\{\}", doc):
                continue
            yield doc


def main(src: str, out: str) -> None:
    src_dir, out_dir = pathlib.Path(src), pathlib.Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    files = 0
    for top in ("model", "test"):
        root = src_dir / top
        if root.is_dir():
            shutil.copytree(root, out_dir / top, dirs_exist_ok=True)
    for path in out_dir.rglob("*.xml"):
        head = path.read_bytes()[:4096].decode("utf-8", "replace")
        files += "<mujoco" in head
    made = 0
    strings_dir = out_dir / "strings"
    for source in sorted(list((src_dir / "test").rglob("*.cc")) + list((src_dir / "python").rglob("*_test.py"))):
        docs = list(strings(source))
        if not docs:
            continue
        folder = strings_dir / source.relative_to(src_dir).parent
        folder.mkdir(parents=True, exist_ok=True)
        testdata = source.parent / "testdata"
        if testdata.is_dir():
            shutil.copytree(testdata, folder / "testdata", dirs_exist_ok=True)
        for n, doc in enumerate(docs):
            (folder / f"{source.stem}-{n}.xml").write_text(doc)
            made += 1
    print(f"{files} model files, {made} models from test strings, in {out_dir}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
