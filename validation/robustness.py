"""The adversarial pass: bad and edge inputs to every verb, given as a user gives them.

Each input is one command line, ``python -m fecheck VERB ...``, run in its own process
(its own session, killed with its children at its timeout, its address space capped at
`MEMORY_CAP_BYTES`) from a scratch folder that holds the bad files the inputs name
(empty, binary, malformed scenes; empty, textual, metre-scaled, swapped, inverted and huge
meshes; broken calibration files; result files for ``run --from``). Each answer is
classified:

* clean: exit 0 with a result (some output, no NaN in it, every JSON written carries its
  ``provenance``), or exit 2 with one error line (``error:``) and no traceback;
* unclear: anything else (a traceback, exit 1, a signal, no answer within the timeout,
  NaN in the output, an error over more than one line, a JSON without provenance).

Writes a Markdown report: a table of every input with its exit code, the answer's first
line and the verdict, and the count of clean answers.

    python validation/robustness.py [--quick] [--out DIR] [--workers N] [--strict]

--quick: about 20 fast inputs (under 2 minutes). The full pass writes
docs/robustness.md (about 10 minutes on 2 cores); --out DIR writes DIR/robustness.md
instead (the quick pass writes a file only with --out). Exit 0 when the pass ran (the
report is the result); with --strict, exit 1 when an answer is unclear.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
KNEE = ROOT / "fecheck" / "data" / "knee" / "lenhart2015"
TIBIA_BONE = KNEE / "lenhart2015_R_tibia_bone_proximal40.stl"
FEMUR_BONE = KNEE / "lenhart2015_R_femur_bone_distal60.stl"
MEMORY_CAP_BYTES = 4 << 30
"""Address-space cap of each input's process (a run that would take more fails there)."""
REFUSE_S, QUICK_S, SOLVE_S, HEAVY_S = 30, 60, 150, 240
"""Timeouts, s: a size that must be refused before any work, an input answered before any
solve, one that solves a decimated scanned knee, one that runs an FE or a study."""
DECIMATE = ["--set", "scanned.decimate_faces=1500"]
"""Cheap scanned knees: the tibial sheets decimated to 1500 faces."""
NAN = re.compile(r"(?<!no )(?<![\w.])nan(?![\w])", re.IGNORECASE)
"""A NaN printed as a value (not "no NaN" in a check's line)."""
WORK = "{work}"
"""Stands for the scratch folder in an input's arguments (absolute paths of its files)."""
ANSWER_CHARS = 160


@dataclass(frozen=True)
class Case:
    """One input: the fecheck arguments, what it tries, its timeout, whether the quick
    pass runs it, and the output files whose JSON must carry provenance."""

    args: tuple[str, ...]
    what: str
    timeout_s: float = QUICK_S
    quick: bool = False
    json_out: tuple[str, ...] = ()


@dataclass
class Answer:
    case: Case
    returncode: int | None
    stdout: str
    stderr: str
    seconds: float
    json_texts: dict[str, str] = field(default_factory=dict)

    @property
    def verb(self) -> str:
        """The verb the input gives, or "(top level)" (no verb, an option, a wrong one)."""
        first = self.case.args[0] if self.case.args else ""
        return first if first in verbs() else "(top level)"


def verbs() -> list[str]:
    """The verbs `fecheck --help` lists."""
    from fecheck.cli import build_parser

    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == "verb")
    return sorted(action.choices)


def c(args: str | list[str], what: str, timeout_s: float = QUICK_S, quick: bool = False,
      json_out: tuple[str, ...] = ()) -> Case:
    """A case from a command line (split on spaces) or an argument list."""
    return Case(tuple(args.split() if isinstance(args, str) else args), what, timeout_s,
                quick, json_out)


# ------------------------------------------------------------------ the bad files
def _write_stl(path: Path, points: np.ndarray, faces: np.ndarray) -> None:
    """A binary STL of a triangle mesh (normals from the winding)."""
    tri = points[faces].astype(np.float32)
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    records = np.zeros(len(faces), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                          ("a", "<u2")])
    records["n"], records["v"] = normals, tri
    with open(path, "wb") as fh:
        fh.write(b"\0" * 80 + struct.pack("<I", len(faces)))
        fh.write(records.tobytes())


