"""The house rules, measured on the source: rooms import one way, no import cycle, short functions.

Every check reads the project's own modules with :mod:`ast` (nothing is imported), so a rule broken
anywhere fails here with the file and line that broke it.
"""

from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("planning", "control", "sim")

#: Longest function (``def`` line to last line) anywhere in the packages.
MAX_FUNCTION_LINES = 80

#: Room -> rooms it must not import (prefix match on dotted module names). The packages depend
#: ``planning <- control <- sim``; inside ``control`` the estimators know nothing of
#: controller design; inside ``sim`` the plant (``physics``) knows nothing of the robot's own software
#: (``robot``), which knows nothing of the loop that runs both (the simulator); neither knows the
#: pipeline, drawing, tools or command line, and only the command line may be imported by nothing else.
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "planning": ("control", "sim", "mujoco", "dm_control"),
    "planning.core": ("planning.planners", "planning.trajectory", "planning.scenario"),
    "planning.collision": ("planning.planners", "planning.trajectory", "planning.scenario"),
    "planning.curves": ("planning.planners", "planning.trajectory", "planning.scenario", "planning.collision"),
    "control": ("sim", "mujoco", "dm_control"),
    "control.estimation": ("control.design",),
    "sim.physics": ("sim.robot", "sim.pipeline", "sim.viz", "sim.tools", "sim.cli", "sim.suite"),
    "sim.robot": ("sim.physics.simulator", "sim.pipeline", "sim.viz", "sim.tools", "sim.cli", "sim.suite"),
    "sim.pipeline": ("sim.viz", "sim.tools", "sim.cli", "sim.suite"),
    "sim.viz": ("sim.pipeline", "sim.tools", "sim.cli", "sim.suite"),
    "sim.suite": ("sim.tools", "sim.cli"),
    "sim.tools": ("sim.cli",),
}

#: Module -> rooms it may import although its room forbids them: the simulator closes the loop
#: between the plant and the robot's software.
ALLOWED: dict[str, tuple[str, ...]] = {"sim.physics.simulator": ("sim.robot",)}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@cache
def _sources() -> dict[str, tuple[Path, ast.Module]]:
    out = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            out[_module_name(path)] = (path, ast.parse(path.read_text(), str(path)))
    return out


def _imports(name: str, tree: ast.Module) -> list[tuple[str, int]]:
    """Every module a module imports (top level or inside functions), with the line."""
    is_pkg = _sources()[name][0].name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                mod = ".".join(base[: len(base) - node.level + 1] + ([mod] if mod else []))
            found.append((mod, node.lineno))
            # ``from pkg import module`` imports the submodule
            found += [(f"{mod}.{a.name}", node.lineno) for a in node.names if f"{mod}.{a.name}" in _sources()]
    return found


def _project_edges() -> dict[str, set[str]]:
    mods = _sources()
    edges: dict[str, set[str]] = {m: set() for m in mods}
    for name, (_, tree) in mods.items():
        for target, _line in _imports(name, tree):
            if target in mods and target != name:
                edges[name].add(target)
    return edges


def _in_room(module: str, room: str) -> bool:
    return module == room or module.startswith(room + ".")


@pytest.mark.parametrize("room", sorted(FORBIDDEN))
def test_rooms_import_one_way(room: str) -> None:
    bad = []
    for name, (path, tree) in _sources().items():
        if not _in_room(name, room):
            continue
        for target, line in _imports(name, tree):
            allowed = ALLOWED.get(name, ())
            if any(_in_room(target, f) for f in FORBIDDEN[room]) and not any(_in_room(target, a) for a in allowed):
                bad.append(f"{path.relative_to(ROOT)}:{line} imports {target}")
    assert not bad, f"room {room} must not import {FORBIDDEN[room]}:\n" + "\n".join(bad)


