"""Compile ``harness.cpp`` against the system's OMPL (Debian's ``libompl-dev``) once, cached by source hash.

The binary lives in ``$XDG_CACHE_HOME/nhsim/ompl_native`` (``~/.cache/...`` by default; override with
``NHSIM_CACHE_DIR``) under a name that hashes the source, the compiler's version and the flags, so an
edited harness or a new compiler rebuilds it and concurrent benches never see a half-written binary
(it is written under a temporary name and renamed).
"""

from __future__ import annotations

import glob
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from planning.errors import DependencyError

SOURCE = Path(__file__).with_name("harness.cpp")

#: What to install when the harness cannot be built (Debian / Ubuntu package names).
INSTALL_HINT = "install a C++ compiler and OMPL's headers: sudo apt-get install g++ libompl-dev"

#: Where Debian's libompl-dev puts the headers (OMPL 1.5: /usr/include/ompl-1.5/ompl/config.h).
_HEADER_GLOBS = ("/usr/include/ompl-*/ompl/config.h", "/usr/local/include/ompl-*/ompl/config.h")


def compiler() -> str | None:
    """The C++ compiler: ``$CXX``, else ``g++``, else ``c++`` on the PATH (None when there is none)."""
    cxx = os.environ.get("CXX")
    if cxx:
        return shutil.which(cxx)
    return shutil.which("g++") or shutil.which("c++")


def ompl_flags() -> list[str] | None:
    """Compile flags for OMPL's headers (and Eigen's, which they include), or None when not installed.

    ``pkg-config --cflags ompl`` when it answers (Debian's ``ompl.pc`` lists boost libraries in its
    ``--libs`` that ``libompl-dev`` does not install, so only ``-lompl`` is linked); else the headers
    found by path.
    """
    if shutil.which("pkg-config"):
        run = subprocess.run(["pkg-config", "--cflags", "ompl"], capture_output=True, text=True, check=False)
        if run.returncode == 0:
            return run.stdout.split()
    headers = sorted(p for pattern in _HEADER_GLOBS for p in glob.glob(pattern))
    if not headers:
        return None
    include = str(Path(headers[-1]).parent.parent)
    return [f"-I{include}", "-I/usr/include/eigen3"]


def missing() -> str | None:
    """Why the harness cannot be built here (naming what to install), or None when it can."""
    if compiler() is None:
        return f"no C++ compiler found (set CXX or put g++ on the PATH); {INSTALL_HINT}"
    if ompl_flags() is None:
        return f"OMPL's C++ headers are not installed; {INSTALL_HINT}"
    return None


def cache_dir() -> Path:
    """Directory of the compiled harnesses (``NHSIM_CACHE_DIR``, else the XDG cache directory)."""
    root = os.environ.get("NHSIM_CACHE_DIR")
    if root:
        return Path(root) / "ompl_native"
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(xdg) / "nhsim" / "ompl_native"


def _command(cxx: str, flags: list[str], out: Path) -> list[str]:
    return [cxx, "-O2", "-DNDEBUG", *flags, "-std=c++17", str(SOURCE), "-o", str(out), "-lompl"]


def harness() -> Path:
    """Path of the compiled harness, built now when the cache has none for this source and toolchain.

    Raises:
        DependencyError: No compiler or no OMPL headers (the message says what to install), or the
            compiler failed (the message carries its output).
    """
    why = missing()
    if why is not None:
        raise DependencyError(why)
    cxx, flags = compiler(), ompl_flags()
    assert cxx is not None and flags is not None  # missing() checked both
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True, check=False).stdout
    key = hashlib.sha256(b"\0".join([SOURCE.read_bytes(), version.encode(), " ".join(flags).encode()])).hexdigest()
    target = cache_dir() / f"harness-{key[:16]}"
    if target.exists():
        return target
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".harness-", dir=target.parent)
    os.close(fd)
    try:
        run = subprocess.run(_command(cxx, flags, Path(tmp)), capture_output=True, text=True, check=False)
        if run.returncode != 0:
            raise DependencyError(
                f"compiling the OMPL harness failed ({' '.join(_command(cxx, flags, target))}):\n"
                f"{run.stderr.strip()[-3000:]}\n(the harness is written for OMPL 1.5, Debian's libompl-dev)"
            )
        os.chmod(tmp, 0o755)
        os.replace(tmp, target)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return target