def _read_stl(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(points (3n, 3), faces (n, 3)) of a binary STL (vertices not merged)."""
    raw = path.read_bytes()
    (n,) = struct.unpack("<I", raw[80:84])
    rec = np.frombuffer(raw[84:84 + 50 * n], dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)),
                                                    ("a", "<u2")])
    return rec["v"].reshape(-1, 3).astype(float), np.arange(3 * n).reshape(n, 3)


def _grid_sheet(n_faces: int, size_mm: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
    """A flat square sheet of about `n_faces` triangles at z = 0, normals up."""
    k = max(int(np.sqrt(n_faces / 2)), 1)
    x = np.linspace(-size_mm / 2, size_mm / 2, k + 1)
    xx, yy = np.meshgrid(x, x, indexing="ij")
    points = np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)])
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    v = (i * (k + 1) + j).ravel()
    faces = np.concatenate([np.column_stack([v, v + k + 1, v + 1]),
                            np.column_stack([v + 1, v + k + 1, v + k + 2])])
    return points, faces


def make_files(work: Path, full: bool) -> None:
    """The bad and edge files the inputs name, in `work`."""
    texts = {
        "empty.toml": "", "comments.toml": "# nothing but a comment\n",
        "bad.toml": "[contact\nyoungs_MPa = \n", "unknown.toml": "[contact]\nyoungs = 20.0\n",
        "wrong_type.toml": "[contact]\nyoungs_MPa = 'twenty'\n",
        "section_value.toml": "contact = 3\n", "nan.toml": "[contact]\npoisson = nan\n",
        "inf_load.toml": "[load]\nforce_N = inf\n", "dup.toml": "name = 'a'\nname = 'b'\n",
        "neg_thickness.toml": "[contact]\nthickness_mm = -6.0\n",
        "zero_direction.toml": "[load]\ndirection = [0.0, 0.0, 0.0]\n",
        "empty_dofs.toml": "[dofs]\nfree = []\n",
        "poly_no_coeffs.toml": "[plateau]\nkind = 'polynomial'\n",
        "custom_no_landmarks.toml": "[knee]\npreset = 'custom'\n",
        "scanned_missing.toml": "[model]\nkind = 'femur-tibia'\n[geometry]\n"
                                "femur = 'nowhere.stl'\ntibia = 'nowhere.stl'\n",
        "cal_text.json": "this is not JSON\n",
        "cal_medial.json": json.dumps({"compartments": {"medial": {"C": 5.0, "n": 0.6}}}),
        "cal_nan.json": json.dumps({"compartments": {"medial": {"C": float("nan"), "n": 0.6},
                                                     "lateral": {"C": 5.0, "n": 0.6}}}),
        "cal_negative.json": json.dumps({"compartments": {"medial": {"C": -5.0, "n": 0.6},
                                                          "lateral": {"C": 5.0, "n": 0.6}}}),
        "result_old.json": json.dumps({"scene": "baseline", "converged": True}),
        "result_list.json": "[1, 2, 3]\n", "not_json.json": "{broken",
        "text.stl": "hello, not a mesh\n", "empty.stl": "",
        "landmarks.toml": "[knee]\npreset = 'custom'\n[knee.landmarks.medial]\n"
                          "center = [1.0, 2.0]\n",
    }
    for name, text in texts.items():
        (work / name).write_text(text, encoding="utf-8")
    (work / "binary.toml").write_bytes(b"\x00\xff\xfe\x00binary")
    (work / "latin1.toml").write_bytes("name = 'genou é'\n".encode("latin-1"))
    (work / "bom.toml").write_bytes("name = 'bom'\n".encode("utf-8-sig"))
    (work / "folder.toml").mkdir(exist_ok=True)
    (work / "folder.stl").mkdir(exist_ok=True)
    (work / "out_dir").mkdir(exist_ok=True)
    _write_stl(work / "one_triangle.stl", np.array([[0.0, 0, 0], [10, 0, 0], [0, 10, 0]]),
               np.array([[0, 1, 2]]))
    femur = KNEE / "lenhart2015_R_femur_cartilage.stl"
    tibia = KNEE / "lenhart2015_R_tibia_cartilage_medial.stl"
    lateral = KNEE / "lenhart2015_R_tibia_cartilage_lateral.stl"
    for name, src in (("femur.stl", femur), ("tibia_medial.stl", tibia),
                      ("tibia_lateral.stl", lateral)):
        shutil.copyfile(src, work / name)
    pts, faces = _read_stl(tibia)
    _write_stl(work / "tibia_metres.stl", pts * 1e-3, faces)
    _write_stl(work / "tibia_flipped.stl", pts, faces[:, ::-1])
    bad = pts.copy()
    bad[5] = np.nan
    _write_stl(work / "tibia_nan.stl", bad, faces)
    flat = pts.copy()
    flat[faces[:20, 1]] = flat[faces[:20, 0]]
    _write_stl(work / "tibia_degenerate.stl", flat, faces)
    _write_stl(work / "tibia_far.stl", pts + np.array([0.0, 0.0, 500.0]), faces)
    sheet = _grid_sheet(2_000_000 if full else 2_000)
    _write_stl(work / "huge_sheet.stl", *sheet)


# ------------------------------------------------------------------------- cases
def _bounds_cases() -> list[Case]:
    """Out-of-range, non-finite and mistyped values of scene keys, each by --set."""
    values = [("contact.poisson", "0.5"), ("contact.poisson", "-1.5"),
              ("contact.youngs_MPa", "0"), ("contact.youngs_MPa", "-20"),
              ("contact.youngs_MPa", "nan"), ("contact.youngs_MPa", "inf"),
              ("contact.youngs_MPa", "'twenty'"), ("contact.thickness_mm", "0"),
              ("contact.thickness_mm", "1e9"), ("load.force_N", "-800"),
              ("load.force_N", "1e12"), ("load.force_N", "nan"), ("load.direction", "[0,0]"),
              ("load.direction", "[0,0,0]"), ("load.direction", "[nan,0,1]"),
              ("dofs.free", "[]"), ("dofs.free", "['w']"), ("dofs.flexion_deg", "400"),
              ("dofs.flexion_deg", "-90"), ("contact.law", "magic"),
              ("contact.area", "none"), ("model.kind", "spring"), ("knee.preset", "fit"),
              ("knee.side", "middle"), ("mesh.sphere_subdivisions", "40"),
              ("mesh.sphere_subdivisions", "-1"), ("mesh.sphere_subdivisions", "2.5"),
              ("solver.max_iterations", "0"), ("contact.margin_mm", "-1"),
              ("gravity", "maybe"), ("name", "[1,2]"), ("contact", "3"),
              ("nokey", "1"), ("contact.youngs", "20")]
    return [c(["run", "baseline", "--set", f"{k}={v}"], f"--set {k}={v}", quick=i < 2)
            for i, (k, v) in enumerate(values)]


def _run_cases() -> list[Case]:
    out = [
        c("run", "no scene: the packaged baseline", SOLVE_S, quick=True, json_out=()),
        c("run baseline --json r_base.json", "baseline with JSON", SOLVE_S, quick=True,
          json_out=("r_base.json",)),
        c("run rigid --json -", "JSON to stdout", quick=True),
        c("run rigid --json - --csv -", "two outputs to stdout"),
        c("run nosuchscene", "unknown scene name", quick=True),
        c("run nosuch.toml", "missing scene file", quick=True),
        c("run folder.toml", "a directory as the scene", quick=True),
        c("run empty.toml", "empty scene file", quick=True),
        c("run comments.toml", "scene of comments only"),
        c("run binary.toml", "binary scene file", quick=True),
        c("run bad.toml", "malformed TOML"),
        c("run unknown.toml", "unknown key in a file"),
        c("run wrong_type.toml", "string where a number belongs"),
        c("run section_value.toml", "a section given a value"),
        c("run nan.toml", "NaN in a file"),
        c("run inf_load.toml", "infinite load in a file"),
        c("run dup.toml", "a key twice"),
        c("run neg_thickness.toml", "negative thickness"),
        c("run zero_direction.toml", "zero load direction"),
        c("run empty_dofs.toml", "no free DOF"),
        c("run poly_no_coeffs.toml", "polynomial plateau without coefficients"),
        c("run custom_no_landmarks.toml", "custom knee without landmarks"),
        c("run landmarks.toml", "landmark with two coordinates"),
        c("run scanned_missing.toml", "mesh files that do not exist"),
        c("run latin1.toml", "a scene not in UTF-8"),
        c("run bom.toml --json r_bom.json", "a scene with a byte-order mark", SOLVE_S,
          json_out=("r_bom.json",)),
        c("run baseline --set", "--set without a value"),
        c("run baseline --set contact.poisson", "--set without '='"),
        c("run baseline --set =3", "--set without a key"),
        c("run baseline --json", "--json without a path"),
        c("run baseline --json out_dir", "a directory as the JSON path"),
        c("run baseline --json /proc/nope/r.json", "an unwritable JSON path"),
        c("run baseline --plot r_base.json", "a file as the plot folder"),
        c("run rigid --plot plots", "pressure map of the rigid model"),
        c("run baseline --explain", "the plan and its audit", SOLVE_S),
        c("run baseline --from r_base.json", "--from with a scene beside it"),
        c("run --from result_old.json", "--from a JSON without provenance", quick=True),
        c("run --from result_list.json", "--from a JSON list"),
        c("run --from not_json.json", "--from broken JSON"),
        c("run --from nowhere.json", "--from a missing file"),
        c("run --from r_changed.json", "--from a run whose femur file changed since"),
        c("run --from r_modified.json --json r_from.json", "--from a modified run",
          SOLVE_S, json_out=("r_from.json",)),
        c(["run", "scanned-knee", *DECIMATE, "--json", "r_scan.json"],
          "decimated scanned knee", SOLVE_S, json_out=("r_scan.json",)),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.poisson=0.4999"],
          "nearly incompressible EF layer (issue list)", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "scanned.decimate_faces=3"],
          "decimated to 3 faces", SOLVE_S),
        c(["run", "scanned-knee", "--set", "geometry.femur=tibia_metres.stl",
           "--set", f"geometry.dir='{KNEE}'"], "femur file missing in geometry.dir", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "geometry.units='m'"],
          "millimetre meshes read as metres", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "load.force_N=1e6"],
          "a 1 MN load on the scanned knee", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "load.force_N=0"],
          "no load on the scanned knee", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "geometry.translation_mm=[0,0,50]"],
          "femur 50 mm away", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.law='ef-calibrated'",
           "--set", f"contact.calibration='{WORK}/cal_medial.json'"],
          "calibration without the lateral compartment (issue list)", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.law='ef-calibrated'",
           "--set", f"contact.calibration='{WORK}/cal_text.json'"], "calibration not JSON",
          SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.law='ef-calibrated'",
           "--set", f"contact.calibration='{WORK}/cal_nan.json'"], "calibration with NaN", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.law='ef-calibrated'",
           "--set", f"contact.calibration='{WORK}/cal_negative.json'"],
          "calibration with a negative C", SOLVE_S),
        c(["run", "scanned-knee", *DECIMATE, "--set", "contact.law='ef-calibrated'"],
          "calibrated law without a file", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set",
           "menisci.dir='fecheck:knee/lenhart2015'"],
          "menisci.dir naming the knee's folder (issue list)", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "menisci.dir='nowhere'"],
          "menisci.dir that does not exist", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "menisci.youngs_MPa=1e-9"],
          "a meniscus of 1e-9 MPa (issue list)", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "menisci.free=[]"],
          "menisci.free = [] (issue list)", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "load.force_N=1e9"],
          "1e9 N on the menisci scene (issue list)", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "menisci.sides=['medial',"
           "'medial']"], "one meniscus side twice", SOLVE_S),
        c(["run", "femur_tibia_menisci", *DECIMATE, "--set", "contact.law='hertz'"],
          "menisci with the Hertz law", SOLVE_S),
        c(["run", "sphere_tibia", *DECIMATE], "condyle spheres on the scanned tibia", SOLVE_S),
        c(["run", "femur_tibia_ligaments", *DECIMATE], "scanned knee with its bundles",
          SOLVE_S),
    ]
    for name in ("hertz", "volumetric", "springs", "ligaments", "equal_force", "polynomial",
                 "inclined", "rigid_ligaments", "additional_left"):
        out.append(c(["run", name], f"packaged scene {name}", SOLVE_S))
    return out


def _fe_cases() -> list[Case]:
    solid = ["--set", f"geometry.tibia_solid='{TIBIA_BONE}'"]
    return [
        c(["fe", "scanned-knee", *DECIMATE, "--no-estimate", "--json", "fe.json"],
          "FE of a decimated scanned knee", HEAVY_S, json_out=("fe.json",)),
        c("fe baseline --hold-rotation", "an option the FE does not have (issue list)",
          quick=True),
        c("fe rigid", "FE of the rigid model"),
        c("fe baseline --refine -1", "negative refinement"),
        c("fe baseline --mode sideways", "unknown FE mode"),
        c("fe nosuch.toml", "missing scene file"),
        c("fe baseline --json out_dir", "a directory as the JSON path"),
        c(["fe", "scanned-knee", *DECIMATE, "--set", "fe.size_mm=0.01"],
          "an FE mesh far too fine", HEAVY_S),
        c(["fe", "scanned-knee", *DECIMATE, "--set", "geometry.tibia=''",
           "--set", "geometry.tibia_lateral=''", *solid],
          "a decimated knee's tibial solid without a sheet", HEAVY_S),
        c(["fe", "scanned-knee", "--set", "geometry.tibia=''", "--set",
           "geometry.tibia_lateral=''", *solid],
          "a tibial solid without a sheet (issue list)", HEAVY_S),
        c(["fe", "femur_tibia_menisci", *DECIMATE, "--set", "menisci.youngs_MPa=1e6"],
          "a stiff meniscus in the FE (issue list)", HEAVY_S),
        c(["fe", "scanned-knee", *DECIMATE, "--set", "fe.size_mm=-1"], "negative FE size"),
    ]


def _flex_cases() -> list[Case]:
    ft = ["flex", "femur_tibia_ligaments", *DECIMATE]
    return [
        c([*ft, "--angles", "0:160:1e-7"], "ten thousand million angles (issue list)",
          REFUSE_S, quick=True),
        c([*ft, "--angles", "0:inf:10"], "an infinite angle (issue list)", quick=True),
        c([*ft, "--angles", "-10:0:5"], "a negative angle read as an option (issue list)"),
        c([*ft, "--angles=-10:0:5"], "a negative angle with '='", HEAVY_S),
        c([*ft, "--angles", "0:10:0"], "zero step"),
        c([*ft, "--angles", "10:0:5"], "descending range"),
        c([*ft, "--angles", "a:b:c"], "angles not numbers"),
        c([*ft, "--angles", "0:10"], "two fields"),
        c([*ft, "--angles", "nan:10:5"], "NaN angle"),
        c([*ft, "--angles", "0:10:5", "--axis-point", "nan,0,0", "--axis-dir", "1,0,0"],
          "NaN in --axis-point (issue list)", HEAVY_S),
        c([*ft, "--angles", "0:10:5", "--axis-point", "-0.48,0,0"],
          "a negative --axis-point read as an option (issue list)"),
        c([*ft, "--angles", "0:10:5", "--axis-point", "1,2"], "axis point of two numbers"),
        c([*ft, "--angles", "0:10:5", "--axis-dir", "0,0,0"], "zero axis direction",
          HEAVY_S),
        c([*ft, "--angles", "0:10:5", "--fe-at", "90"], "FE at an angle outside the range"),
        c([*ft, "--angles", "0:10:5", "--json", "-", "--csv", "-"], "two outputs to stdout"),
        c(["flex", "rigid", "--angles", "0:10:5"], "flexion of the rigid model"),
        c(["flex", "scanned-knee", *DECIMATE, "--angles", "0:10:10", "--json", "flex.json"],
          "two angles of the scanned knee", HEAVY_S, json_out=("flex.json",)),
    ]


def _sweep_cases() -> list[Case]:
    return [
        c("sweep baseline --param contact.youngs_MPa --values 10:20:100000000",
          "a hundred million points (issue list)", REFUSE_S, quick=True),
        c("sweep rigid --param contact.youngs_MPa --values 10:20:3 --csv sweep.csv",
          "three points of the rigid model"),
        c("sweep baseline --param contact.youngs_MPa --values 10:20:0", "zero points"),
        c("sweep baseline --param contact.youngs_MPa --values -10:20:3",
          "a negative start read as an option"),
        c("sweep baseline --param contact.youngs_MPa --values=-10:20:3",
          "negative modulus values"),
        c("sweep baseline --param contact.law --values 1:2:2", "sweep a string key"),
        c("sweep baseline --param nokey --values 1:2:2", "sweep an unknown key"),
        c("sweep baseline --param load.point_mm[7] --values 1:2:2", "index out of range"),
        c("sweep baseline --param contact.youngs_MPa --values 1:nan:3", "NaN bound"),
        c("sweep baseline --param contact.youngs_MPa --values 10:20:3 --workers 0",
          "zero workers"),
        c("sweep baseline --param contact.youngs_MPa --values 10:20:3 --workers -2",
          "negative workers"),
        c("sweep baseline --param contact.youngs_MPa --values 10:20:3 --scheduler nohost:1",
          "a scheduler that is not there", SOLVE_S),
        c("sweep baseline --param contact.poisson --values 0.3:0.6:4 --csv sweep2.csv",
          "a sweep into the out-of-range Poisson's ratio", SOLVE_S),
        c("sweep baseline --param contact.youngs_MPa", "no --values"),
    ]


def _knee_cases() -> list[Case]:
    imp = ["knee", "import"]
    return [
        c([*imp, "--femur", "tibia_medial.stl", "--tibia", "femur.stl", "-o", "swap.toml"],
          "femur and tibia files swapped, one tibia file", SOLVE_S),
        c([*imp, "--femur", "tibia_medial.stl", "--tibia", "femur.stl", "--split", "sagittal",
           "-o", "swap2.toml"], "femur and tibia files swapped (issue list)", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "--tibia-lateral",
           "tibia_lateral.stl", "-o", "own.toml"], "the packaged knee's files", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "--tibia-lateral",
           "tibia_lateral.stl", "--femur-bone", str(TIBIA_BONE), "--tibia-bone",
           str(FEMUR_BONE), "-o",
           "bones_swapped.toml"], "femoral and tibial bones swapped (issue list)", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "huge_sheet.stl", "--split", "sagittal",
           "-o", "huge.toml"], "a 2-million-face tibial sheet (issue list)", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "empty.stl", "-o", "e.toml"],
          "an empty tibia file", quick=True),
        c([*imp, "--femur", "femur.stl", "--tibia", "text.stl", "-o", "t.toml"],
          "a text file as a mesh"),
        c([*imp, "--femur", "femur.stl", "--tibia", "folder.stl", "-o", "d.toml"],
          "a directory as a mesh file (issue list)"),
        c([*imp, "--femur", "femur.stl", "--tibia", "nowhere.stl", "-o", "n.toml"],
          "a missing mesh file"),
        c([*imp, "--femur", "femur.stl", "--tibia", "one_triangle.stl", "-o", "o.toml"],
          "a one-triangle tibia"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_metres.stl", "-o", "m.toml"],
          "a tibia in metres, read as mm"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_flipped.stl", "--tibia-lateral",
           "tibia_lateral.stl", "-o", "f.toml"], "a tibia with its normals down", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_nan.stl", "-o", "nan.toml"],
          "a NaN vertex"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_degenerate.stl",
           "--tibia-lateral", "tibia_lateral.stl", "-o", "deg.toml"],
          "zero-area faces", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_far.stl", "--tibia-lateral",
           "tibia_lateral.stl", "-o", "far.toml"], "a tibia 500 mm away", SOLVE_S),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "-o", "x.toml",
           "--load-N", "-5"], "a negative load"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "-o", "x.toml",
           "--load-N", "nan"], "a NaN load"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "-o", "out_dir"],
          "a directory as the scene to write"),
        c([*imp, "--femur", "femur.stl", "-o", "x.toml"], "no tibia"),
        c([*imp, "--femur", "femur.stl", "--tibia", "tibia_medial.stl", "--split-x", "inf",
           "-o", "x.toml"], "an infinite split plane"),
        c("knee", "the knee verb without an action", quick=True),
    ]


def _mesh_cases() -> list[Case]:
    return [
        c("mesh info femur.stl --json info.json", "info of a surface",
          json_out=("info.json",), quick=True),
        c("mesh info empty.stl", "info of an empty file"),
        c("mesh info text.stl", "info of a text file"),
        c("mesh info folder.stl", "info of a directory"),
        c("mesh info nowhere.stl", "info of a missing file"),
        c("mesh info one_triangle.stl tibia_nan.stl", "info of a NaN vertex"),
        c("mesh icosphere --radius 10 --subdivisions 2 -o ico.stl", "a small icosphere"),
        c("mesh icosphere --radius -10 --subdivisions 2 -o ico2.stl", "negative radius"),
        c("mesh icosphere --radius 10 --subdivisions 30 -o ico3.stl", "30 subdivisions"),
        c("mesh icosphere --radius nan --subdivisions 2 -o ico4.stl", "NaN radius"),
        c("mesh icosphere --radius 10 --subdivisions 2 -o ico.xyz", "unknown format"),
        c("mesh plateau --size 0 -o p.stl", "zero element size"),
        c("mesh plateau --kind polynomial --coeffs [[1,2] -o p.stl", "broken coefficients"),
        c("mesh layer --thickness -1 -o l.vtu", "negative layer thickness"),
        c("mesh layer --size 1e-4 -o l2.vtu", "a layer of tiny elements"),
        c("mesh", "the mesh verb without a kind"),
    ]


def _population_cases() -> list[Case]:
    pop = ["population", "baseline"]
    atl = ["atlas", "baseline"]
    return [
        c([*pop, "--vary", "nokey=uniform:1:2", "--samples", "64"], "vary an unknown key",
          quick=True),
        c([*pop, "--vary", "contact.poisson=uniform:0.3:0.7", "--samples", "64"],
          "a distribution outside the key's range"),
        c([*pop, "--vary", "contact.youngs_MPa=uniform:10:30", "--samples", "3"],
          "too few samples for the indices"),
        c([*pop, "--vary", "contact.youngs_MPa=normal:20:-1", "--samples", "64"],
          "a negative standard deviation"),
        c([*pop, "--vary", "contact.youngs_MPa=uniform:30:10", "--samples", "64"],
          "a reversed range"),
        c([*pop, "--vary", "contact.youngs_MPa=beta:1:2", "--samples", "64"],
          "an unknown distribution"),
        c([*pop, "--vary", "contact.youngs_MPa=uniform:nan:30", "--samples", "64"],
          "NaN bound"),
        c([*pop, "--vary", "mesh.plateau_size_mm=uniform:1.5:2.5", "--samples", "64"],
          "a key that rebuilds meshes at every sample"),
        c([*pop, "--vary", "contact.youngs_MPa=uniform:10:30", "--samples", "-5"],
          "a negative sample count"),
        c([*pop, "--vary", "contact.youngs_MPa=uniform:10:30", "--samples", "32",
           "--json", "pop.json"], "a small population of the baseline", SOLVE_S,
          json_out=("pop.json",)),
        c([*atl, "--vary", "nokey=uniform:1:2", "--fe", "4"], "atlas of an unknown key"),
        c([*atl, "--vary", "contact.youngs_MPa=uniform:10:30", "--fe", "0"],
          "atlas with no FE design point"),
        c([*atl, "--vary", "contact.youngs_MPa=uniform:10:30", "--fe", "4",
           "--tolerance", "-0.1"], "a negative tolerance"),
    ]


def _other_cases() -> list[Case]:
    cal = ["calibrate", "scanned-knee", *DECIMATE]
    return [
        c("", "no verb at all", quick=True),
        c("--version", "version"),
        c("nosuchverb", "unknown verb", quick=True),
        c("scenes", "scene list", quick=True),
        c("scenes --paths", "scene paths"),
        c("keys", "every key"),
        c("keys nosuchprefix", "keys of an unknown prefix", quick=True),
        c("keys contact --format yaml", "unknown format"),
        c("keys --format markdown", "keys as Markdown"),
        c([*cal, "-o", "cal.json", "--loads", "0"], "calibrate at zero load"),
        c([*cal, "-o", "cal.json", "--loads", "-1"], "calibrate at a negative load"),
        c([*cal, "-o", "cal.json", "--loads", "nan"], "calibrate at a NaN load"),
        c([*cal, "-o", "out_dir"], "calibration written over a directory"),
        c("calibrate rigid -o cal.json", "calibrate the rigid model"),
        c([*cal, "-o", "cal_ok.json"], "calibrate a decimated scanned knee", HEAVY_S,
          json_out=("cal_ok.json",)),
        c("stress --only nosuchcase", "stress with no matching case"),
        c("stress --timeout -1", "negative stress timeout"),
        c("stress --quick --only poisson --json stress.json", "a few stress cases",
          HEAVY_S, json_out=("stress.json",)),
        c("verify --list", "list the verification cases", quick=True),
        c("verify --only nosuchcase", "verify with no matching case"),
        c("verify --scene baseline", "verify a scene without --out"),
        c("verify --quick --only patch --json verify.json", "a verification case",
          HEAVY_S, json_out=("verify.json",)),
        c("verify --scene-levels 0 --scene baseline --out vout", "zero scene levels"),
        c("bench nosuchsuite", "unknown bench suite"),
        c("bench --json out_dir", "bench JSON over a directory"),
        c("validate --list", "list the validation rows"),
        c("validate --only nosuchrow", "an unknown validation row"),
        c("validate --dir nowhere --list", "validation rows from a missing folder"),
    ]


def all_cases() -> list[Case]:
    """Every input of the pass, in report order."""
    return (_run_cases() + _bounds_cases() + _fe_cases() + _flex_cases() + _sweep_cases()
            + _knee_cases() + _mesh_cases() + _population_cases() + _other_cases())


# ----------------------------------------------------------------------- running
def _limit_memory() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP_BYTES, MEMORY_CAP_BYTES))


def run_case(case: Case, work: Path) -> Answer:
    """Run one input in `work`; kill its process group at the timeout."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", MPLBACKEND="Agg",
               VTK_DEFAULT_OPENGL_WINDOW="vtkEGLRenderWindow")
    for name in case.json_out:
        (work / name).unlink(missing_ok=True)
    args = [a.replace(WORK, str(work)) for a in case.args]
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "fecheck", *args], cwd=work, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            errors="replace", start_new_session=True,
                            preexec_fn=_limit_memory)
    try:
        out, err = proc.communicate(timeout=case.timeout_s)
        code: int | None = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        code = None
    texts = {n: (work / n).read_text(errors="replace") for n in case.json_out
             if (work / n).is_file()}
    return Answer(case, code, out.replace(str(work), WORK), err.replace(str(work), WORK),
                  time.perf_counter() - t0, texts)


