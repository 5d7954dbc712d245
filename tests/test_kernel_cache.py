"""numba's cache directory is named by the kernel sources, so an updated callee is never run stale."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from planning import kernel_cache

ROOT = Path(__file__).resolve().parents[1]


def test_the_kernel_sources_are_the_modules_that_import_numba() -> None:
    found = {p.relative_to(ROOT).as_posix() for p in kernel_cache.kernel_sources()}
    # the pair whose stale cache crashed: the EKF's kernels and the sensing loop that compiles them in
    assert {"control/estimation/kernels.py", "sim/robot/sensing.py", "planning/planners/lattice.py"} <= found
    assert "planning/kernel_cache.py" not in found and "sim/cli/main.py" not in found


def test_the_key_follows_kernel_sources_only(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for package in kernel_cache.PACKAGES:
        (tmp_path / package).mkdir()
    kernel = tmp_path / "control" / "k.py"
    other = tmp_path / "sim" / "text.py"
    kernel.write_text("import numba\nN = 7\n")
    other.write_text("MESSAGE = 'a'\n")
    monkeypatch.setattr(kernel_cache, "_ROOT", tmp_path)
    key = kernel_cache.source_key()
    other.write_text("MESSAGE = 'b'\n")
    assert kernel_cache.source_key() == key  # a module without kernels leaves the cache alone
    kernel.write_text("import numba\nN = 8\n")
    assert kernel_cache.source_key() != key


def _cache_dir_in_a_new_process(env: dict[str, str]) -> str:
    code = "import control.estimation.kernels, numba; print(numba.config.CACHE_DIR)"
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_a_process_uses_the_directory_of_its_sources_or_the_one_it_was_given(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(ROOT), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    want = tmp_path / "xdg" / "nhsim" / "numba" / kernel_cache.source_key()
    assert _cache_dir_in_a_new_process(env) == str(want)
    given = str(tmp_path / "mine")
    assert _cache_dir_in_a_new_process({**env, "NUMBA_CACHE_DIR": given}) == given


def test_old_cache_directories_are_pruned(tmp_path: Path) -> None:
    for i, name in enumerate(["a", "b", "c", "d"]):
        (tmp_path / name).mkdir()
        os.utime(tmp_path / name, (1000 + i, 1000 + i))
    kernel_cache._prune(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c", "d"]


def test_processes_sharing_a_cache_compile_each_kernel_once(tmp_path: Path) -> None:
    """Commands run side by side on a cold cache (montecarlo's and tune's workers, the test workers and the
    commands they start) each compiled every kernel: a process defining nhsim's first cached kernel installs the
    per-kernel compile lock, and one that needs a kernel another holds the lock of waits, then loads it. A
    NUMBA_CACHE_DIR the user gives (the child's alone, none of the locator this process installed) is used through
    the same locator: it skipped the lock."""
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES")}
    env.update(PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    code = (
        "import time, numpy as np\n"
        "from numba.core.dispatcher import Dispatcher\n"
        "import control.fbl as fbl\n"  # a kernel module: its cached kernels are defined on import
        "assert getattr(Dispatcher.compile, 'nhsim_once', False)\n"
        "from planning.kernel_cache import kernel_lock_name, lock_folder\n"
        "kernel = next(v for v in vars(fbl).values() if isinstance(v, Dispatcher))\n"
        "print(lock_folder() / (kernel_lock_name(kernel.py_func) + '.lock'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().startswith(str(tmp_path / "cache" / "compile-locks"))


def test_another_checkout_of_the_same_kernel_sources_loads_their_kernels(tmp_path: Path) -> None:
    """numba names a kernel file's cache folder by its absolute path, so a second clone or worktree of the same
    sources compiled every kernel again; nhsim's own files are kept by their place in the project."""
    copy = tmp_path / "checkout"
    for package in kernel_cache.PACKAGES:
        shutil.copytree(ROOT / package, copy / package, ignore=shutil.ignore_patterns("__pycache__"))
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "NUMBA_CACHE_LOCATOR_CLASSES")}
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    code = (
        "import planning.core.ellipse as e, numpy as np\n"
        "e.ellipse_distances(np.zeros(1), np.zeros(1), 1.0, 2.0)\n"
        "print(e.__file__, e.ellipse_distances.stats.cache_hits.most_common(1), e.ellipse_distances._cache.cache_path)"
    )
    runs = []
    for where in (ROOT, copy):
        done = subprocess.run(
            [sys.executable, "-c", code],
            env={**env, "PYTHONPATH": str(where)},
            cwd=where,
            capture_output=True,
            text=True,
            check=False,
        )
        assert done.returncode == 0, done.stderr
        runs.append(done.stdout.split(" ", 1))
    (first_file, first), (second_file, second) = runs
    assert first_file.startswith(str(ROOT)) and second_file.startswith(str(copy))
    folder = tmp_path / "xdg" / "nhsim" / "numba" / kernel_cache.source_key() / "planning_core"
    assert first.startswith("[]") and first.strip().endswith(str(folder))  # compiled in the first checkout
    assert second.startswith("[((") and ", 1)]" in second and second.strip().endswith(str(folder))  # loaded
