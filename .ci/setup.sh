# Shared set-up for ./nhsim and ./run-tests (sourced, not run): everything the project needs on a
# fresh Debian machine with Python >= 3.11 — Debian's libosmesa6 for headless rendering, a virtual
# environment in .venv, and the project installed into it. Idempotent and quick when done already.

nhsim_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
nhsim_python="${PYTHON:-python3}"

nhsim_say() { [ -n "${NHSIM_QUIET_SETUP:-}" ] || echo "setup: $*" >&2; }

nhsim_apt_install() {
    local sudo=""
    if [ "$(id -u)" != 0 ]; then
        if command -v sudo >/dev/null 2>&1; then sudo="sudo"; else
            echo "setup: need root to 'apt-get install $*'; install it, then rerun" >&2
            return 1
        fi
    fi
    nhsim_say "apt-get install $*"
    $sudo apt-get update -qq >/dev/null && $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}

nhsim_setup() {
    if ! command -v "$nhsim_python" >/dev/null 2>&1; then
        echo "setup: $nhsim_python not found; install Python >= 3.11 (Debian: apt-get install python3 python3-venv)" >&2
        return 1
    fi
    if ! "$nhsim_python" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
        echo "setup: nhsim needs Python >= 3.11, $nhsim_python is $("$nhsim_python" -V 2>&1); set PYTHON=..." >&2
        return 1
    fi
    # Headless rendering uses OSMesa (Debian's libosmesa6) where there is no display.
    # grep reads the whole list (no -q): under pipefail an early exit would SIGPIPE ldconfig and the
    # library would look missing on every run
    if command -v ldconfig >/dev/null 2>&1 && ! ldconfig -p 2>/dev/null | grep libOSMesa >/dev/null; then
        if command -v apt-get >/dev/null 2>&1; then
            nhsim_apt_install libosmesa6 || echo "setup: continuing without libosmesa6 (videos will be skipped)" >&2
        else
            echo "setup: no libOSMesa found; install OSMesa for headless rendering" >&2
        fi
    fi
    # The tests' system packages, only on request (NHSIM_BENCH=1: ./run-tests sets it unless told
    # NHSIM_BENCH=0; ./nhsim does not): g++ and Debian's libompl-dev for the bench's OMPL C++ harness
    # (~200 MB), and PostgreSQL's server for the shared-study test of 'nhsim tune'. Without them
    # those tests skip, saying why.
    if [ "${NHSIM_BENCH:-0}" != 0 ] && command -v apt-get >/dev/null 2>&1; then
        local wanted=""
        if ! { command -v g++ >/dev/null 2>&1 && [ -n "$(ls /usr/include/ompl-*/ompl/config.h 2>/dev/null)" ]; }; then
            wanted="g++ libompl-dev"
        fi
        if [ -z "$(ls /usr/lib/postgresql/*/bin/initdb 2>/dev/null)" ]; then
            wanted="$wanted postgresql"
        fi
        if [ -n "$wanted" ]; then
            # shellcheck disable=SC2086  # a word list
            nhsim_apt_install $wanted || echo "setup: continuing without$wanted (their tests are skipped)" >&2
        fi
    fi
    if [ ! -x "$nhsim_root/.venv/bin/python" ]; then
        nhsim_say "creating .venv"
        if ! "$nhsim_python" -m venv "$nhsim_root/.venv" 2>/dev/null; then
            rm -rf "$nhsim_root/.venv"
            local ver
            ver="$("$nhsim_python" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')"
            nhsim_apt_install "python${ver}-venv" || nhsim_apt_install python3-venv
            "$nhsim_python" -m venv "$nhsim_root/.venv"
        fi
    fi
    local stamp="$nhsim_root/.venv/.nhsim-installed" want
    want="$(cat "$nhsim_root/pyproject.toml" | sha256sum | cut -d' ' -f1)"
    if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
        nhsim_say "installing nhsim and its dependencies into .venv (first run takes a few minutes)"
        "$nhsim_root/.venv/bin/python" -m pip install -q --upgrade pip >/dev/null
        "$nhsim_root/.venv/bin/python" -m pip install -q -e "$nhsim_root[dev,docs]"
        echo "$want" > "$stamp"
    fi
}
