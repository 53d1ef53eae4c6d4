# The hand-written type stubs (penumbra/__init__.pyi) describe the extension as it is: every
# public name, every class member, and every function's parameter names (the keywords users
# type), read from pybind11's signatures.
import ast
import pathlib

import pytest

import penumbra

STUBS = pathlib.Path(penumbra.__file__).with_name("__init__.pyi")
# Dunder members the bindings define on purpose (the rest come from pybind11 or Python).
PROTOCOL = {"__len__", "__getitem__", "__setitem__", "__iter__", "_repr_png_"}


def stub_tree():
    return ast.parse(STUBS.read_text(), filename=str(STUBS))


def public(name):
    return not name.startswith("_")


def stub_members(cls_node):
    names = {}
    for node in cls_node.body:
        if isinstance(node, ast.FunctionDef):
            names.setdefault(node.name, []).append(node)
        elif isinstance(node, ast.AnnAssign):
            names[node.target.id] = []
    return names


def split_top_level(text):
    """Splits "a: int = 1, b: List[float[3]] = f(x=1, y=2)" at the commas outside brackets."""
    parts, depth, start = [], 0, 0
    for i, c in enumerate(text):
        if c in "([{":
            depth += 1
        elif c in ")]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    if text[start:].strip():
        parts.append(text[start:])
    return parts


def runtime_parameters(fn):
    """Parameter names from pybind11's signature line "name(a: T, b: T = d) -> R"."""
    first = fn.__doc__.splitlines()[0]
    inside = first[first.index("(") + 1:first.rindex(") ->")]
    return [p.split(":")[0].strip() for p in split_top_level(inside)]


def stub_parameters(node):
    a = node.args
    return [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]


def test_stubs_name_every_public_name():
    tree = stub_tree()
    top = set()
    for node in tree.body:
        if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
            top.add(node.name)
        elif isinstance(node, ast.AnnAssign):
            top.add(node.target.id)
    stubbed = {n for n in top if public(n)}
    assert stubbed == set(penumbra.__all__), (stubbed ^ set(penumbra.__all__))
    assert {"__version__", "__all__"} <= top
    assert set(penumbra.__all__) == {n for n in dir(penumbra._penumbra) if public(n)}


def test_stub_classes_have_the_runtime_members():
    for node in stub_tree().body:
        if not isinstance(node, ast.ClassDef):
            continue
        cls = getattr(penumbra, node.name)
        if issubclass(cls, BaseException):
            continue
        members = stub_members(node)
        runtime = {k for k in vars(cls) if public(k) or k in PROTOCOL}
        stubbed = {k for k in members if public(k) or k in PROTOCOL}
        assert stubbed == runtime, (node.name, stubbed ^ runtime)
        # Options classes take their writable fields as keywords: the stub's __init__ lists
        # them all.
        if "__init__" in members and len(members["__init__"]) == 1:
            init = members["__init__"][0]
            if init.args.kwonlyargs:
                fields = [k for k, v in vars(cls).items()
                          if isinstance(v, property) and v.fset is not None]
                assert [a.arg for a in init.args.kwonlyargs] == fields, node.name


def test_stub_functions_take_the_runtime_keywords():
    checked = 0
    for node in stub_tree().body:
        if isinstance(node, ast.FunctionDef) and public(node.name):
            assert stub_parameters(node) == runtime_parameters(getattr(penumbra, node.name)), \
                node.name
            checked += 1
        elif isinstance(node, ast.ClassDef):
            cls = getattr(penumbra, node.name)
            for name, defs in stub_members(node).items():
                fn = vars(cls).get(name)
                if len(defs) != 1 or not callable(fn) or isinstance(fn, property) \
                        or "Overloaded function" in (fn.__doc__ or "") or name == "__init__":
                    continue
                assert stub_parameters(defs[0]) == runtime_parameters(fn), (node.name, name)
                checked += 1
    assert checked > 60  # 69 functions and methods when written


def test_the_checks_see_a_wrong_stub():
    # Negative control: a renamed keyword and a missing member are what the tests above catch.
    wrong = ast.parse("def write_image(path, img, exposure=None, metadata=None): ...").body[0]
    assert stub_parameters(wrong) != runtime_parameters(penumbra.write_image)
    assert runtime_parameters(penumbra.add_ambient_residual) == ["ctx", "env", "lights", "options"]
    node = next(n for n in stub_tree().body if isinstance(n, ast.ClassDef) and n.name == "LightSet")
    node.body = [n for n in node.body if getattr(n, "name", None) != "__iter__"]
    assert "__iter__" not in stub_members(node) and "__iter__" in vars(penumbra.LightSet)


def test_package_is_typed():
    assert STUBS.with_name("py.typed").exists()
    with pytest.raises(SyntaxError):
        ast.parse("def f(:")  # the parser used above does reject broken text
