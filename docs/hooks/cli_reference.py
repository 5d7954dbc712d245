"""MkDocs hook: the command reference is generated from nhsim's own argparse parsers at build time.

A page that holds the line ``<!-- nhsim-cli-reference -->`` gets, in its place, one section per command
and subcommand with its usage, description and every option's help, read from
``sim.cli.main.build_parser()``. So an option added or renamed shows without anyone editing a page.
"""

from __future__ import annotations

import argparse
import os
import re

MARKER = "<!-- nhsim-cli-reference -->"


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _escape(text: str) -> str:
    """Help text as Markdown that shows it as written: a placeholder such as ``<robot>`` is not an HTML tag, an
    asterisk (``RRT*``) opens no emphasis, and a table cell's bars and brackets stay text."""
    text = text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("*", "\\*")
    return text.replace("|", "\\|").replace("[", "\\[").replace("]", "\\]").replace("\n", " ")


def _option_rows(actions: list[argparse.Action]) -> list[str]:
    rows = []
    for action in actions:
        if isinstance(action, argparse._SubParsersAction | argparse._HelpAction) or action.help == argparse.SUPPRESS:
            continue
        names = ", ".join(f"`{s}`" for s in action.option_strings) or f"`{action.dest}`"
        metavar = action.metavar or (action.dest.upper() if action.option_strings and action.nargs != 0 else "")
        if isinstance(metavar, tuple):
            metavar = " ".join(metavar)
        help_text = action.help or ""
        if "%(default)" in help_text:
            help_text = help_text % {"default": action.default}
        if action.choices is not None and not isinstance(action, argparse._SubParsersAction):
            help_text += " (choices: " + ", ".join(f"`{c}`" for c in action.choices) + ")"
        rows.append(f"| {names} | {('`' + str(metavar) + '`') if metavar else ''} | {_escape(help_text)} |")
    return rows


def _text(text: str, parser: argparse.ArgumentParser) -> list[str]:
    """A description or epilog as ``--help`` prints it: where the parser keeps its lines
    (``RawDescriptionHelpFormatter``), each paragraph with indented lines (an example) kept line for line in a code
    block and the others as paragraphs; else one paragraph."""
    if not issubclass(parser.formatter_class, argparse.RawDescriptionHelpFormatter):
        return [_escape(text.strip()), ""]
    out = []
    for para in re.split(r"\n\s*\n", text.strip("\n")):
        lines = para.split("\n")
        if any(line[:1].isspace() for line in lines):
            out += ["```text", para, "```", ""]
        else:
            out += [_escape(" ".join(line.strip() for line in lines)), ""]
    return out


def _section(name: str, parser: argparse.ArgumentParser, depth: int) -> list[str]:
    os.environ["COLUMNS"] = "110"
    usage = parser.format_usage().strip()
    out = [f"{'#' * depth} `{name}`", ""]
    if parser.description:
        out += _text(parser.description, parser)
    out += ["```", re.sub(r"^usage: ", "", usage), "```", ""]
    groups = [(g, _option_rows(g._group_actions)) for g in parser._action_groups]
    groups = [(g, rows) for g, rows in groups if rows]
    for group, rows in groups:
        if len(groups) > 1:  # --help's groups, with their titles and descriptions
            out += [f"**{_escape(group.title or '')}**", ""]
            if group.description:
                out += _text(group.description, parser)
        out += ["| option | value | what it does |", "|---|---|---|", *rows, ""]
    if parser.epilog:
        out += ["```", parser.epilog.strip(), "```", ""]
    for sub_name, sub in _subparsers(parser).items():
        out += _section(f"{name} {sub_name}", sub, min(depth + 1, 4))
    return out


def render() -> str:
    """The whole command reference as Markdown."""
    from sim.cli.main import build_parser

    return "\n".join(_section("nhsim", build_parser(), 2))


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, render())
    return markdown
