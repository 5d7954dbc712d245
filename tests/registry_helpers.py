"""Registries isolated for a test: their entries as they are now, restored after it, and the plugin modules the
test imported (named ``nhsim_test_*``) forgotten again."""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Iterable, Iterator
from typing import Any

import pytest

from planning.core.plugins import PLUGIN_VARIABLE, Registry


@contextlib.contextmanager
def isolated(monkeypatch: pytest.MonkeyPatch, registries: Iterable[Registry[Any]], plugins: str) -> Iterator[None]:
    """Within the block, ``registries`` hold what they hold now, their plugins ``plugins`` ("unloaded": the next
    lookup loads them; "loaded": none load), with ``NHSIM_PLUGINS`` unset."""
    for registered in registries:
        monkeypatch.setattr(registered, "_entries", dict(registered._entries))
        monkeypatch.setattr(registered, "origins", dict(registered.origins))
        monkeypatch.setattr(registered, "plugins", plugins)
    monkeypatch.delenv(PLUGIN_VARIABLE, raising=False)
    modules = set(sys.modules)
    yield
    for name in set(sys.modules) - modules:
        if name.startswith("nhsim_test_"):
            del sys.modules[name]
