"""The package's shape: layers that import only downward, no cycles, no borrowed private
names, modules of a readable size, and every ``__all__`` name importable."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

import humanoid_ik

SRC = Path(humanoid_ik.__file__).parent
LAYERS = (
    "errors",
    "core",
    "solvers",
    "motion",
    "config",
    "run",
    "outputs",
    "experiments",
    "cli",
)
"""The data flow, bottom to top: a module may import its own layer and those below."""
FACADES = ("humanoid_ik", "humanoid_ik.__main__")
"""The package's front door re-exports from every layer; nothing inside imports it."""
MAX_LINES = 600


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()
EXTENSIONS = {
    ".".join(path.relative_to(SRC.parent).with_suffix("").parts) for path in SRC.rglob("*.c")
}
"""The compiled modules, by their C sources (``_lm_kernel.c``): importing one imports a
module, not a private name."""


def _shim_nodes(tree: ast.Module) -> set[int]:
    """The nodes inside a module-level ``__getattr__``: a deprecated alias's lazy import
    of the name's new home, which may point back at an importer (never upward)."""
    out: set[int] = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name == "__getattr__":
            out |= {id(n) for n in ast.walk(node)}
    return out


def _imports(name: str, path: Path, shims: bool = True) -> list[tuple[str, list[str]]]:
    """``(imported module, imported names)`` for every import of the package, including
    imports inside functions (and, unless ``shims`` is false, inside a deprecated
    alias's module ``__getattr__``)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    tree = ast.parse(path.read_text())
    skip = set() if shims else _shim_nodes(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names if a.name.startswith("humanoid_ik")]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1])
                base = f"{base}.{node.module}" if node.module else base
            if not base.startswith("humanoid_ik"):
                continue
            names = [a.name for a in node.names]
            # `from pkg import module` imports the module
            known = MODULES.keys() | EXTENSIONS
            subs = [f"{base}.{n}" for n in names if f"{base}.{n}" in known]
            out += [(s, []) for s in subs]
            rest = [n for n in names if f"{base}.{n}" not in known]
            if rest or not subs:
                out.append((base, rest))
    return out


def _layer(module: str) -> int | None:
    if module in FACADES:
        return None
    return LAYERS.index(module.split(".")[1])


def test_every_module_belongs_to_a_layer():
    """Each module sits in one of the named layers (or is the package's front door)."""
    for name in MODULES:
        if name not in FACADES:
            assert name.split(".")[1] in LAYERS, name


def test_no_upward_import():
    """No module imports a layer above its own, nor the package's front door."""
    bad = []
    for name, path in MODULES.items():
        mine = _layer(name)
        if mine is None:
            continue
        for target, _ in _imports(name, path):
            theirs = _layer(target)
            if theirs is None or theirs > mine:
                bad.append(f"{name} -> {target}")
    assert bad == []


def test_no_import_cycle():
    """The module import graph (imports inside functions included) has no cycle; a
    deprecated alias's lazy import (a module ``__getattr__``) may point back at an
    importer, as the name's new home imports the old module."""
    graph = {
        name: {t for t, _ in _imports(name, path, shims=False) if t in MODULES and t != name}
        for name, path in MODULES.items()
    }
    # a package's __init__ importing its own submodules is how it re-exports; a
    # submodule importing its package's __init__ back would close a cycle, and is caught
    state: dict[str, int] = {}
    cycles = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                cycles.append(" -> ".join([*stack[stack.index(nxt) :], nxt]))
            elif nxt not in state:
                visit(nxt, [*stack, nxt])
        state[node] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert cycles == []


def test_no_private_name_of_another_module():
    """No module imports a ``_private`` name from another module."""
    bad = [
        f"{name} imports {target}.{n}"
        for name, path in MODULES.items()
        for target, names in _imports(name, path)
        for n in names
        if n.startswith("_") and not n.startswith("__") and target != name
    ]
    assert bad == []


def test_module_size():
    """No module over 600 lines: a longer one does more than one thing."""
    sizes = {name: len(path.read_text().splitlines()) for name, path in MODULES.items()}
    assert {n: s for n, s in sizes.items() if s > MAX_LINES} == {}


@pytest.mark.parametrize("name", sorted(set(MODULES) - {"humanoid_ik.__main__"}))
def test_all_names_import(name):
    """Every name a module lists in ``__all__`` exists."""
    mod = importlib.import_module(name)
    for item in getattr(mod, "__all__", []):
        assert hasattr(mod, item), f"{name}.__all__ lists missing {item!r}"


def test_front_door_lists_each_public_name_once_for_runtime_and_type_checkers():
    """``humanoid_ik/__init__.py`` imports lazily from ``_EXPORTS``; its TYPE_CHECKING
    imports must name the same objects from the same modules."""
    tree = ast.parse((SRC / "__init__.py").read_text())
    typed: dict[str, str] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            for stmt in node.body:
                if isinstance(stmt, ast.ImportFrom):
                    typed.update({a.name: str(stmt.module) for a in stmt.names})
    assert typed == humanoid_ik._EXPORTS
    for name in humanoid_ik.__all__:
        assert getattr(humanoid_ik, name) is not None


_PUBLIC_UNDERSCORE = frozenset({"_replace", "_asdict", "_fields", "_make", "_exit"})
"""Named tuples' public methods and ``os._exit``, which start with an underscore."""
_ALLOWED_PRIVATE = {
    ("humanoid_ik.solvers.mink.adapter", "_weighted_residual"),
}
"""Reads of another package's internals, each in the one module that isolates it:
mink's weighted task residual (``solvers/mink/adapter.py``, pinned to the tested mink
releases, docs/mink.md)."""


def _own_private_names(tree: ast.Module) -> set[str]:
    """The ``_private`` names a module defines: functions, classes, methods, class
    attributes and attributes it assigns (``x._name = ...``)."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            out.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
            out.add(node.attr)
        elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            out.add(node.id)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            out.add(node.target.id)
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") in ("setattr", "getattr"):
            if len(node.args) > 1 and isinstance(node.args[1], ast.Constant):
                out.add(str(node.args[1].value))
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            out.add(node.value)  # __slots__ entries, namedtuple/dataclass field names
    return {n for n in out if n.startswith("_")}


def test_no_private_attribute_of_another_module_is_read():
    """No module reads a ``_private`` attribute it does not define itself (another
    module's object's internals, such as ``chain._jac`` or MuJoCo's ``_address``): what
    one layer needs from another is a public interface."""
    bad = []
    for name, path in MODULES.items():
        tree = ast.parse(path.read_text())
        own = _own_private_names(tree)
        for node in ast.walk(tree):
            if not isinstance(node, ast.Attribute):
                continue
            attr = node.attr
            if not attr.startswith("_") or attr.startswith("__") or attr in _PUBLIC_UNDERSCORE:
                continue
            if attr in own or (name, attr) in _ALLOWED_PRIVATE:
                continue
            value = node.value
            if isinstance(value, ast.Name) and value.id in ("self", "cls"):
                continue  # a class's own or inherited protected members
            if isinstance(value, ast.Call) and getattr(value.func, "id", "") == "super":
                continue
            bad.append(f"{name}:{node.lineno} reads .{attr}")
    assert bad == []
