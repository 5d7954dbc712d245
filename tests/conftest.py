"""Shared fixtures. MuJoCo's GL backend is chosen once, before any test module imports mujoco.

Tests marked ``slow`` are deselected by default (``-m "not slow"`` in pyproject); run them with
``-m slow``, or everything with ``--all-cases``.
"""

from __future__ import annotations

import pytest


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--all-cases", action="store_true", default=False, help="run every test, slow ones too")


def pytest_configure(config: pytest.Config) -> None:
    from sim.viz import gl

    gl.configure()  # MUJOCO_GL (the user's, or the default) before collection imports mujoco
    if config.getoption("--all-cases"):
        config.option.markexpr = ""
