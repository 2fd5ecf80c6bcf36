"""Time each fecheck verb on the shipped knee and write docs/verb_times.json.

The verb pages read their "Typical time" from that file (the documentation build turns it
into substitutions) and the script writes each CPU time into the README's table of verbs
(tests/test_docs.py checks that they agree), so no time in them is typed by hand.
Each verb runs once as a user runs it (``python -m fecheck VERB ...`` in a subprocess, the
numba kernels already compiled): its CPU time (user + system, what it takes on an idle
machine, the verbs being single-threaded) and its wall time, on the lenhart2015 knee that ships
with fecheck (the ``femur_tibia`` scene) where the verb takes a knee, at the size named in
its command. The machine (cores, load average) is recorded with the times.

    python scripts/time_verbs.py            # every verb (about 15 minutes)
    python scripts/time_verbs.py run keys   # only these verbs, the others kept
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "verb_times.json"
README = REPO / "README.md"
KNEE = "fecheck/data/knee/lenhart2015/lenhart2015_R_"
QUICK = "--set scanned.decimate_faces=1500"

COMMANDS: dict[str, str] = {
    "run": "run femur_tibia",
    "fe": f"fe femur_tibia {QUICK}",
    "flex": f"flex femur_tibia --angles 0:90:10 {QUICK}",
    "sweep": "sweep femur_tibia --param load.force_N --values 400:1200:5",
    "calibrate": f"calibrate femur_tibia {QUICK} -o {{tmp}}/calibration.json",
    "knee": (f"knee import --femur {KNEE}femur_cartilage.stl "
             f"--tibia {KNEE}tibia_cartilage_medial.stl "
             f"--tibia-lateral {KNEE}tibia_cartilage_lateral.stl "
             f"--femur-bone {KNEE}femur_bone_distal60.stl "
             f"--tibia-bone {KNEE}tibia_bone_proximal40.stl "
             "--units mm --side right -o {tmp}/knee.toml"),
    "mesh": f"mesh info {KNEE}femur_cartilage.stl {KNEE}tibia_cartilage_medial.stl",
    "keys": "keys",
    "scenes": "scenes",
    "verify": "verify --quick --out {tmp}/verify",
    "validate": "validate --quick --out {tmp}/validation",
    "stress": "stress --quick",
    "bench": "bench --quick",
    "population": ("population femur_tibia --vary contact.youngs_MPa=uniform:16:24 "
                   "--vary load.force_N=uniform:600:1000 --samples 400"),
    "atlas": ("atlas baseline --vary contact.youngs_MPa=uniform:15:25 "
              "--vary contact.poisson=uniform:0.2:0.4 --samples 200 --fe 6 "
              "--set mesh.plateau_refine_mm=1.4 --set fe.axisym_size_mm=0.2"),
}
"""The command timed per verb (after ``fecheck``); {tmp} is a temporary folder."""


def _duration(seconds: float) -> str:
    """Rounded to what a reader plans with: 3.2 s, 48 s, 4 min."""
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min"


def _text(cpu: float, wall: float, command: str) -> str:
    """'12 s of CPU, 26 s wall (`fecheck run femur_tibia`)', the knee's folder left out."""
    shown = command.replace("{tmp}/", "").replace(KNEE, "")
    return f"{_duration(cpu)} of CPU, {_duration(wall)} wall (`fecheck {shown}`)"


def time_verb(verb: str, tmp: Path) -> dict[str, object]:
    """Run the verb's command once; its wall time, exit code and the text for the pages."""
    command = COMMANDS[verb]
    argv = [sys.executable, "-m", "fecheck", *command.format(tmp=tmp).split()]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(argv, cwd=REPO, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode not in (0, 1):
        raise SystemExit(f"fecheck {command} failed ({done.returncode}): {done.stderr[-800:]}")
    return {"command": f"fecheck {command}", "wall_s": round(wall, 2), "cpu_s": round(cpu, 2),
            "exit_code": done.returncode, "short": _duration(cpu),
            "text": _text(cpu, wall, command)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("verbs", nargs="*", help=f"verbs to time (default: all): {list(COMMANDS)}")
    parser.add_argument("--json", type=Path, default=OUT,
                        help="the file to write (default: docs/verb_times.json)")
    args = parser.parse_args(argv)
    unknown = set(args.verbs) - set(COMMANDS)
    if unknown:
        parser.error(f"no timed command for {sorted(unknown)}")
    data = (json.loads(args.json.read_text(encoding="utf-8")) if args.json.is_file()
            else {"verbs": {}})
    for verb in args.verbs or list(COMMANDS):
        with tempfile.TemporaryDirectory() as tmp:
            data["verbs"][verb] = time_verb(verb, Path(tmp))
        print(f"{verb}: {data['verbs'][verb]['text']}", file=sys.stderr)
        _write(data, args.json)
    update_readme(data)
    return 0


def readme_row(verb: str) -> re.Pattern:
    """The README's table row of `verb`; group 1 is the row up to its last cell, the time."""
    return re.compile(rf"^(\| \[`{re.escape(verb)}`\]\(docs/verbs/[^)]*\) \|.*\| )([^|]*) \|$",
                      re.MULTILINE)


def update_readme(data: dict) -> None:
    """Write each verb's CPU time into the last cell of its row of the README's table."""
    text = README.read_text(encoding="utf-8")
    for verb, row in data["verbs"].items():
        text = readme_row(verb).sub(lambda m, t=row["short"]: m.group(1) + t + " |", text)
    README.write_text(text, encoding="utf-8")


def _write(data: dict, path: Path) -> None:
    """`path` (docs/verb_times.json) with the verbs in COMMANDS order and the machine's
    state."""
    load = os.getloadavg()[0]
    data["machine"] = (f"{os.cpu_count()} cores, load average {load:.1f} when the last verb "
                       f"was timed ({time.strftime('%Y-%m-%d')})")
    data["verbs"] = {verb: data["verbs"][verb] for verb in COMMANDS if verb in data["verbs"]}
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    raise SystemExit(main())
