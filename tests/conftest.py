"""Shared fixtures. Importing ``sim`` first lets it choose MuJoCo's GL backend before mujoco loads.

Tests marked ``slow`` run only with ``-m slow`` or ``--all-cases``.
"""

from __future__ import annotations

import pytest

import sim  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--all-cases", action="store_true", default=False, help="also run tests marked slow")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--all-cases") or "slow" in (config.getoption("-m") or ""):
        return
    skip = pytest.mark.skip(reason="slow: run with -m slow or --all-cases")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