def _find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One import cycle (a list of modules, first == last) or None; iterative DFS."""
    colour = dict.fromkeys(edges, 0)  # 0 new, 1 on the stack, 2 done
    for root in sorted(edges):
        if colour[root]:
            continue
        stack = [(root, iter(sorted(edges[root])))]
        path = [root]
        colour[root] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                colour[node] = 2
                stack.pop()
                path.pop()
            elif colour[nxt] == 1:
                return [*path[path.index(nxt) :], nxt]
            elif colour[nxt] == 0:
                colour[nxt] = 1
                stack.append((nxt, iter(sorted(edges[nxt]))))
                path.append(nxt)
    return None


def test_no_import_cycle_counting_imports_inside_functions() -> None:
    edges = _project_edges()
    # a package's __init__ re-exporting its own modules is not a cycle through its modules
    for name in edges:
        if _sources()[name][0].name == "__init__.py":
            edges[name] = {t for t in edges[name] if not _in_room(t, name)}
    cycle = _find_cycle(edges)
    assert cycle is None, "import cycle: " + " -> ".join(cycle or [])


def test_find_cycle_finds_one() -> None:
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_no_function_is_longer_than_the_limit() -> None:
    long = []
    for path, tree in _sources().values():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines:\n" + "\n".join(long)


def test_no_compiled_kernel_runs_object_mode_code() -> None:
    """numba caches a kernel without its ``numba.objmode`` blocks and compiles them afresh in every
    process (Hybrid-A*'s deadline clock cost each cold plan about 40 ms so): compiled code reads the
    clock through ``planning.clock.monotonic``. ``tests/test_plan_clock.py`` (slow) runs a plan's second
    process and checks that numba compiles nothing."""
    found = []
    for path, tree in _sources().values():
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr in ("objmode", "object_mode"):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
            elif isinstance(node, ast.ImportFrom) and any(a.name == "objmode" for a in node.names):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not found, "numba object mode in:\n" + "\n".join(found)


def _scalar(node: ast.expr) -> bool:
    """A number, a negated one, or a named constant (``np.nan``, ``math.inf``)."""
    if isinstance(node, ast.UnaryOp):
        return _scalar(node.operand)
    return (isinstance(node, ast.Constant) and isinstance(node.value, (int, float, bool))) or (
        isinstance(node, ast.Attribute) and node.attr in ("nan", "inf", "pi", "e")
    )


def _compiled(node: ast.FunctionDef) -> bool:
    return any("njit" in ast.unparse(d) for d in node.decorator_list)


def test_no_compiled_kernel_copies_an_array_by_slice_assignment() -> None:
    """``dst[a:b] = src`` in a kernel makes numba compile its shape-mismatch error's message formatting, 4-5 s
    in each process that compiles such a kernel afresh (``planning.core.copy_kernels``): kernels copy arrays with
    ``copy_into`` and ``copy_rows_into``, and give a slice only a number (or fill it with ``.fill(x)``).
    What this cannot see, an array given to one row (``dst[i] = row``), is the same cost; the same helpers."""
    found = []
    for path, tree in _sources().values():
        for fn in ast.walk(tree):
            if not (isinstance(fn, ast.FunctionDef) and _compiled(fn)):
                continue
            for node in ast.walk(fn):
                if not isinstance(node, ast.Assign) or _scalar(node.value):
                    continue
                targets = [t for tgt in node.targets for t in (tgt.elts if isinstance(tgt, ast.Tuple) else [tgt])]
                if any(
                    isinstance(t, ast.Subscript) and any(isinstance(n, ast.Slice) for n in ast.walk(t.slice))
                    for t in targets
                ):
                    found.append(f"{path.relative_to(ROOT)}:{node.lineno} {ast.unparse(node)}")
    assert not found, "slice assignments of arrays in kernels:\n" + "\n".join(found)


def _is_table(node: ast.stmt) -> bool:
    value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign, ast.Return, ast.Expr)) else None
    return isinstance(value, (ast.Dict, ast.List, ast.Tuple, ast.Set, ast.Call))


#: Rooms whose modules are named after a command (``sim/cli/<command>.py``, ``sim/tools/bench/<what it
#: benchmarks>.py``, ``sim/viz/plots/<command>.py``) and so may share a name with what they drive.
NAMED_AFTER_COMMANDS = ("sim.cli", "sim.tools.bench", "sim.viz.plots")
#: Names every family of registered things gives its protocol and registry.
SHARED_NAMES = frozenset({"base"})


def test_no_two_modules_share_a_name() -> None:
    by_name: dict[str, list[str]] = {}
    for name, (path, _) in _sources().items():
        if path.name in ("__init__.py", "__main__.py") or any(_in_room(name, r) for r in NAMED_AFTER_COMMANDS):
            continue
        by_name.setdefault(name.rsplit(".", 1)[-1], []).append(name)
    shared = {k: v for k, v in by_name.items() if len(v) > 1 and k not in SHARED_NAMES}
    assert not shared, f"modules doing different things share a name: {shared}"


def test_fmt_skip_only_on_aligned_tables() -> None:
    bad = []
    for path, tree in _sources().values():
        lines = path.read_text().splitlines()
        skips = {i + 1 for i, line in enumerate(lines) if "# fmt: skip" in line}
        tables = {
            node.end_lineno
            for node in ast.walk(tree)
            if isinstance(node, ast.stmt) and not isinstance(node, ast.FunctionDef) and _is_table(node)
        }
        bad += [f"{path.relative_to(ROOT)}:{i}" for i in sorted(skips - tables)]
    assert not bad, "`# fmt: skip` outside a literal table:\n" + "\n".join(bad)


def test_only_the_command_line_parses_arguments_or_prints() -> None:
    bad = []
    for name, (path, tree) in _sources().items():
        if _in_room(name, "sim.cli") or name == "sim.__main__":
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "print":
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno} prints")
            if isinstance(node, ast.Attribute) and node.attr == "Namespace":
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno} uses argparse.Namespace")
        for target, line in _imports(name, tree):
            if target == "argparse":
                bad.append(f"{path.relative_to(ROOT)}:{line} imports argparse")
    assert not bad, "\n".join(bad)


def test_control_resolves_to_this_repository() -> None:
    import control

    assert Path(control.__file__).resolve().parent == ROOT / "control"