def _error_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if "error:" in line]


def _json_problem(answer: Answer) -> str | None:
    """Why a written JSON is unclear (missing, NaN, no provenance), or None."""
    for name in answer.case.json_out:
        text = answer.json_texts.get(name)
        if text is None:
            return f"{name} not written"
        if NAN.search(text):
            return f"NaN in {name}"
        data = json.loads(text)
        rows = data if isinstance(data, list) else [data]
        if not all(isinstance(r, dict) and "provenance" in r for r in rows):
            return f"{name} carries no provenance"
    return None


def verdict(answer: Answer) -> tuple[bool, str]:
    """(clean, why) of an answer (module docstring)."""
    if answer.returncode is None:
        return False, f"no answer within {answer.case.timeout_s:g} s"
    if "Traceback" in answer.stderr:
        return False, "traceback"
    if answer.returncode == 0:
        if not (answer.stdout.strip() or answer.stderr.strip() or answer.json_texts):
            return False, "exit 0 in silence"
        if NAN.search(answer.stdout) or NAN.search(answer.stderr):
            return False, "NaN in the output"
        problem = _json_problem(answer)
        return (False, problem) if problem else (True, "result")
    if answer.returncode == 2:
        lines = _error_lines(answer.stderr)
        if len(lines) == 1:
            return True, "one-line error"
        return False, "no error line" if not lines else f"{len(lines)} error lines"
    if answer.returncode < 0:
        return False, f"killed by signal {-answer.returncode}"
    return False, f"exit {answer.returncode}"


