#!/usr/bin/env bash
# Builds the documentation site into docs/_build/html from a fresh clone: installs fecheck
# with its docs extras into .venv (scripts/setup.sh first if there is no .venv), then runs
# Sphinx with warnings as errors. The gallery's examples run during the build, off-screen
# (pyvista with EGL, matplotlib Agg), two at a time (FECHECK_DOCS_JOBS).
#   bash scripts/build_docs.sh        # then open docs/_build/html/index.html
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x .venv/bin/python ] || bash scripts/setup.sh
.venv/bin/python -m pip install -q -e ".[docs]"
export OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 OMP_NUM_THREADS=1 MPLBACKEND=Agg
export VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
.venv/bin/python -m sphinx -W --keep-going -b html docs docs/_build/html "$@"
