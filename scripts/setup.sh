#!/usr/bin/env bash
# Installs fecheck on a fresh Debian/Ubuntu machine: the system libraries gmsh and
# off-screen VTK rendering need, CHOLMOD with OpenBLAS (Debian's default BLAS is the
# reference one, on which the FE factorization ran 4-8x slower), then a virtual
# environment in .venv with the package.
#   bash scripts/setup.sh          # runtime + test dependencies
set -euo pipefail
cd "$(dirname "$0")/.."

if command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    pkgs="libglu1-mesa libgl1 libxcursor1 libxft2 libxinerama1 libgomp1 libegl1 libegl-mesa0 libsuitesparse-dev libopenblas0-pthread"
    if ! dpkg -s $pkgs >/dev/null 2>&1; then
        echo "fecheck setup: installing system libraries (gmsh, off-screen rendering, CHOLMOD)"
        $SUDO apt-get update -qq
        DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $pkgs >/dev/null
    fi
fi

PY=${PYTHON:-python3}
[ -x .venv/bin/python ] || "$PY" -m venv .venv
echo "fecheck setup: installing Python packages into .venv (about 1-2 minutes the first time)"
.venv/bin/python -m pip install -q --upgrade pip
.venv/bin/python -m pip install -q -e ".[test]"
# numba compiles the contact and law kernels on first use and caches them on disk: compile
# every one of them here (one small contact of each kind with each law), then solve the
# default scene once, so that a user's first run compiles nothing. numba's cache checks
# only a kernel's own file, not the files of the kernels it calls, so after an update a
# cached kernel could run a callee's old code: the setup drops the cache and rebuilds it
echo "fecheck setup: compiling the contact kernels (once, under a minute)"
find fecheck geometry -path '*/__pycache__/*' \( -name '*.nbi' -o -name '*.nbc' \) -delete
.venv/bin/python -m fecheck.laws.warm
.venv/bin/fecheck run > /dev/null
echo "fecheck setup: done"