def first_line(answer: Answer) -> str:
    """The line that answers: the error line, else the last line on stderr of a failure,
    else the first line of the output."""
    lines = _error_lines(answer.stderr)
    if lines:
        text = lines[0]
    elif answer.returncode not in (0, None) and answer.stderr.strip():
        text = answer.stderr.strip().splitlines()[-1]
    elif answer.stdout.strip():
        text = answer.stdout.strip().splitlines()[0]
    else:
        text = (answer.stderr.strip().splitlines() or ["(nothing)"])[-1]
    text = " ".join(text.split())
    return text if len(text) <= ANSWER_CHARS else text[:ANSWER_CHARS - 1] + "…"


def _cell(text: str) -> str:
    """`text` for a table cell: pipes escaped, the repository's path shortened."""
    return (text.replace(str(ROOT), "<repo>").replace(WORK, "<scratch>")
            .replace("|", "\\|").replace("`", "'"))


def report(answers: list[Answer], quick: bool, seconds: float) -> str:
    """The Markdown report (module docstring)."""
    clean = [a for a in answers if verdict(a)[0]]
    given = sorted({a.verb for a in answers} - {"(top level)"})
    missing = sorted(set(verbs()) - set(given))
    lines = [
        "# Robustness: bad and edge inputs",
        "",
        f"Written by `python validation/robustness.py{' --quick' if quick else ''}`: "
        f"{len(answers)} inputs across the verbs {', '.join(given)} and the top level "
        f"(verbs without an input: {', '.join(missing) or 'none'}), each run as "
        "`python -m fecheck ...` in its own process from a scratch folder, with a timeout "
        f"and an address space capped at {MEMORY_CAP_BYTES >> 30} GB; "
        f"{seconds / 60:.1f} minutes in all.",
        "",
        f"**{len(clean)} of {len(answers)} answers are clean.**",
        "",
        "Clean: exit 0 with a result (output without NaN; every JSON written carries its "
        "provenance), or exit 2 with one error line and no traceback. Unclear: anything "
        "else: a traceback, exit 1, a signal (such as the memory cap), no answer within "
        "the timeout, NaN in the output, an error over more than one line, a JSON "
        "without provenance. A verdict judges the form of the answer, not its numbers: "
        "a result that is wrong but well formed counts as clean. The scenes are cheap: "
        "scanned knees decimated to 1500 tibial faces (`--set "
        "scanned.decimate_faces=1500`).",
        "",
        "| # | input | what it tries | exit | s | answer (first line) | verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for i, a in enumerate(answers, 1):
        ok, why = verdict(a)
        code = "timeout" if a.returncode is None else str(a.returncode)
        lines.append(f"| {i} | `{_cell(' '.join(['fecheck', *a.case.args]))}` | "
                     f"{_cell(a.case.what)} | {code} | {a.seconds:.1f} | "
                     f"{_cell(first_line(a))} | {'clean' if ok else 'UNCLEAR: ' + why} |")
    unclear = [a for a in answers if not verdict(a)[0]]
    if unclear:
        lines += ["", "## Unclear answers", ""]
        lines += [f"- `{_cell(' '.join(['fecheck', *a.case.args]))}`: {verdict(a)[1]}"
                  for a in unclear]
    return "\n".join(lines) + "\n"


def _prepare_from(work: Path) -> None:
    """The result files that ``run --from`` replays: a modified baseline, and a scanned
    knee read from a copy of its files whose femur then changes by one byte."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OPENBLAS_NUM_THREADS="1")
    shutil.copytree(KNEE, work / "knee")
    for args in (["baseline", "--set", "contact.poisson=0.35", "--json", "r_modified.json"],
                 ["scanned-knee", *DECIMATE, "--set", f"geometry.dir='{work / 'knee'}'",
                  "--json", "r_changed.json"]):
        subprocess.run([sys.executable, "-m", "fecheck", "run", *args], cwd=work, env=env,
                       capture_output=True, timeout=SOLVE_S, check=False)
    femur = work / "knee" / "lenhart2015_R_femur_cartilage.stl"
    femur.write_bytes(femur.read_bytes() + b"\n")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description="Bad and edge inputs to every fecheck verb; "
                                "writes a Markdown table of the answers.")
    p.add_argument("--quick", action="store_true", help="about 20 fast inputs")
    p.add_argument("--out", type=Path, metavar="DIR",
                   help="write DIR/robustness.md (default: docs/robustness.md for the full "
                        "pass, no file for --quick)")
    p.add_argument("--workers", type=int, default=2, help="inputs run at once (default 2)")
    p.add_argument("--strict", action="store_true", help="exit 1 when an answer is unclear")
    args = p.parse_args(argv)
    cases = [k for k in all_cases() if k.quick or not args.quick]
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="fecheck-robustness-") as tmp:
        work = Path(tmp)
        make_files(work, full=not args.quick)
        if not args.quick:
            _prepare_from(work)
        with ThreadPoolExecutor(max(args.workers, 1)) as pool:
            answers = list(pool.map(lambda k: run_case(k, work), cases))
    seconds = time.perf_counter() - t0
    for a in answers:
        ok, why = verdict(a)
        print(f"{'clean  ' if ok else 'UNCLEAR'} {' '.join(a.case.args)[:70]:70s} {why}")
    clean = sum(verdict(a)[0] for a in answers)
    print(f"{clean} of {len(answers)} answers clean ({seconds:.0f} s)")
    target = (args.out / "robustness.md" if args.out is not None
              else None if args.quick else ROOT / "docs" / "robustness.md")
    if target is not None:
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(report(answers, args.quick, seconds), encoding="utf-8")
        print(f"wrote {target}")
    return 1 if args.strict and clean < len(answers) else 0


if __name__ == "__main__":
    sys.exit(main())
