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


def _same_document(a, b):
    """Whether two XML documents have the same root element: names, attributes, text and
    comments, white space between elements ignored."""
    import xml.dom.minidom

    def nodes(n):
        out = []
        for c in n.childNodes:
            if c.nodeType == c.TEXT_NODE and not c.data.strip():
                continue
            if c.nodeType == c.ELEMENT_NODE:
                out.append(("element", c.tagName, sorted(c.attributes.items()), nodes(c)))
            elif c.nodeType in (c.TEXT_NODE, c.COMMENT_NODE):
                out.append((c.nodeType, " ".join(c.data.split())))
        return out

    da, db = xml.dom.minidom.parseString(a).documentElement, xml.dom.minidom.parseString(b).documentElement
    return (da.tagName, sorted(da.attributes.items()), nodes(da)) == (db.tagName, sorted(db.attributes.items()), nodes(db))


# Documents built on xacro's comment rules (which comments before a xacro element go, which
# stay, `xacro:eval-comments`), macro arguments from an include namespace (evaluated in the
# caller's scope since xacro 2.1.0), u'' strings, and namespace declarations lifted out of an
# include inside a macro.
XACRO_DOCUMENTS = {
    "comments": """<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <!-- kept -->

  <!-- dropped -->
  <xacro:property name="n" value="three"/>
  <!-- dropped -->
  <xacro:if value="1"><!-- kept --> text <b/><!-- kept --></xacro:if>
  <!-- dropped -->
  <xacro:macro name="m" params="*blk"><!-- kept --><xacro:insert_block name="blk"/><!-- last --></xacro:macro>
  <xacro:m><!-- in the block: ignored --><blk/></xacro:m>
  <!-- dropped -->
  <xacro:m><blk/></xacro:m>
  <!-- xacro:eval-comments -->
  <!-- ${n} -->
  <!-- ${n} -->
  <link name="l"><!-- ${n} --></link>
  <!-- ${n} -->
  <!-- xacro:eval-comments:on -->
  <!-- ${n} -->
  text
  <!-- ${n} -->
  <!-- xacro:eval-comments -->
  <!-- ${n} --><!-- xacro:eval-comments:off --><!-- ${n} -->
</robot>""",
    "namespaced_macro": """<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="inner.xacro" ns="B"/>
  <xacro:property name="ext" value="main"/>
  <xacro:property name="var" value="main"/>
  <xacro:B.bar arg="${ext}"/>
  <xacro:B.bar arg="${var}"/>
  <xacro:B.bar/>
  <xacro:if value="${u'🍔' * 2 == U'🍔🍔' and len(r'a\\d') == 3 and len('a\\\\d') == 3}"><ok/></xacro:if>
  <xacro:macro name="lift"><xacro:include filename="ns.xacro"/></xacro:macro>
  <xacro:lift/>
</robot>""",
}
XACRO_INCLUDES = {
    "inner.xacro": """<a xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:property name="var" value="2"/>
  <xacro:property name="inner" value="int"/>
  <xacro:macro name="bar" params="arg:=${ext}"><a arg="${arg}" var="${var}" ext="${ext}"/></xacro:macro>
</a>""",
    "ns.xacro": """<inc xmlns:xacro="http://www.ros.org/wiki/xacro" xmlns:b="http://www.ros.org/b"><b:x/></inc>""",
}


@pytest.mark.parametrize("name", sorted(XACRO_DOCUMENTS))
def test_documents_match_xacro_comments_included(tmp_path, name):
    xacro = pytest.importorskip("xacro")
    for file, text in XACRO_INCLUDES.items():
        (tmp_path / file).write_text(text)
    path = tmp_path / f"{name}.xacro"
    path.write_text(XACRO_DOCUMENTS[name])
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        theirs = xacro.process_file(str(path)).toxml()
    finally:
        os.chdir(cwd)
    ours = kc.expand_xacro(path)
    assert _same_document(ours, theirs), f"kinechain:\n{ours}\nxacro:\n{theirs}"
    if name == "namespaced_macro":
        assert "<ok/>" in ours and 'arg="main" var="2" ext="main"' in ours, ours


