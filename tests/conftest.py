"""Shared fixtures. Importing ``sim`` first lets it choose MuJoCo's GL backend before mujoco loads."""

from __future__ import annotations

import sim  # noqa: F401  (sets MUJOCO_GL before anything imports mujoco)
