"""Results of one scene run: plain dataclasses, their JSON/CSV rows and a printed table.

Units: forces N, pressures MPa, areas mm², depths mm, torques N·mm (about the tibial
origin), pose in mm and degrees, times in s. Ligament force is + in tension.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from geometry.files import write_output

POSE_KEYS = ("x_mm", "y_mm", "z_mm", "abduction_deg", "internal_deg", "adduction_deg",
             "internal_rotation_deg")
LEGACY_TIMING = ("per_evaluation", "per_evaluation_us")
"""Timing keys kept for older readers beside ``per_evaluation_s`` (same time, s and µs)."""

POSE_SIGNS = {
    "adduction_deg": "+ adduction (varus): the distal tibia moves medially; - abduction "
                     "(valgus)",
    "internal_rotation_deg": "+ internal rotation: the tibia's anterior turns medially; - "
                             "external",
    "abduction_deg": "old name: θy of R = Rx·Ry·Rz, + moves the distal tibia toward -x "
                     "(adduction in a right knee, abduction in a left one); read "
                     "adduction_deg",
    "internal_deg": "θz of R = Rx·Ry·Rz, + turns the anterior toward -x (internal in a "
                    "right knee); read internal_rotation_deg",
}
"""The sense of each secondary rotation of the pose, as stated in the reports."""


def anatomical_sign(side: str) -> float:
    """+1 for a right knee (medial at -x), -1 for a left one: the factor that turns θy and
    θz into adduction and internal rotation.

    >>> anatomical_sign("left")
    -1.0
    """
    return 1.0 if side == "right" else -1.0


@dataclass(frozen=True, eq=False)
class Pose(Mapping[str, float]):
    """The solved pose of one body relative to the fixed femur.

    q : (x, y, z mm, θy abduction rad, θz internal rad), the generalized coordinates of
        `fecheck.statics.newton.pose`; flexion θx (rad) is set by the scene, not solved
    body : the body's name ("tibia": the only moving body of today's models)
    side : "right" or "left": the knee's side, which sets the anatomical sense of θy and θz
        (`POSE_SIGNS`): adduction_deg = ±θy and internal_rotation_deg = ±θz, + for a right
        knee (medial at -x), - for a left one

    As a mapping it reads the reported values (`POSE_KEYS`: x_mm … internal_deg), so that
    ``result.pose["z_mm"]`` and ``dict(result.pose)`` give the report's pose.
    """

    q: tuple[float, ...]
    flexion_rad: float = 0.0
    body: str = "tibia"
    side: str = "right"

    @classmethod
    def of(cls, q: Any, flexion_rad: float = 0.0, body: str = "tibia",
           side: str = "right") -> Pose:
        """The pose of generalized coordinates `q` (5,) (mm, rad) of a `side` knee."""
        return cls(tuple(float(v) for v in q), float(flexion_rad), body, side)

    @property
    def x_mm(self) -> float:
        return self.q[0]

    @property
    def y_mm(self) -> float:
        return self.q[1]

    @property
    def z_mm(self) -> float:
        return self.q[2]

    @property
    def abduction_rad(self) -> float:
        return self.q[3]

    @property
    def internal_rad(self) -> float:
        return self.q[4]

    @property
    def abduction_deg(self) -> float:
        return math.degrees(self.q[3])

    @property
    def internal_deg(self) -> float:
        return math.degrees(self.q[4])

    @property
    def adduction_deg(self) -> float:
        """Adduction (varus) +, abduction -, deg: θy for a right knee, -θy for a left."""
        return anatomical_sign(self.side) * math.degrees(self.q[3])

    @property
    def internal_rotation_deg(self) -> float:
        """Internal rotation +, external -, deg: θz for a right knee, -θz for a left."""
        return anatomical_sign(self.side) * math.degrees(self.q[4])

    @property
    def flexion_deg(self) -> float:
        return math.degrees(self.flexion_rad)

    def __getitem__(self, key: str) -> float:
        if key not in POSE_KEYS:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(POSE_KEYS)

    def __len__(self) -> int:
        return len(POSE_KEYS)


@dataclass(frozen=True)
class CompartmentResult:
    """Contact metrics of one compartment (NaN where the model has no such quantity,
    e.g. pressures of the rigid point-contact model).

    face_pressure_MPa : (n_slave_faces,) mean pressure on every slave face (0 off contact)
    slave_points, slave_faces : the slave mesh in world coordinates at equilibrium (plots)
    torque_vector_Nmm : (3,) moment of the compartment's contact force on the tibia about
        the tibial origin, world axes; `torque_Nmm` is its norm
    face_area_mm2 : (n_slave_faces,) in-contact area of every slave face (the face clipped
        at zero depth, as the law integrates it; 0 off contact), so that
        Σ face_pressure_MPa · face_area_mm2 is the compartment's normal force (None for
        point contacts)
    face_depth_mm : (n_slave_faces,) mean depth over that area, mm (None for point contacts)
    force_vector_N : (3,) the compartment's contact force on the tibia, world axes;
        `force_N` is its magnitude and `axial_force_N` its component along the tibia's
        long axis (the tibial z axis at equilibrium; + compressive, i.e. pressing the
        tibia down its axis)
    tibial_compression_mm, femoral_compression_mm : the deepest compression of each
        cartilage layer (face-mean depth split by the layers' compliances in series,
        `fecheck.model.sides`), mm; None where the scene does not set the layers apart
    """

    force_N: float
    max_pressure_MPa: float
    mean_pressure_MPa: float
    area_mm2: float
    max_depth_mm: float
    torque_Nmm: float
    torque_vector_Nmm: np.ndarray
    n_contact_faces: int = 0
    face_pressure_MPa: np.ndarray | None = None
    slave_points: np.ndarray | None = None
    slave_faces: np.ndarray | None = None
    face_area_mm2: np.ndarray | None = None
    face_depth_mm: np.ndarray | None = None
    force_vector_N: np.ndarray | None = None
    axial_force_N: float = math.nan
    tibial_compression_mm: float | None = None
    femoral_compression_mm: float | None = None

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready metrics (no per-face arrays; the layers' compressions where set)."""
        vector = (None if self.force_vector_N is None
                  else [_num(v) for v in self.force_vector_N])
        sides = ({} if self.tibial_compression_mm is None else
                 {"tibial_compression_mm": _num(self.tibial_compression_mm),
                  "femoral_compression_mm": _num(self.femoral_compression_mm)})
        return {"force_N": _num(self.force_N), "force_vector_N": vector,
                "axial_force_N": _num(self.axial_force_N),
                "max_pressure_MPa": _num(self.max_pressure_MPa),
                "mean_pressure_MPa": _num(self.mean_pressure_MPa),
                "area_mm2": _num(self.area_mm2), "max_depth_mm": _num(self.max_depth_mm),
                "torque_Nmm": _num(self.torque_Nmm),
                "torque_vector_Nmm": [_num(v) for v in self.torque_vector_Nmm],
                "n_contact_faces": int(self.n_contact_faces)} | sides