def _record_xacro_test_documents(test_dir):
    """Runs ros/xacro's own test suite (``test_xacro.py`` in ``test_dir``) with its
    ``quick_xacro`` wrapped to record every document it expands: (text, arguments, options,
    keywords, the test). Returns them and the test module. The suite runs with the installed
    ``xacro`` package (the release xacrodoc uses, 2.1.x), which is the reference: its own
    expectations from an older release may differ from it (its issue #373 changed the scope of
    macro arguments in 2.1.0)."""
    import importlib.util
    import io
    import sys
    import unittest

    sys.path.insert(0, test_dir)
    cwd = os.getcwd()
    os.chdir(test_dir)
    try:
        spec = importlib.util.spec_from_file_location("xacro_own_tests", os.path.join(test_dir, "test_xacro.py"))
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        recorded = []
        original = module.TestXacroBase.quick_xacro

        def quick_xacro(self, xml, cli=None, **kwargs):
            text = xml.read() if hasattr(xml, "read") else xml
            args = dict(a.split(":=", 1) for a in (cli or []) if ":=" in a)
            options = [a for a in (cli or []) if ":=" not in a]
            recorded.append((text, args, options, kwargs, self.id()))
            return original(self, io.StringIO(text) if hasattr(xml, "read") else text, cli, **kwargs)

        module.TestXacroBase.quick_xacro = quick_xacro
        suite = unittest.defaultTestLoader.loadTestsFromModule(module)
        unittest.TextTestRunner(stream=io.StringIO(), verbosity=0).run(suite)
        return recorded, module
    finally:
        os.chdir(cwd)
        sys.path.remove(test_dir)


@pytest.mark.skipif(not os.environ.get("KINECHAIN_XACRO_TESTS"), reason="set KINECHAIN_XACRO_TESTS to ros/xacro's test/ folder")
def test_the_documents_of_xacros_own_test_suite():
    # Every document ros/xacro's test suite expands, expanded by xacro (the installed release)
    # and by kinechain: the same document, comments included (compared as the suite compares
    # them), or both refusing it. Documents that need what kinechain refuses by design (Python
    # comprehensions and imports) or ROS (a package xacro cannot find without it, xacro's
    # command-line options) are counted apart.
    import xml.dom.minidom

    test_dir = os.path.abspath(os.environ["KINECHAIN_XACRO_TESTS"])
    recorded, module = _record_xacro_test_documents(test_dir)
    xacro = module.xacro
    agree, both_refuse, apart, differ = [], [], [], []
    cwd = os.getcwd()
    os.chdir(test_dir)
    try:
        for n, (text, args, options, kwargs, test) in enumerate(recorded):
            if options or kwargs:
                apart.append(f"{test}: xacro options {options} {sorted(kwargs)}")
                continue
            try:
                doc = xacro.parse(text)
                xacro.filestack = None
                xacro.process_doc(doc, mappings=args)
                theirs = doc.toxml()
            except BaseException as e:  # xacro's refusal: any exception
                theirs = e
            if isinstance(theirs, BaseException) and "not found" in str(theirs) and "ackage" in str(theirs):
                apart.append(f"{test}: needs ROS ({theirs})")
                continue
            path = os.path.join(test_dir, f".kinechain-{n}.xacro")
            with open(path, "w") as f:
                f.write(text)
            try:
                ours = kc.expand_xacro(path, args=args)
            except kc.Error as e:
                ours = e
            finally:
                os.remove(path)
            if isinstance(theirs, BaseException) and isinstance(ours, Exception):
                both_refuse.append(test)
            elif isinstance(ours, Exception):
                why = str(ours)
                if "comprehensions are not supported" in why or "import" in why:
                    apart.append(f"{test}: by design: {why.splitlines()[-1]}")
                else:
                    differ.append(f"{test}: kinechain refuses: {why.splitlines()[-1]}")
            elif isinstance(theirs, BaseException):
                differ.append(f"{test}: xacro refuses ({type(theirs).__name__}: {theirs}), kinechain expands")
            elif module.xml_matches(xml.dom.minidom.parseString(ours).documentElement, xml.dom.minidom.parseString(theirs).documentElement):
                agree.append(test)
            else:
                differ.append(f"{test}: different documents\n    kinechain: {ours}\n    xacro:     {theirs}")
    finally:
        os.chdir(cwd)
    print(f"\n{len(recorded)} documents: {len(agree)} the same, {len(both_refuse)} refused by both, "
          f"{len(apart)} apart, {len(differ)} differ")
    for line in apart:
        print("  apart: " + line)
    for line in differ:
        print("  " + line)
    assert not differ
