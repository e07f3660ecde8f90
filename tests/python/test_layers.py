"""The add-on's layers, as docs/architecture.md draws them: core/ never imports Blender, and each layer
imports only the layers below it (core <- blender <- features <- ui). Read from the source, no Blender."""
import ast
import os

import pytest

ADDON = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon")
LAYERS = ("core", "blender", "features", "ui")
BLENDER_MODULES = {"bpy", "bpy_extras", "mathutils", "bmesh", "gpu", "blf", "addon_utils"}


def _modules(layer):
    folder = os.path.join(ADDON, layer)
    return sorted(os.path.join(folder, n) for n in os.listdir(folder) if n.endswith(".py"))


def _imports(path):
    """(absolute module names, sibling layers reached by relative imports) of one file, wherever they are
    in it (functions included)."""
    absolute, layers = set(), set()
    for node in ast.walk(ast.parse(open(path, encoding="utf-8").read(), path)):
        if isinstance(node, ast.Import):
            absolute.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                absolute.add(node.module.split(".")[0])
            elif node.level == 2:  # from ..layer import x, or from .. import x
                layers.add(node.module.split(".")[0] if node.module else "<package>")
    return absolute, layers


@pytest.mark.parametrize("layer", LAYERS)
def test_each_layer_imports_only_the_layers_below_it(layer):
    below = set(LAYERS[:LAYERS.index(layer)])
    for path in _modules(layer):
        absolute, layers = _imports(path)
        assert layers <= below, f"{os.path.relpath(path, ADDON)} reaches {sorted(layers - below)}"
        if layer == "core":
            assert not absolute & BLENDER_MODULES, f"{os.path.relpath(path, ADDON)} imports Blender"


def test_core_imports_in_plain_python():
    """Not just no `import bpy` in the text: importing every core module pulls in no Blender module."""
    import importlib
    import sys
    for path in _modules("core"):
        importlib.import_module("core." + os.path.basename(path)[:-3])
    assert not BLENDER_MODULES & set(sys.modules)


def test_the_layers_are_all_there_is():
    """Every module of the add-on is in a layer, but the package's own __init__.py."""
    top = sorted(n for n in os.listdir(ADDON) if n.endswith(".py"))
    assert top == ["__init__.py"]
    assert {d for d in os.listdir(ADDON) if os.path.isdir(os.path.join(ADDON, d)) and d != "__pycache__"} \
        == set(LAYERS)


def _ui_properties():
    """The properties ui/ registers on Blender's types (bpy.types.Scene.motionkit_retarget = ...)."""
    names = set()
    for path in _modules("ui"):
        for node in ast.walk(ast.parse(open(path, encoding="utf-8").read(), path)):
            if isinstance(node, ast.Assign):
                for target in node.targets:
                    if isinstance(target, ast.Attribute) and ast.unparse(target.value).startswith("bpy.types."):
                        names.add(target.attr)
    return names


@pytest.mark.parametrize("layer", LAYERS[:-1])
def test_no_layer_below_ui_reads_the_uis_properties(layer):
    """The UI's property groups are the UI's: features/ take settings objects the UI builds from them."""
    registered = _ui_properties()
    assert "motionkit_ik" in registered  # the check itself sees what ui/ registers
    for path in _modules(layer):
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        read = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)} | \
            {node.value for node in ast.walk(tree) if isinstance(node, ast.Constant) and isinstance(node.value, str)}
        assert not read & registered, f"{os.path.relpath(path, ADDON)} reads {sorted(read & registered)}"


@pytest.mark.parametrize("layer", [layer for layer in LAYERS if layer != "blender"])
def test_only_blender_reads_or_writes_blender_data_in_bulk(layer):
    """foreach_get and foreach_set, Blender's bulk access, appear in blender/ only."""
    for path in _modules(layer):
        tree = ast.parse(open(path, encoding="utf-8").read(), path)
        bulk = {node.attr for node in ast.walk(tree) if isinstance(node, ast.Attribute)} & {"foreach_get", "foreach_set"}
        assert not bulk, f"{os.path.relpath(path, ADDON)} calls {sorted(bulk)}"


def _siblings(path):
    """The modules of path's own layer that it imports (from . import x, from .x import y), anywhere in it."""
    out = set()
    for node in ast.walk(ast.parse(open(path, encoding="utf-8").read(), path)):
        if isinstance(node, ast.ImportFrom) and node.level == 1:
            out.update([node.module.split(".")[0]] if node.module else [alias.name for alias in node.names])
    return out


@pytest.mark.parametrize("layer", LAYERS)
def test_no_two_modules_of_a_layer_import_each_other_round_a_cycle(layer):
    """Across layers imports go one way (above); within one, neither may a module reach itself through others
    (a function-level import included): each module can be read, and changed, before the ones it uses."""
    graph = {os.path.basename(p)[:-3]: _siblings(p) for p in _modules(layer)}
    state = {}

    def visit(module, trail):
        if state.get(module) == "done" or module not in graph:
            return
        assert state.get(module) != "open", f"{layer}: {' -> '.join(trail + [module])}"
        state[module] = "open"
        for used in sorted(graph[module]):
            visit(used, trail + [module])
        state[module] = "done"

    for module in sorted(graph):
        visit(module, [])


def test_the_architecture_names_every_module():
    """docs/architecture.md, the map of the add-on, names each module of every layer (as `name`, `name.thing`
    or `layer/name.py`)."""
    text = open(os.path.join(os.path.dirname(ADDON), "docs", "architecture.md"), encoding="utf-8").read()

    def named(layer, name):
        return any(form in text for form in (f"`{name}`", f"`{name}.", f"{layer}/{name}.py"))

    unnamed = [os.path.relpath(p, ADDON) for layer in LAYERS for p in _modules(layer)
               if not p.endswith("__init__.py") and not named(layer, os.path.basename(p)[:-3])]
    assert not unnamed, unnamed
