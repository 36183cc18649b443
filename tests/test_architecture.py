"""The architecture the folder tree promises, read from the source: core never imports bpy nor the add-on, its
modules import each other without a circle, and every import sits at the top of its module where a reader sees it.

The add-on package's ``__init__`` and ``__main__`` are the exception: ``python -m radiosity_addon`` imports the
package as a top-level module, where its submodules' relative imports of ``..core`` cannot resolve yet, so they
import their submodules inside register() and main().
"""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ENTRY_POINTS = {"radiosity_addon/__init__.py", "radiosity_addon/__main__.py"}


def _modules(package: str) -> dict[str, ast.Module]:
    return {path.stem: ast.parse(path.read_text(encoding="utf-8")) for path in sorted((ROOT / package).glob("*.py"))}


def _imported_names(tree: ast.Module) -> list[tuple[int, str]]:
    """(level, dotted name) of every import: level 0 absolute, 1 the same package, 2 its parent."""
    names = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names += [(0, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.module:
                names.append((node.level, node.module))
            else:
                names += [(node.level, alias.name) for alias in node.names]
    return names


def _core_graph() -> dict[str, set[str]]:
    modules = _modules("core")
    return {name: {dotted.split(".")[0] for level, dotted in _imported_names(tree) if level == 1} - {name}
            for name, tree in modules.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One circle of imports, or None (depth-first search with colours)."""
    state, path = {}, []

    def visit(node):
        state[node] = "open"
        path.append(node)
        for target in sorted(graph.get(node, ())):
            if state.get(target) == "open":
                return path[path.index(target):] + [target]
            if target not in state:
                found = visit(target)
                if found:
                    return found
        path.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_core_imports_neither_bpy_nor_the_addon():
    for name, tree in _modules("core").items():
        for level, dotted in _imported_names(tree):
            assert not (level == 0 and dotted.split(".")[0] in ("bpy", "mathutils")), f"core/{name}.py imports bpy"
            assert not (level >= 2), f"core/{name}.py imports from outside core: {'.' * level}{dotted}"


def test_core_modules_import_each_other_without_a_circle():
    assert _cycle(_core_graph()) is None, f"import circle in core: {' -> '.join(_cycle(_core_graph()))}"


def test_the_circle_finder_finds_one():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


@pytest.mark.parametrize("package", ["core", "radiosity_addon"])
def test_every_import_is_at_the_top_of_its_module(package):
    misplaced = []
    for path in sorted((ROOT / package).glob("*.py")):
        if f"{package}/{path.name}" in ENTRY_POINTS:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        top = {id(node) for node in tree.body}
        misplaced += [f"{package}/{path.name}:{node.lineno}" for node in ast.walk(tree)
                      if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in top]
    assert not misplaced, f"imports inside functions or blocks: {misplaced}"