@dataclass(frozen=True)
class LigamentResult:
    """One ligament: force (N, + tension) and length (mm) at equilibrium."""

    force_N: float
    length_mm: float

    def as_dict(self) -> dict[str, Any]:
        return {"force_N": _num(self.force_N), "length_mm": _num(self.length_mm)}


@dataclass(frozen=True)
class SolveRecord:
    """What the Newton solve of a contact model did.

    evaluations : contact-and-tangent evaluations of every compartment
    contact_faces : {compartment: slave faces of its contact pair}
    detection : {compartment: how its contact is detected (one line)}
    residual_history : residual norm (N) of every iteration
    equal_forces_multiplier : the equal-force constraint's multiplier (N), None without it
    wrench_N : {"contact"|"ligaments"|"load_and_gravity": (6,) wrench on the tibia, N and
        N·mm about the world origin} at equilibrium (scanned models), else None
    """

    evaluations: int
    contact_faces: Mapping[str, int]
    detection: Mapping[str, str]
    residual_history: tuple[float, ...]
    equal_forces_multiplier: float | None = None
    wrench_N: Mapping[str, np.ndarray] | None = None

    def as_dict(self, pose: Pose) -> dict[str, Any]:
        """The run JSON's "extra" object: this record with the solved `pose`'s q."""
        out: dict[str, Any] = {"evaluations": int(self.evaluations),
                               "contact_faces": dict(self.contact_faces),
                               "detection": dict(self.detection),
                               "residual_history": list(self.residual_history)}
        if self.equal_forces_multiplier is not None:
            out["equal_forces_multiplier"] = self.equal_forces_multiplier
        out["q"] = list(pose.q)
        if self.wrench_N is not None:
            out["wrench_N"] = dict(self.wrench_N)
        return _jsonable(out)


