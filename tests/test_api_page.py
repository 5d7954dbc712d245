"""The Python API page (docs/reference/api.md) documents exactly what the three packages export.

The packages re-export their public names lazily (a module ``__getattr__``), which mkdocstrings cannot
follow, so the page names each one in a ``::: package.name`` block. A name added to a package's
``__all__`` and not to the page, or left on the page after it stops being exported, fails here.
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "reference" / "api.md"
PACKAGES = ("planning", "control", "sim")


def _page_sections() -> dict[str, list[str]]:
    """Level-2 heading -> the ``:::`` identifiers under it, in page order."""
    sections: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in PAGE.read_text().splitlines():
        if heading := re.fullmatch(r"## (\S+)", line):
            current = sections.setdefault(heading.group(1), [])
        elif directive := re.fullmatch(r":::\s+(\S+)\s*", line):
            assert current is not None, f"{line!r} comes before the first package heading"
            current.append(directive.group(1))
    return sections


def _exports(package: str) -> list[str]:
    return list(importlib.import_module(package).__all__)


def test_the_page_has_one_section_per_package() -> None:
    assert list(_page_sections()) == list(PACKAGES)


@pytest.mark.parametrize("package", PACKAGES)
def test_the_page_documents_every_exported_name_and_nothing_else(package: str) -> None:
    documented = _page_sections()[package]
    assert documented[:1] == [package], f"the {package} section starts with '::: {package}' (its docstring)"
    names = documented[1:]
    duplicated = sorted({n for n in names if names.count(n) > 1})
    assert not duplicated, f"documented twice: {duplicated}"
    expected = {f"{package}.{name}" for name in _exports(package)}
    missing = sorted(expected - set(names))
    extra = sorted(set(names) - expected)
    assert not missing, f"{package} exports these, docs/reference/api.md does not document them: {missing}"
    assert not extra, f"docs/reference/api.md documents these, {package} does not export them: {extra}"


@pytest.mark.parametrize("package", PACKAGES)
def test_every_exported_name_is_visible_to_static_analysis(package: str) -> None:
    """mkdocstrings (griffe) reads the source without importing it, and finds ``package.name`` through
    the package's ``if TYPE_CHECKING:`` imports; a name exported only through the lazy table would make
    the strict site build fail with "Could not collect"."""
    tree = ast.parse((ROOT / package / "__init__.py").read_text())
    guarded = {
        alias.asname or alias.name
        for node in tree.body
        if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING"
        for stmt in node.body
        if isinstance(stmt, ast.ImportFrom)
        for alias in stmt.names
    }
    assert sorted(set(_exports(package)) - guarded) == []


def _sphinx_roles_extension():
    pytest.importorskip("griffe", reason="install the docs extra: pip install -e '.[docs]'")
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import sphinx_roles
    finally:
        sys.path.remove(str(ROOT / "docs" / "hooks"))
    return sphinx_roles


@pytest.mark.parametrize(
    ("docstring", "markdown"),
    [
        ("see :func:`sim.viz.gl.configure`.", "see `sim.viz.gl.configure`."),
        (":class:`~planning.core.world.World` and :meth:`~.tree.Tree.add`", "`World` and `add`"),
        (":data:`the registry <planning.PLANNERS>`", "`the registry`"),
        ("Usage::\n\n    x = 1", "Usage:\n\n    x = 1"),
        ("Usage ::\n\n    x = 1", "Usage\n\n    x = 1"),
        ("pose [x, y, theta] [m, m, rad]", "pose [x, y, theta] \\[m, m, rad]"),
        ("``a] [b`` and x[0][1]", "``a] [b`` and x[0][1]"),
        ("``sqlite:///:memory:``", "``sqlite:///:memory:``"),
    ],
)
def test_sphinx_markup_reads_as_markdown(docstring: str, markdown: str) -> None:
    extension = _sphinx_roles_extension()
    assert extension.to_markdown(docstring) == markdown
    assert extension.to_markdown(markdown) == markdown  # idempotent: a docstring may be seen twice


def test_the_site_loads_the_sphinx_markup_extension() -> None:
    assert "docs/hooks/sphinx_roles.py" in (ROOT / "mkdocs.yml").read_text()
