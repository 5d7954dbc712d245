"""The layers depend one way: planning <- control <- sim; and `control` is this repository's."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"planning": {"control", "sim", "mujoco", "dm_control"}, "control": {"sim", "mujoco", "dm_control"}}


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_lower_layers_do_not_import_upwards(package: str) -> None:
    for path in (ROOT / package).rglob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            for name in names:
                assert name.split(".")[0] not in FORBIDDEN[package], f"{path.relative_to(ROOT)} imports {name}"


def test_control_resolves_to_this_repository() -> None:
    import control

    assert Path(control.__file__).resolve().parent == ROOT / "control"


def _import_graph(package: str) -> dict[str, set[str]]:
    """Module -> the package's modules it imports, counting every import statement (inside functions too)."""
    modules: dict[str, Path] = {}
    for path in (ROOT / package).rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path

    def resolve(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = {m: set() for m in modules}
    for mod, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            graph[mod] |= {t for t in map(resolve, targets) if t is not None and t != mod}
    return graph


@pytest.mark.parametrize("package", ["planning", "control"])
def test_no_import_cycles(package: str) -> None:
    graph = _import_graph(package)
    done: set[str] = set()

    def visit(mod: str, trail: list[str]) -> None:
        if mod in trail:
            cycle = [*trail[trail.index(mod) :], mod]
            raise AssertionError(f"import cycle: {' -> '.join(cycle)}")
        if mod in done:
            return
        for dep in sorted(graph[mod]):
            visit(dep, [*trail, mod])
        done.add(mod)

    for mod in sorted(graph):
        visit(mod, [])
