"""The documentation site is checked like code: it builds strictly, its runnable blocks run, and its
command reference is generated from the parsers themselves."""

from __future__ import annotations

import argparse
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.doc_blocks import ROOT, Block, runnable_blocks

BLOCKS = runnable_blocks()


def test_the_site_builds_strictly(tmp_path: Path) -> None:
    """Broken links or anchors, a page missing from the navigation, an unresolved API reference, or a
    command reference that cannot be generated fail ``mkdocs build --strict``."""
    assert importlib.util.find_spec("mkdocs") is not None, "install the docs extra: pip install -e '.[docs]'"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    site = tmp_path / "site"
    assert (site / "index.html").is_file()
    cli = (site / "reference" / "cli.html").read_text()
    assert "nhsim simulate" in cli and "--overwrite" in cli
    # links work from disk: pages link to .html files, not to folders a browser cannot open
    assert 'href="tutorials/first-run.html"' in (site / "index.html").read_text()
    assert not list(_misrendered(site))


#: The HTML elements the site's pages are made of (Markdown's, the theme's, mkdocstrings'): any other tag in a
#: page is text the browser hides (a placeholder such as ``<robot>`` written bare).
HTML_TAGS = set(
    "a abbr article aside b blockquote body br button code col colgroup dd del details div dl dt em figcaption "
    "figure footer form h1 h2 h3 h4 h5 h6 head header hr html i img input kbd label li link main meta nav ol option "
    "p path pre script section select small span strong style sub summary sup svg table tbody td textarea tfoot th "
    "thead title tr u ul".split()
)


def _misrendered(site: Path) -> list[str]:
    """What the built pages show other than their Markdown says: an emphasis opened by an unescaped asterisk inside a
    word (``RRT* ... Hybrid-A*`` set in italics, the asterisks gone), an unknown tag (a bare ``<name>``), or a
    Markdown table left as literal ``| ... |`` lines (no blank line before it)."""
    found = []
    for page in sorted(site.rglob("*.html")):
        if {"assets", "search"} & set(page.relative_to(site).parts):
            continue
        html = page.read_text(encoding="utf-8")
        body = re.sub(r"<(pre|code|script|style)\b.*?</\1>", "", html, flags=re.S)  # code is shown as written
        where = page.relative_to(site)
        found += [f"{where}: emphasis after {m.group(0)[:40]!r}" for m in re.finditer(r"\w<(em|strong)>", body)]
        found += [
            f"{where}: hidden <{m.group(1)}>"
            for m in re.finditer(r"<([a-zA-Z][\w-]*)[\s/>]", body)
            if m.group(1).lower() not in HTML_TAGS
        ]
        found += [
            f"{where}: literal table row {m.group(0)[:60]!r}" for m in re.finditer(r"<p>\| [^|<]+ \| [^|<]+ \|", body)
        ]
    return found


def _every_option(parser: argparse.ArgumentParser, prefix: str = "nhsim") -> list[tuple[str, str]]:
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                out += _every_option(sub, f"{prefix} {name}")
        elif action.option_strings and action.help != argparse.SUPPRESS and "-h" not in action.option_strings:
            out += [(prefix, s) for s in action.option_strings]
    return out


def test_the_command_reference_names_every_command_and_option() -> None:
    sys.path.insert(0, str(ROOT / "docs" / "hooks"))
    try:
        import cli_reference
    finally:
        sys.path.remove(str(ROOT / "docs" / "hooks"))
    from sim.cli.main import build_parser

    text = cli_reference.render()
    options = _every_option(build_parser())
    assert len(options) > 100
    sections = {}
    for chunk in re.split(r"^(?=#+ `)", text, flags=re.M)[1:]:
        sections[chunk.split("`")[1]] = chunk
    for command, option in options:
        assert command in sections, f"no section for {command}"
        assert f"`{option}`" in sections[command], f"{command} {option} missing from the reference"


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.owner is None], ids=lambda b: b.name)
def test_a_runnable_block_runs(block: Block, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "renders").mkdir()
    exec(compile(block.code, block.name, "exec"), {"__name__": "__docs__"})


def test_blocks_owned_by_a_test_are_run_there() -> None:
    owned = [b for b in BLOCKS if b.owner is not None]
    assert owned, "the docs should have blocks run by their own tests"
    for b in owned:
        owner = ROOT / b.owner
        assert owner.is_file(), f"{b.name}: no test module {b.owner}"
        assert b.page in owner.read_text(), f"{b.owner} does not read {b.page}"


def test_an_interrupted_benchmark_keeps_its_page_and_stops_the_script(tmp_path: Path) -> None:
    """nhsim handles Ctrl-C itself and exits 130, so bash never saw the interrupt: ``docs/bench.sh bag sim``
    replaced bag.md with a page of "interrupted" (exit status 130) and went on to the next benchmark. Here the
    benchmark is a stand-in that exits 130 as an interrupted nhsim does."""
    root = tmp_path / "repo"
    (root / "docs" / "benchmarks").mkdir(parents=True)
    (root / ".venv" / "bin").mkdir(parents=True)
    (root / "docs" / "bench.sh").write_text((ROOT / "docs" / "bench.sh").read_text())
    python = root / ".venv" / "bin" / "python"
    python.write_text('#!/bin/sh\necho "$*" >> "$(dirname "$0")/ran"\necho "nhsim bench: interrupted" >&2\nexit 130\n')
    python.chmod(0o755)
    page = root / "docs" / "benchmarks" / "bag.md"
    page.write_text("the good page\n")
    done = subprocess.run(["bash", str(root / "docs" / "bench.sh"), "bag", "sim"], capture_output=True, text=True)
    assert done.returncode == 130, done.stderr
    assert "was interrupted (exit status 130); docs/benchmarks/bag.md kept as it was" in done.stderr
    assert page.read_text() == "the good page\n"
    assert sorted(p.name for p in page.parent.iterdir()) == ["bag.md"]  # no temporary page left
    assert (root / ".venv" / "bin" / "ran").read_text() == "-m sim bench bag --repeats 5\n"  # sim never started
    python.write_text('#!/bin/sh\necho "crashed"\nexit 139\n')  # a crash (SIGSEGV) is no interrupt: it is the page
    done = subprocess.run(["bash", str(root / "docs" / "bench.sh"), "bag"], capture_output=True, text=True)
    assert done.returncode == 0 and "(exit status 139)" in page.read_text() and "crashed" in page.read_text()
