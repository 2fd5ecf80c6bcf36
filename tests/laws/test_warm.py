"""The setup's warm-up (`fecheck.laws.warm`) leaves every kernel a scene uses compiled: a
run after it, in a fresh process with the same (otherwise empty) numba cache, compiles
nothing."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

SCENES = Path(__file__).resolve().parents[2] / "validation" / "scenes"


@pytest.mark.validation  # compiles every kernel from an empty cache: over a minute
def test_a_run_after_the_warm_up_compiles_nothing(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    subprocess.run([sys.executable, "-m", "fecheck.laws.warm"], env=env, check=True,
                   capture_output=True)
    code = ("import numba.core.dispatcher as d\n"
            "compiled = []\n"
            "original = d.Dispatcher.compile\n"
            "def compile(self, sig):\n"
            "    if self._cache.load_overload(sig, self.targetctx) is None:\n"
            "        compiled.append(self.py_func.__qualname__)\n"
            "    return original(self, sig)\n"
            "d.Dispatcher.compile = compile\n"
            "from fecheck.cli import main\n"
            "import sys\n"
            "for scene in sys.argv[1:]:\n"
            "    main(['run', scene] if scene != '-' else ['run'])\n"
            "print('COMPILED', sorted(set(compiled)))\n")
    scenes = ["-", str(SCENES / "inclined.toml"), str(SCENES / "polynomial.toml"),
              str(SCENES / "hertz.toml")]
    out = subprocess.run([sys.executable, "-c", code, *scenes], env=env, text=True,
                         capture_output=True, check=False)
    assert "COMPILED []" in out.stdout, out.stdout[-800:] + out.stderr[-800:]
