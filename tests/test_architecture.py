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
MAX_LINES = 700


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(SRC.rglob("*.py")):
        parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _imports(name: str, path: Path) -> list[tuple[str, list[str]]]:
    """``(imported module, imported names)`` for every import of the package, including
    imports inside functions."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
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
            subs = [f"{base}.{n}" for n in names if f"{base}.{n}" in MODULES]
            out += [(s, []) for s in subs]
            rest = [n for n in names if f"{base}.{n}" not in MODULES]
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
    """The module import graph (imports inside functions included) has no cycle."""
    graph = {
        name: {t for t, _ in _imports(name, path) if t in MODULES and t != name}
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
    """No module over 700 lines: a longer one does more than one thing."""
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
