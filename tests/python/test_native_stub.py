"""addon/_native.pyi, the hand-kept stub of the compiled module, says what the module has: the same
functions, classes and submodule (_testing, written in the stub as a class of static methods), with the
same parameters in the same order (keyword-only ones marked), for every overload; and each class the
same public attributes. pybind11 writes each function's signature at the top of its docstring, which is
what the stub is checked against."""
import ast
import os

import pytest

STUB = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon",
                    "_native.pyi")


def _split_top(text):
    """Split at commas outside brackets and quotes."""
    parts, depth, quote, current = [], 0, None, ""
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "([{":
            depth += 1
        elif ch in ")]}":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(current.strip())
            current = ""
            continue
        current += ch
    if current.strip():
        parts.append(current.strip())
    return parts


def _params_of_signature(line, name):
    """Parameter names (and '*') of a pybind11 signature line 'name(a: T, *, b: T = 1) -> R'."""
    start = line.index(name + "(") + len(name) + 1
    depth, end = 1, start
    while depth:
        depth += {"(": 1, ")": -1}.get(line[end], 0)
        end += 1
    names = [p.split(":")[0].split("=")[0].strip() for p in _split_top(line[start:end - 1])]
    return tuple(n for n in names if n != "self")


def _signatures(obj, name):
    """Every overload's parameters from pybind11's docstring."""
    doc = obj.__doc__ or ""
    lines = [line.strip() for line in doc.splitlines()]
    if len(lines) > 1 and lines[1] == "Overloaded function.":
        return {_params_of_signature(line, name) for line in lines if line[:1].isdigit() and f"{name}(" in line}
    return {_params_of_signature(lines[0], name)}


def _stub_params(node):
    args = node.args
    names = [a.arg for a in args.posonlyargs + args.args if a.arg != "self"]
    if args.vararg:
        names.append("*" + args.vararg.arg)
    elif args.kwonlyargs:
        names.append("*")
    names += [a.arg for a in args.kwonlyargs]
    if args.kwarg:
        names.append("**" + args.kwarg.arg)
    return tuple(names)


def _stub_namespace(body):
    """name -> set of parameter tuples (functions) or the class node. Private classes other than _testing
    are the stub's own typing helpers (the keywords of IkOptions(**kwargs), say), not the module's."""
    out = {}
    for node in body:
        if isinstance(node, ast.ClassDef) and node.name.startswith("_") and node.name != "_testing":
            continue
        if isinstance(node, ast.FunctionDef):
            out.setdefault(node.name, set()).add(_stub_params(node))
        elif isinstance(node, ast.ClassDef):
            out[node.name] = node
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out[node.target.id] = "attribute"
    return out


@pytest.fixture(scope="module")
def stub():
    return _stub_namespace(ast.parse(open(STUB, encoding="utf-8").read(), STUB).body)


def _public(namespace):
    return {n for n in dir(namespace) if not n.startswith("_")}


def _check_functions(owner, names, stub_names, where):
    for name in sorted(names):
        obj = getattr(owner, name)
        if isinstance(obj, type):
            continue
        assert _signatures(obj, name) == stub_names[name], f"{where}{name}: the stub's parameters differ"


def test_the_stub_names_what_the_module_has(native, stub):
    module_names = _public(native) | {"__version__", "_testing"}
    assert module_names == set(stub), (f"only in the module: {sorted(module_names - set(stub))}; "
                                       f"only in the stub: {sorted(set(stub) - module_names)}")
    _check_functions(native, _public(native), stub, "")


def test_the_testing_submodule(native, stub):
    testing = stub["_testing"]
    inside = _stub_namespace(testing.body)
    assert _public(native._testing) == set(inside)
    _check_functions(native._testing, _public(native._testing), inside, "_testing.")


def test_classes_have_the_stubs_attributes_and_constructors(native, stub):
    for name in sorted(_public(native)):
        cls = getattr(native, name)
        if not isinstance(cls, type) or issubclass(cls, BaseException):
            continue
        inside = _stub_namespace(stub[name].body)
        attributes = _public(cls)
        assert attributes == set(inside) - {"__init__", "__len__"}, f"{name}: attributes differ"
        if "__init__" in inside:
            assert _signatures(cls.__init__, "__init__") == inside["__init__"], f"{name}.__init__ differs"


def test_thread_counts_default_to_every_core_as_in_cpp(native):
    """threads=0 (every core) in each binding that takes a thread count, as the C++ jobs' own default
    (tests/native: IkOptions.DefaultThreadCountIsEveryCoreAsInPython)."""
    assert native.IkOptions().threads == 0
    assert "threads: int = 0" in native.quaternion_to_euler.__doc__.splitlines()[0]
