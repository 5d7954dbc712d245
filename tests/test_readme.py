"""The README's Python API snippet runs as printed (in a scratch folder, never the repository's renders/)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.doc_blocks import block_of

README = Path(__file__).resolve().parents[1] / "README.md"


def python_api_snippet() -> str:
    """The first ```python block of the README's "Python API" section."""
    text = README.read_text()
    section = text[text.index("## Python API") :]
    match = re.search(r"```python\n(.*?)```", section, flags=re.S)
    assert match is not None, "the Python API section has no python block"
    return match.group(1)


def test_the_docs_python_page_shows_the_same_snippet() -> None:
    assert block_of("docs/how-to/python-api.md").code == python_api_snippet()


def test_the_readme_fits_on_two_screens_and_links_only_to_what_exists() -> None:
    text = README.read_text()
    assert len(text.splitlines()) <= 200
    for target in re.findall(r"\]\(((?:docs/)[^)#]+)", text):
        assert (README.parent / target).is_file(), f"README links to missing {target}"


def test_the_snippet_is_ten_lines_or_so() -> None:
    lines = [line for line in python_api_snippet().splitlines() if line.strip()]
    assert 6 <= len(lines) <= 12


@pytest.mark.render
def test_the_python_api_snippet_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "renders").mkdir()
    exec(compile(python_api_snippet(), "README.md (Python API)", "exec"), {})
    out = capsys.readouterr().out.splitlines()
    # the first print's comment shows what it prints
    shown = re.search(r"print\(plan\.status.*#\s*(.+)$", python_api_snippet(), flags=re.M)
    assert shown is not None and out[0] == shown.group(1).strip(), out[0]
    assert {line.split()[0] for line in out[1:]} >= {"closed_loop", "open_loop"}
    video = tmp_path / "renders" / "edumip_map.mp4"
    assert video.stat().st_size > 10_000
