"""The documentation's Python blocks: a block is runnable when the line before it is an HTML comment
``<!-- runnable -->`` (run by ``tests/test_docs.py``) or ``<!-- runnable: tests/FILE.py -->`` (run,
with assertions of its own, by that test module)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
_BLOCK = re.compile(r"<!-- runnable(?::\s*(?P<owner>[^ ]+?))?\s*-->\n```python\n(?P<code>.*?)```", re.S)


@dataclass(frozen=True)
class Block:
    """One runnable block: its page (relative to the repository), line, code and owning test (or None)."""

    page: str
    line: int
    code: str
    owner: str | None

    @property
    def name(self) -> str:
        return f"{self.page}:{self.line}"


def runnable_blocks() -> list[Block]:
    """Every runnable Python block of the docs, in page order."""
    out = []
    for path in sorted(DOCS.rglob("*.md")):
        text = path.read_text()
        for m in _BLOCK.finditer(text):
            line = text.count("\n", 0, m.start("code")) + 1
            out.append(Block(str(path.relative_to(ROOT)), line, m.group("code"), m.group("owner")))
    return out


def block_of(page: str) -> Block:
    """The one runnable block of ``page`` (a path relative to the repository) that a test owns."""
    found = [b for b in runnable_blocks() if b.page == page and b.owner is not None]
    assert len(found) == 1, f"{page} should have exactly one runnable block owned by a test, has {len(found)}"
    return found[0]
