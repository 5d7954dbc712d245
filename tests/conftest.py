"""Shared fixtures. Importing ``sim`` first lets it choose MuJoCo's GL backend before mujoco loads.

Tests marked ``slow`` are deselected by default (``-m "not slow"`` in pyproject); run them with
``-m slow``, or everything with ``--all-cases``.
"""

from __future__ import annotations

import pytest

import sim  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--all-cases", action="store_true", default=False, help="run every test, slow ones too")


def pytest_configure(config: pytest.Config) -> None:
    if config.getoption("--all-cases"):
        config.option.markexpr = ""