@dataclass(frozen=True)
class RunResult:
    """Everything one `fecheck run` reports.

    pose : {x_mm, y_mm, z_mm, abduction_deg, internal_deg, adduction_deg,
        internal_rotation_deg} of the tibia (senses in `POSE_SIGNS`)
    compartments : {"medial"|"lateral": CompartmentResult}
    ligaments : {name: LigamentResult}
    timing_s : {"total", "solve", …} wall-clock seconds (solve = the equilibrium solve
        with its contact evaluations, without mesh building and imports; build = meshes
        and contact pairs; contact = all contact-and-tangent evaluations; per_evaluation_s
        = one evaluation of every compartment; the older ``per_evaluation`` (s, sphere-
        plane) and ``per_evaluation_us`` (µs, scanned) hold the same, `LEGACY_TIMING`)
    exact : closed-form references and deviations (sphere-plane EF), else {}
    record : the Newton solve's record (`SolveRecord`); None for the rigid model, which
        solves one linear system
    menisci : with menisci (`fecheck.model.menisci`): per compartment the axial load into
        the tibia through meniscus and cartilage and the meniscal share, each body's balance
        and pose, the meniscal ligament forces; else {}
    meniscus_maps : with menisci, per meniscus side {"pressure_MPa": (n,) the meniscus's
        face-mean pressure on the compartment's tibial faces (as the compartment's
        `slave_faces`), "outline": (k, 2, 3) world segments (mm) of its footprint's edge
        at the solved pose}, for the pressure map (not written to JSON); else {}

    `pose` is the tibia's; the femur is the fixed frame. `poses` maps every moving body's
    name to its `Pose` (today only the tibia moves).
    coordinates : every free body's generalised coordinates (6,) at the equilibrium (x y z
        mm, θx θy θz rad, `fecheck.statics.newton.body_pose`), by body name (the
        tibia's, "tibia", and each meniscus's, "<compartment> meniscus"); with menisci,
        else {} (the JSON gives them under ``menisci.poses``)
    """

    scene: str
    model: str
    law: str
    converged: bool
    iterations: int
    residual_norm: float
    pose: Pose
    compartments: Mapping[str, CompartmentResult]
    ligaments: Mapping[str, LigamentResult]
    timing_s: Mapping[str, float]
    exact: Mapping[str, Any] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    record: SolveRecord | None = None
    menisci: Mapping[str, Any] = field(default_factory=dict)
    meniscus_maps: Mapping[str, Any] = field(default_factory=dict)
    coordinates: Mapping[str, np.ndarray] = field(default_factory=dict)

    @property
    def poses(self) -> dict[str, Pose]:
        """{body name: solved pose} of every moving body."""
        return {self.pose.body: self.pose}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready nested dict (keys as documented in the README)."""
        return {
            "scene": self.scene, "model": self.model, "law": self.law,
            "converged": bool(self.converged), "iterations": int(self.iterations),
            "residual_norm": _num(self.residual_norm),
            "pose": {k: _num(self.pose[k]) for k in POSE_KEYS},
            "pose_signs": dict(POSE_SIGNS),
            "compartments": {k: c.as_dict() for k, c in self.compartments.items()},
            "ligaments": {k: v.as_dict() for k, v in self.ligaments.items()},
            "timing_s": {k: _num(v) for k, v in self.timing_s.items()},
            "exact": _jsonable(self.exact), "notes": list(self.notes),
            "extra": {} if self.record is None else self.record.as_dict(self.pose),
            **({"menisci": _jsonable(self.menisci)} if self.menisci else {}),
        }

    def write_json(self, path: str | Path) -> None:
        """Write `as_dict()` to `path` as JSON (NaN written as null)."""
        text = json.dumps(self.as_dict(), indent=2) + "\n"
        write_output(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))

    def flat_row(self) -> dict[str, Any]:
        """One flat row (CSV): pose, compartment metrics and ligament forces."""
        row: dict[str, Any] = {"converged": self.converged, "iterations": self.iterations}
        row.update({k: self.pose[k] for k in POSE_KEYS})
        for name, c in self.compartments.items():
            for k, v in c.as_dict().items():
                if k == "force_vector_N":
                    for axis, value in zip("xyz", v or (None,) * 3, strict=True):
                        row[f"{name}_force_{axis}_N"] = value
                elif k != "torque_vector_Nmm":
                    row[f"{name}_{k}"] = v
        for name, lig in self.ligaments.items():
            row[f"{name}_force_N"] = lig.force_N
        row["solve_s"] = self.timing_s.get("solve", math.nan)
        return row

    def write_csv(self, path: str | Path) -> None:
        """Write `flat_row()` as a one-row CSV."""
        write_rows(path, [self.flat_row()])

    def table(self) -> str:
        """A readable text table of the result."""
        lines = [f"scene: {self.scene}   model: {self.model}   law: {self.law}",
                 (f"converged: {self.converged}   iterations: {self.iterations}   "
                  f"residual: {self.residual_norm:.3g} N")]
        lines.append("pose: " + "  ".join(f"{k} {self.pose[k]:+.4f}" for k in POSE_KEYS))
        lines.append("  (adduction_deg: + adduction/varus, the distal tibia medially; "
                     "internal_rotation_deg: + internal; abduction_deg, internal_deg: θy, θz "
                     "of R = Rx·Ry·Rz, old names)")
        rows = [("force N (|F|)", "force_N", "{:.2f}"),
                ("axial force N", "axial_force_N", "{:.2f}"),
                ("max pressure MPa", "max_pressure_MPa", "{:.3f}"),
                ("mean pressure MPa", "mean_pressure_MPa", "{:.3f}"),
                ("contact area mm²", "area_mm2", "{:.1f}"), ("max depth mm", "max_depth_mm",
                "{:.4f}"), ("torque N·mm", "torque_Nmm", "{:.1f}")]
        names = list(self.compartments)
        if all(self.compartments[n].tibial_compression_mm is not None for n in names):
            rows += [("tibial layer mm", "tibial_compression_mm", "{:.4f}"),
                     ("femoral layer mm", "femoral_compression_mm", "{:.4f}")]
        lines.append(f"{'':20s}" + "".join(f"{n:>12s}" for n in names))
        for label, attr, fmt in rows:
            vals = [getattr(self.compartments[n], attr) for n in names]
            lines.append(f"{label:20s}" + "".join(
                f"{'-' if math.isnan(v) else fmt.format(v):>12s}" for v in vals))
        for name, lig in self.ligaments.items():
            lines.append(f"ligament {name:11s}{lig.force_N:12.4g} N (+ tension), "
                         f"length {lig.length_mm:.3f} mm")
        for name, ref in self.exact.items():
            if isinstance(ref, Mapping) and "deviation_percent" in ref:
                dev = ref["deviation_percent"]
                lines.append(f"exact EF {name}: d {ref['max_depth_mm']:.4f} mm, "
                             f"A {ref['area_mm2']:.2f} mm², p_max "
                             f"{ref['max_pressure_MPa']:.3f} MPa; deviation % "
                             + ", ".join(f"{k} {v:+.2f}" for k, v in dev.items()))
        lines.extend(_menisci_lines(self.menisci))
        lines.append("force: |F| is the magnitude of the compartment's contact force on the "
                     "tibia; axial force its component along the tibia's long axis "
                     "(+ compressive)")
        lines.extend(f"note: {n}" for n in self.notes)
        lines.append("time s: " + "  ".join(
            f"{k.removesuffix('_s')} {v:.4f}" for k, v in self.timing_s.items()
            if k not in LEGACY_TIMING))
        return "\n".join(lines)


def _menisci_lines(menisci: Mapping[str, Any]) -> list[str]:
    """The table's lines of a run with menisci (none without)."""
    if not menisci:
        return []
    out = [f"{'menisci':20s}" + "".join(f"{n:>12s}" for n in menisci["compartments"])]
    for label, key, fmt in (("through meniscus N", "meniscus_N", "{:.2f}"),
                            ("through cartilage N", "cartilage_N", "{:.2f}"),
                            ("meniscal share", "meniscal_share", "{:.3f}"),
                            ("meniscus p_max MPa", "meniscus_tibia_max_pressure_MPa", "{:.3f}"),
                            ("meniscus area mm²", "meniscus_tibia_area_mm2", "{:.1f}")):
        vals = [row.get(key, math.nan) for row in menisci["compartments"].values()]
        out.append(f"{label:20s}" + "".join(
            f"{'-' if math.isnan(v) else fmt.format(v):>12s}" for v in vals))
    out += [f"meniscus law {side}: {text}" for side, text in menisci.get("laws", {}).items()]
    out.append("balance N (free DOFs): " + "  ".join(
        f"{k} {v:.2g}" for k, v in menisci["balance_N"].items()))
    for name, pose in menisci["poses"].items():
        out.append(f"pose {name}: translation mm " + " ".join(
            f"{v:+.4f}" for v in pose["translation_mm"]) + ", rotation deg (θx θy θz) "
            + " ".join(f"{v:+.3f}" for v in pose["rotation_deg"]))
    return out


def _num(x: Any) -> float | None:
    x = float(x)
    return None if math.isnan(x) else x


def _jsonable(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return _num(x)
    return x


def write_rows(path: str | Path, rows: list[Mapping[str, Any]]) -> None:
    """Write dict rows to a CSV file (columns of the first row, in order)."""
    def write(tmp: Path) -> None:
        with open(tmp, "w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)

    write_output(path, write)

