"""Griffe extension: the packages' Sphinx markup reads as Markdown on the mkdocstrings pages.

The docstrings are written for ``help()`` and Sphinx, mkdocstrings renders them as Markdown. Before any
docstring is parsed, this extension rewrites it to show what Sphinx would:

- a role becomes inline code of the text Sphinx shows: ``:func:`make_planner``` reads ```make_planner```,
  ``:class:`~planning.core.world.World``` reads ```World```, ``:meth:`title <target>``` reads ```title```;
- a paragraph's trailing ``::`` (an indented literal block follows) becomes ``:``, or goes after a space;
- in ``[x, y, theta] [m, m, rad]`` (units after a bracketed list) the second bracket is escaped outside
  code spans, since Markdown would read the pair as a reference link;
- an attribute without a docstring takes the ``#:`` comment lines right above it (Sphinx autodoc's
  convention, e.g. ``planning.PLANNERS``).

Registered in mkdocs.yml under the python handler's ``extensions``; the rewrite is idempotent.
"""

from __future__ import annotations

import re
from typing import Any

from griffe import Docstring, Extension, GriffeLoader, Module, Object

ROLE = re.compile(r"(?<![\w`]):(?:py:)?(?:func|meth|class|mod|data|attr|obj|exc|const|math):`([^`]+)`")
TITLED = re.compile(r"^(.*?)\s*<[^<>]+>$")
LITERAL_MARK = re.compile(r"(?m)(\S?)([ \t]*)::[ \t]*$")
CODE_SPAN = re.compile(r"(`+).*?\1", re.DOTALL)
BRACKET_PAIR = re.compile(r"\](\s)\[")


def _role_text(target: str) -> str:
    titled = TITLED.match(target)
    if titled and titled.group(1):
        return titled.group(1)
    target = target.lstrip("!")
    if target.startswith("~"):
        return target.rsplit(".", 1)[-1]
    return target.lstrip(".")


def _literal_mark(match: re.Match[str]) -> str:
    before, space = match.group(1), match.group(2)
    return before if space or not before else f"{before}:"


def _escape_pairs(text: str) -> str:
    return BRACKET_PAIR.sub(r"]\1\\[", text)


def to_markdown(text: str) -> str:
    """One docstring's Sphinx markup rewritten as the module docstring says."""
    text = LITERAL_MARK.sub(_literal_mark, ROLE.sub(lambda m: f"`{_role_text(m.group(1))}`", text))
    out, last = [], 0
    for span in CODE_SPAN.finditer(text):
        out += [_escape_pairs(text[last : span.start()]), span.group()]
        last = span.end()
    return "".join([*out, _escape_pairs(text[last:])])


def _comment_docstring(obj: Object, loader: GriffeLoader) -> Docstring | None:
    """The ``#:`` comment lines right above an attribute, as Sphinx autodoc reads them."""
    lines = obj.module.lines
    end = (obj.lineno or 0) - 1  # the line above the attribute (1-based)
    start = end
    while 1 <= start <= len(lines) and lines[start - 1].lstrip().startswith("#:"):
        start -= 1
    if start == end:
        return None
    return Docstring(
        "\n".join(line.lstrip()[2:].removeprefix(" ") for line in lines[start:end]),
        lineno=start + 1,
        endlineno=end,
        parent=obj,
        parser=loader.docstring_parser,
        parser_options=loader.docstring_options,
    )


class SphinxMarkup(Extension):
    """Rewrites every loaded object's docstring (see the module docstring)."""

    def on_package(self, *, pkg: Module, loader: GriffeLoader, **kwargs: Any) -> None:
        self.on_object(obj=pkg, loader=loader)

    def on_object(self, *, obj: Object, loader: GriffeLoader, **kwargs: Any) -> None:
        if obj.docstring is None and obj.is_attribute:
            obj.docstring = _comment_docstring(obj, loader)
        if obj.docstring is not None:
            obj.docstring.value = to_markdown(obj.docstring.value)
