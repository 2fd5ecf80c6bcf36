"""Driven knee flexion: the tibia turned about a stated flexion axis, the other DOFs solved.

The flexion axis is a line fixed in the femur: a point c (mm) and a unit direction e
pointing to the subject's right (+x side), either given or fitted from the femoral
articular surface: a sphere fitted to the posterior-distal faces of each condyle (the
selection of the lenhart2015 data README: outward normal between distal and posterior,
-10° < atan2(-n_y, -n_z) < 100°, |n_x| < 0.5, centroid y < 15 mm and |x| > 8 mm, medial
and lateral by the sign of x), the axis through the two centres (a cylinder fit of the
posterior condyles, close to the transepicondylar axis).

At knee flexion φ (deg, + flexed: the ankle moves posterior) the tibia's rotation is
R = Q·Rx(-φ)·Ry(θy)·Rz(θz)·Qᵀ with Q the smallest rotation taking e_x to e: θy and θz
are the Cardan angles about the floating and the tibial axis, as in the fixed-axis models.
Reported by anatomical sense (`FLEX_SIGNS`): adduction_deg (+ adduction, varus: the distal
tibia moves medially; +θy in a right knee, -θy in a left one) and internal_rotation_deg (+
internal: the tibia's anterior turns medially; +θz right, -θz left). The old fields stay:
abduction_deg is θy (adduction in a right knee, despite its name) and internal_deg the
internal rotation.
The translation reported is that of the tibial point at c at the rest pose, d = R·c + t - c,
in the axis frame (Qᵀ·d: x along the axis, y anterior, z superior): zero for a pure hinge.
Each angle starts from the last equilibrium with the same θy, θz and d.
"""

from __future__ import annotations

import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fecheck.errors import FecheckError
from fecheck.fe.knee.balance import body_balance
from fecheck.fe.knee.patella_layer import ef_knee
from fecheck.laws.coldstart import announce_cold_kernels
from fecheck.model.knee_surfaces import femoral_master
from fecheck.model.patella import PatellaModel, PatellaState, build_patella, solve_knee
from fecheck.scene import Scene
from geometry.mesh import TriMesh

NOTCH_MM = 8.0
"""Faces within this distance of x = 0 (the intercondylar notch) are not fitted, mm."""

POSTERIOR_Y_MM = 15.0
"""Faces anterior of this y (the trochlea) are not fitted, mm."""

EDGE_MM = 5.0
"""A failing angle whose last contact was this close to the femoral surface's edge is
reported as past the cartilage, mm."""

AXIS_MIN_X = 0.2
"""Smallest |x| component of a given flexion axis's unit direction (78.46° from x)."""
MAX_ANGLES = 2_000
"""Most angles a flex run solves: 0.1° steps over the whole -30 to 160° range fit (1,901),
and 2,000 angles take about 25 minutes on the scanned knee (`SECONDS_PER_ANGLE`); each
angle's face pressures stay in memory for the outputs."""
SECONDS_PER_ANGLE = 0.8
"""Wall time of one angle of femur_tibia_ligaments (measured 0.76 s per angle over 0:20:1,
after the build), s."""
LIGAMENT_GROUPS = ("ACL", "PCL", "MCL", "LCL", "PFL", "pCAP")
"""Bundle-name prefixes summed per ligament in the reports."""
PATELLA_GROUPS = ("PT", "lPFL", "mPFL")
"""Bundle-name prefixes of the patella's bundles summed in the reports (with patella.dir)."""

FLEX_SIGNS = {
    "flexion_deg": "+ flexion (the ankle moves posterior), driven about the flexion axis",
    "adduction_deg": "+ adduction (varus): the distal tibia moves medially; - abduction",
    "internal_rotation_deg": "+ internal rotation: the tibia's anterior turns medially; - "
                             "external",
    "abduction_deg": "old name of +θy (Cardan angle about the floating axis): adduction in a "
                     "right knee, abduction in a left one; read adduction_deg",
    "internal_deg": "old name of internal_rotation_deg (the same value)",
    "ml_mm, ap_mm, si_mm": "the tibial point at the axis point, moved from the rest pose, "
                           "in the axis frame: along the axis (+ right), anterior, superior",
}
"""The sense of each kinematic column of `fecheck flex`, as stated in its outputs."""


@dataclass(frozen=True)
class FlexionAxis:
    """The knee flexion axis: point (3,) mm, unit direction (3,) (+x side), source text,
    and the two condyle sphere fits (centre mm, radius mm) when fitted."""

    point: np.ndarray
    direction: np.ndarray
    source: str
    spheres: dict = field(default_factory=dict)

    def describe(self) -> str:
        """One line: the axis and where it comes from."""
        p, e = self.point, self.direction
        return (f"flexion axis: point ({p[0]:.2f}, {p[1]:.2f}, {p[2]:.2f}) mm, direction "
                f"({e[0]:.4f}, {e[1]:.4f}, {e[2]:.4f}) ({self.source})")


def axis_rotation(direction: np.ndarray) -> np.ndarray:
    """Q (3, 3): the smallest rotation taking e_x to the unit `direction` (x > 0).

    >>> bool(np.allclose(axis_rotation(np.array([0.0, 1.0, 1.0])) @ [1.0, 0.0, 0.0],
    ...                  [0.0, 0.7071068, 0.7071068]))
    True
    """
    e = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    v = np.cross([1.0, 0.0, 0.0], e)
    c = float(e[0])
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def given_axis(point: Sequence[float], direction: Sequence[float],
               where: str = "--axis-dir") -> FlexionAxis:
    """An axis given by the user (`where` names the option or key), direction made +x."""
    e = np.asarray(direction, dtype=float)
    norm = float(np.linalg.norm(e))
    if not np.all(np.isfinite(e)) or norm == 0.0:
        raise FecheckError(f"{where} {list(direction)} is not a direction: give three "
                           "finite numbers, not all zero")
    e = e / norm
    if abs(e[0]) < AXIS_MIN_X:
        off = math.degrees(math.acos(abs(e[0])))
        limit = math.degrees(math.acos(AXIS_MIN_X))
        raise FecheckError(f"{where} {list(direction)} is {off:.2f}° from the medio-lateral "
                           f"x axis, more than the {limit:.2f}° allowed: give the knee's "
                           "flexion axis")
    return FlexionAxis(np.asarray(point, dtype=float), np.sign(e[0]) * e,
                       f"given by {where.removesuffix('-dir').removesuffix('_dir')}")


def condyle_axis(femur: TriMesh) -> FlexionAxis:
    """The axis through the centres of spheres fitted to the posterior-distal faces of the
    two femoral condyles (module docstring), from the femoral articular surface (mm)."""
    from geometry.fits import fit_sphere

    n = femur.face_normals
    cen = femur.face_centroids
    angle = np.degrees(np.arctan2(-n[:, 1], -n[:, 2]))
    keep = (angle > -10.0) & (angle < 100.0) & (np.abs(n[:, 0]) < 0.5) \
        & (cen[:, 1] < POSTERIOR_Y_MM)
    fits = {}
    for name, side in (("x<0", cen[:, 0] < -NOTCH_MM), ("x>0", cen[:, 0] > NOTCH_MM)):
        sel = keep & side
        if np.count_nonzero(sel) < 20:
            raise FecheckError(f"the femoral surface has {np.count_nonzero(sel)} "
                               f"posterior-distal faces at {name} (|x| > {NOTCH_MM} mm, "
                               f"y < {POSTERIOR_Y_MM} mm): no condyle to fit a flexion "
                               "axis; give it with --axis-point and --axis-dir")
        fit = fit_sphere(cen[sel], weights=femur.face_areas[sel])
        fits[name] = (fit.center, fit.radius_mm)
    a, b = fits["x<0"][0], fits["x>0"][0]
    e = (b - a) / np.linalg.norm(b - a)
    return FlexionAxis((a + b) / 2.0, e, "fitted: through the centres of spheres fitted to "
                       "the posterior condyles", fits)


def parse_angles(text: str) -> np.ndarray:
    """Flexion angles (deg) from ``A:B:STEP`` (A to B inclusive) or ``A,B,C``: finite,
    within -30 to 160 degrees, at most `MAX_ANGLES` of them (counted before any is made).

    >>> parse_angles("0:10:5").tolist()
    [0.0, 5.0, 10.0]
    """
    try:
        if ":" in text:
            a, b, step = (float(v) for v in text.split(":"))
            if not step > 0 or not b >= a:
                raise ValueError
        else:
            out = np.array([float(v) for v in re.split(r"[,\s]+", text.strip())])
            a, b, step = float(out.min()), float(out.max()), None
    except ValueError:
        raise FecheckError(f"--angles {text!r}: give START:STOP:STEP (STEP > 0, STOP >= "
                           "START) or a comma list, degrees") from None
    values = [a, b] + ([] if step is None else [step])
    if not all(math.isfinite(v) for v in values) or a < -30.0 or b > 160.0:
        raise FecheckError(f"--angles {text!r}: flexion angles are finite numbers from -30 to "
                           "160 degrees")
    if step is None:
        count = len(out)
    else:
        count = math.floor((b - a) / step + 1e-9) + 1
    if count > MAX_ANGLES and step is None:
        raise FecheckError(f"--angles: {count:,} angles listed, more than the {MAX_ANGLES:,} a "
                           "flex run solves: give fewer")
    if count > MAX_ANGLES:
        fits = (b - a) / (MAX_ANGLES - 1)
        digits = max(0, 1 - math.floor(math.log10(fits)))
        raise FecheckError(f"--angles {text!r} makes {count:,} angles, more than the "
                           f"{MAX_ANGLES:,} a flex run solves (about {SECONDS_PER_ANGLE:g} s "
                           f"each on the scanned knee): use a STEP >= "
                           f"{math.ceil(fits * 10**digits) / 10**digits:g} degrees")
    if step is None:
        return out
    return a + step * np.arange(count)


@dataclass
class FlexPoint:
    """One solved flexion angle.

    flexion_deg : driven knee flexion, deg
    abduction_deg : θy (old name; + adduction in a right knee), deg
    internal_deg : internal rotation, deg (+ internal, either side)
    translation_mm : (3,) d in the axis frame, mm
    compartments : {name: dict of force_N, axial_force_N, area_mm2, max_pressure_MPa,
        cop_x_mm, cop_y_mm (centre of pressure, tibia frame)}
    ligaments : {bundle: tension N}
    rot, t : the tibia's pose; fields : {compartment: face pressure MPa (n_faces,)}
    iterations, seconds : Newton iterations and wall time of this angle
    q : (5,) the solved coordinates (x, y, z mm, θy, θz rad) with the flexion held
    side : "right" or "left", the knee's side (sets `adduction_deg`'s sign)
    patella : the patella at this angle (`fecheck.model.patella.PatellaState`), with
        patella.dir; else None
    """

    flexion_deg: float
    abduction_deg: float
    internal_deg: float
    translation_mm: np.ndarray
    compartments: dict
    ligaments: dict
    rot: np.ndarray
    t: np.ndarray
    fields: dict
    iterations: int
    seconds: float
    q: np.ndarray | None = None
    side: str = "right"
    patella: PatellaState | None = None

    @property
    def adduction_deg(self) -> float:
        """Adduction (varus) +, abduction -, deg."""
        return (1.0 if self.side == "right" else -1.0) * self.abduction_deg

    @property
    def internal_rotation_deg(self) -> float:
        """Internal rotation +, external -, deg."""
        return self.internal_deg

    def row(self) -> dict:
        """Flat CSV row: kinematics (`FLEX_SIGNS`), compartments, ligament groups (N)."""
        d = self.translation_mm
        out = {"flexion_deg": self.flexion_deg, "abduction_deg": self.abduction_deg,
               "internal_deg": self.internal_deg, "ml_mm": d[0], "ap_mm": d[1],
               "si_mm": d[2], "adduction_deg": self.adduction_deg,
               "internal_rotation_deg": self.internal_rotation_deg}
        for name, c in self.compartments.items():
            out.update({f"{name}_{k}": v for k, v in c.items()})
        for group in LIGAMENT_GROUPS:
            out[f"{group}_N"] = sum(v for k, v in self.ligaments.items()
                                    if k.startswith(group))
        if self.patella is not None:
            out.update(patella_row(self.patella))
        out.update(iterations=self.iterations, seconds=self.seconds)
        return out


def patella_row(state: PatellaState) -> dict:
    """The patella's columns of a row: its six coordinates (the source
    model's pf_r), the patellofemoral contact (PF_force_N, PF_area_mm2,
    PF_max_pressure_MPa, centre of pressure PF_cop_x/y/z_mm in the femur frame), its
    bundle groups (`PATELLA_GROUPS`, N) and the quadriceps total (N)."""
    c = state.contact
    cop = state.centre_of_pressure()
    out = dict(state.coordinates())
    out.update(PF_force_N=c.force_N, PF_area_mm2=c.area_mm2,
               PF_max_pressure_MPa=c.max_pressure_MPa, PF_cop_x_mm=float(cop[0]),
               PF_cop_y_mm=float(cop[1]), PF_cop_z_mm=float(cop[2]))
    for group in PATELLA_GROUPS:
        out[f"{group}_N"] = sum(v for k, v in state.ligaments.items() if k.startswith(group))
    out["quadriceps_N"] = sum(state.quadriceps.values())
    return out


@dataclass
class FlexRun:
    """A flexion run: axis, solved points, build time and wall time of the angles after
    it (s), and how it ended (`stopped`: None when every angle was solved, else the
    one-line reason); `fe`: the FE cross-check rows of the --fe-at angles (`fe_row`);
    `femur`: {part: TriMesh} of the fixed femur (mm, world; the articular surface, to which
    the caller may add the bone, `femur_bone`); `bundles`: (names, femoral points (n, 3)
    world, tibial points (n, 3) tibia frame) of the ligament bundles, mm; `patella`: the
    patella's model (`fecheck.model.patella.PatellaModel`) with patella.dir, else None."""

    axis: FlexionAxis
    points: list[FlexPoint]
    build_seconds: float
    slaves: dict
    stopped: str | None = None
    sweep_seconds: float = 0.0
    fe: list[dict] = field(default_factory=list)
    femur: dict = field(default_factory=dict)
    bundles: tuple = ((), np.zeros((0, 3)), np.zeros((0, 3)))
    patella: PatellaModel | None = None


def scene_axis(scene: Scene) -> FlexionAxis:
    """The flexion axis of a femur-tibia scene: flexion.axis_point_mm and flexion.axis_dir
    if set, else fitted from its femoral articular surface."""
    from fecheck.scene import surfaces

    point, direction = scene["flexion.axis_point_mm"], scene["flexion.axis_dir"]
    if (point is None) != (direction is None):
        raise FecheckError("set both flexion.axis_point_mm and flexion.axis_dir, or neither "
                           "(the axis fitted to the posterior condyles)")
    check_kind(scene)
    if point is not None:
        return given_axis(point, direction, "flexion.axis_dir")
    return condyle_axis(surfaces.femoral_surface(scene))


def check_kind(scene: Scene) -> None:
    """Refuse a scene that is not a femur-tibia model (flexion turns a femoral surface),
    or one with menisci (not carried through flexion yet)."""
    if scene["model.kind"] != "femur-tibia":
        raise FecheckError(f"fecheck flex needs a femur-tibia scene (a femoral surface to "
                           f"roll over the plateaus), not model.kind = "
                           f"{scene['model.kind']!r}: set model.kind = 'femur-tibia'")
    if scene["menisci.dir"]:
        raise FecheckError("fecheck flex does not carry the menisci through flexion yet "
                           f"(menisci.dir = {scene['menisci.dir']!r}): set menisci.dir = '' "
                           "to flex the knee without them")


def _cop(slave: TriMesh, pressure: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Centre of pressure (3,) mm of one compartment in the tibia frame (NaN: none)."""
    w = pressure * area
    total = float(w.sum())
    if total <= 0.0:
        return np.full(3, math.nan)
    return w @ slave.face_centroids / total


def _warm(axis: FlexionAxis, q_rot: np.ndarray, phi: float, ab: float, ie: float,
          d: np.ndarray) -> np.ndarray:
    """q (5,) at flexion `phi` (rad) with rotations ab, ie (rad) and axis-point
    displacement d (world, mm): t = c + d - R·c."""
    from fecheck.statics.newton import body_pose

    rot, _ = body_pose(np.array([0.0, 0.0, 0.0, -phi, ab, ie]), q_rot)
    t = axis.point + d - rot @ axis.point
    return np.array([t[0], t[1], t[2], ab, ie])


def parse_fe_at(text: str | None, angles: np.ndarray) -> list[float]:
    """The --fe-at angles (deg), each one of the sweep's `angles` ([] for None).

    >>> parse_fe_at("0,10", parse_angles("0:10:5"))
    [0.0, 10.0]
    """
    if text is None:
        return []
    try:
        out = [float(v) for v in re.split(r"[,\s]+", text.strip())]
    except ValueError:
        raise FecheckError(f"--fe-at {text!r}: give a comma list of flexion angles, "
                           "degrees") from None
    missing = [a for a in out if not np.any(np.isclose(angles, a, rtol=0.0, atol=1e-9))]
    if missing:
        raise FecheckError(f"--fe-at {text!r}: {', '.join(f'{a:g}' for a in missing)}° not "
                           f"among the --angles ({angles[0]:g} to {angles[-1]:g}°, "
                           f"{len(angles)} angles): give angles of the sweep")
    return out


def run_flex(scene: Scene, angles: Sequence[float], axis: FlexionAxis,
             progress: Callable[[int, FlexPoint], None] | None = None,
             fe_at: Sequence[float] = (), fe_log: Callable[[str], None] | None = None
             ) -> FlexRun:
    """Solve the scene at every flexion angle (deg) in turn, each from the last, then
    the FE cross-check at the solved angles of `fe_at` (`fe_row`; `fe_log` gets its
    progress; an angle whose FE fails gets a row of its flexion and the one-line reason,
    ``fe_error``, and the others go on).

    A failure at an angle (no equilibrium, no convergence, contact lost in a compartment:
    the femoral cartilage ran out) stops the run with `stopped` naming the angle; Ctrl-C
    stops it with the finished angles kept (`stopped` says so).
    """
    from fecheck.model.scanned import build_compartments, bundle_springs

    check_kind(scene)
    announce_cold_kernels()
    t0 = time.perf_counter()
    comps = build_compartments(scene)
    names, springs = bundle_springs(scene)
    patella = build_patella(scene) if scene["patella.dir"] else None
    run = FlexRun(axis, [], time.perf_counter() - t0, {c.name: c.pair.slave for c in comps},
                  femur={"articular surface": comps[0].pair.master.mesh},
                  bundles=(tuple(names),
                           np.array([s.femur_point for s in springs]).reshape(-1, 3),
                           np.array([s.tibia_point for s in springs]).reshape(-1, 3)),
                  patella=patella)
    t_built = time.perf_counter()
    try:
        _sweep(scene, angles, axis, run, comps, (names, springs), progress)
    except KeyboardInterrupt:
        run.stopped = f"interrupted at flexion {angles[len(run.points)]:g}°"
    finally:
        run.sweep_seconds = time.perf_counter() - t_built
    for p in run.points:
        if any(math.isclose(p.flexion_deg, a, abs_tol=1e-9) for a in fe_at):
            try:
                run.fe.append(fe_row(scene, p, axis, (comps, names, springs), fe_log, patella))
            except FecheckError as err:
                run.fe.append({"flexion_deg": p.flexion_deg, "fe_error": str(err)})
    return run


def femur_bone(scene: Scene) -> TriMesh | None:
    """The femoral bone of the scene (geometry.femur_bone, mm), None where unset."""
    from fecheck.scene import surfaces

    if surfaces.file_path(scene, "femur_bone") is None:
        return None
    return surfaces.bone(scene, "femur")


def fe_row(scene: Scene, point: FlexPoint, axis: FlexionAxis, built: tuple,
           log: Callable[[str], None] | None = None, patella: PatellaModel | None = None
           ) -> dict:
    """The FE cross-check (`fecheck.fe.knee.crosscheck.cross_check`, joint mode by default) of
    one solved angle: the EF run at the angle's pose (`run_scanned` from its q, the
    flexion held about the axis; with the `patella`, the tibia and the patella solved
    together from their poses, `fecheck.fe.knee.patella_layer.ef_knee`), the FE from there with
    the same flexion held and the other DOFs free under the same load, gravity, ligaments
    (and muscles).

    Returns {flexion_deg, balance (the largest free-DOF imbalance of any body at the FE
    pose over its load, `fecheck.fe.knee.balance.body_balance`: for the tibia forces /
    load.force_N, moments / (100 mm · load.force_N)), fe_seconds, ef_seconds, and per
    tibial compartment FE and EF p_max (face-averaged, MPa), area (mm²), split (share of
    the summed force magnitudes), centre of pressure x, y (mm, tibia frame) and their
    distance (mm); with the patella `patella_row_fe`'s PF columns}, `check`: the
    `CrossCheck`.
    """
    from fecheck.fe.knee.crosscheck import cross_check
    from fecheck.model.scanned import run_scanned

    flexion = (-math.radians(point.flexion_deg), axis_rotation(axis.direction))
    if log is not None:
        log(f"the FE cross-check at flexion {point.flexion_deg:g}°")
    t0 = time.perf_counter()
    pf = None
    if patella is None:
        ef = run_scanned(scene, point.q, flexion, built)
    else:
        ef, pf, _ = ef_knee(scene, flexion, (point.q, point.patella.q), built, patella)
    ef_seconds = time.perf_counter() - t0
    check = cross_check(scene, log=log, ef=(ef, ef_seconds), flexion=flexion, extra=pf)
    balance = body_balance(scene, check, flexion)
    row = {"flexion_deg": point.flexion_deg, "balance": max(balance.values()),
           "fe_seconds": check.timing_s["fe"], "ef_seconds": ef_seconds}
    splits = {side: check.split(side) for side in ("fe", "ef_model")}
    for name, chk in check.compartments.items():
        if name not in splits["fe"]:
            row |= patella_row_fe(chk) | {"patella_balance": balance["patella"]}
            continue
        fe_cop, ef_cop = (np.full(3, math.nan) if c is None else np.asarray(c, dtype=float)
                          for c in (chk.fe.center_of_pressure_mm,
                                    chk.ef_model.center_of_pressure_mm))
        row.update({f"{name}_fe_p_max_MPa": float(np.nanmax(chk.fe_face_pressure_MPa)),
                    f"{name}_ef_p_max_MPa": chk.ef_model.max_pressure_MPa,
                    f"{name}_fe_area_mm2": chk.fe.area_mm2,
                    f"{name}_ef_area_mm2": chk.ef_model.area_mm2,
                    f"{name}_fe_split": splits["fe"][name],
                    f"{name}_ef_split": splits["ef_model"][name],
                    f"{name}_fe_cop_x_mm": fe_cop[0], f"{name}_fe_cop_y_mm": fe_cop[1],
                    f"{name}_ef_cop_x_mm": ef_cop[0], f"{name}_ef_cop_y_mm": ef_cop[1],
                    f"{name}_cop_distance_mm": chk.cop_distance_mm})
    return row | {"check": check}


def patella_row_fe(chk) -> dict:
    """The PF columns of an FE row from the patellofemoral `CompartmentCheck`: FE and EF
    force (N), p_max (FE face-averaged, MPa), area (mm²), centre of pressure x, y, z (mm,
    patella frame) and their distance (mm)."""
    fe_cop, ef_cop = (np.full(3, math.nan) if c is None else np.asarray(c, dtype=float)
                      for c in (chk.fe.center_of_pressure_mm, chk.ef_model.center_of_pressure_mm))
    out = {"PF_fe_force_N": chk.fe.force_N, "PF_ef_force_N": chk.ef_model.force_N,
           "PF_fe_p_max_MPa": float(np.nanmax(chk.fe_face_pressure_MPa)),
           "PF_ef_p_max_MPa": chk.ef_model.max_pressure_MPa,
           "PF_fe_area_mm2": chk.fe.area_mm2, "PF_ef_area_mm2": chk.ef_model.area_mm2,
           "PF_cop_distance_mm": chk.cop_distance_mm}
    for i, axis in enumerate("xyz"):
        out[f"PF_fe_cop_{axis}_mm"], out[f"PF_ef_cop_{axis}_mm"] = fe_cop[i], ef_cop[i]
    return out


SUBSTEP_DEG = 1.0
"""An angle not solved from the last solved one in one step is approached from there in
steps of at most this (deg), each from the one before (a continuation; only the asked
angle is reported): the source model's passive set-up with the patella solves every
angle 0-120° at 1° steps, while from 30° to 60° in one step the patella leaves the
trochlea."""


def _sweep(scene: Scene, angles: Sequence[float], axis: FlexionAxis, run: FlexRun, comps,
           bundles: tuple, progress: Callable[[int, FlexPoint], None] | None) -> None:
    """The angles of `run_flex` in turn, appended to `run.points` (`run.stopped` set
    where they stop); an angle not reached in one step is reached in `SUBSTEP_DEG` steps."""
    from fecheck.model.equilibrium import compartment_results, solve_equilibrium
    from fecheck.model.scanned import bundle_parts

    names, springs = bundles
    parts = bundle_parts(springs)
    q_rot = axis_rotation(axis.direction)
    sign = 1.0 if scene["knee.side"] == "right" else -1.0

    def solve_at(phi_deg: float, last: tuple | None) -> tuple[FlexPoint | None, object, str]:
        """The point at `phi_deg` from the last solved (eq, patella state), or None, and
        the equilibrium, and why it failed ('' when solved)."""
        phi = math.radians(phi_deg)
        warm = state = None
        if last is not None:
            eq, state = last
            warm = _warm(axis, q_rot, phi, float(eq.q[3]), float(eq.q[4]),
                         eq.rot @ axis.point + eq.t - axis.point)
        try:
            if run.patella is None:
                eq = solve_equilibrium(scene, comps, parts, (), warm, (-phi, q_rot),
                                       check=last is None)
            else:
                eq, state = solve_knee(scene, comps, parts, run.patella, warm,
                                       None if state is None else state.q, (-phi, q_rot),
                                       check=last is None)
        except FecheckError as err:
            return None, None, f"flexion {phi_deg:g}°: {err}"
        point = _point(scene, comps, eq, compartment_results(comps, eq), names, springs,
                       axis, q_rot, phi_deg, sign)
        point.patella = state
        lost = [c for c, v in point.compartments.items() if v["force_N"] <= 0.0]
        if state is not None and state.contact.force_N <= 0.0:
            lost.append("patellofemoral")
        if not eq.solution.converged or lost:
            return None, None, _stop_reason(phi_deg, eq, lost, run.points)
        return point, (eq, state), ""

    last = None
    for i, phi_deg in enumerate(angles):
        point, solved, why = solve_at(phi_deg, last)
        if why and run.points and abs(phi_deg - run.points[-1].flexion_deg) > SUBSTEP_DEG:
            point, solved, why = _continued(solve_at, run.points[-1].flexion_deg, phi_deg,
                                            last)
        if why:
            run.stopped = why + _edge_note(scene, run.points)
            return
        run.points.append(point)
        last = solved
        if progress is not None:
            progress(i, point)


def _continued(solve_at: Callable, start_deg: float, phi_deg: float, last: tuple) -> tuple:
    """`solve_at` (of `_sweep`) from the solved `start_deg` to `phi_deg` in steps of at most
    `SUBSTEP_DEG`, each from the one before; the last step's (point, solved, why), or the
    first failed one's, its reason naming both angles."""
    n = math.ceil(abs(phi_deg - start_deg) / SUBSTEP_DEG - 1e-9)
    out = (None, last, "")
    for between in np.linspace(start_deg, phi_deg, n + 1)[1:]:
        out = solve_at(float(between), out[1])
        if out[2]:
            return (None, None, f"flexion {phi_deg:g}° (approached from {start_deg:g}° in "
                                f"{SUBSTEP_DEG:g}° steps): {out[2]}")
    return out


def _stop_reason(phi_deg: float, eq, lost: list[str], done: list[FlexPoint]) -> str:
    """The one line of an angle that did not solve."""
    if lost:
        where = ""
        if done and lost[0] in done[-1].compartments:
            last = done[-1].compartments[lost[0]]
            where = (f" (its centre of pressure at {done[-1].flexion_deg:g}° was at x = "
                     f"{last['cop_x_mm']:.1f}, y = {last['cop_y_mm']:.1f} mm, tibia frame)")
        return (f"flexion {phi_deg:g}°: no {' or '.join(lost)} contact: the femoral "
                f"cartilage surface ends there{where}; stop the range before this angle")
    sol = eq.solution
    return (f"flexion {phi_deg:g}°: no equilibrium in {sol.iterations} iterations (residual "
            f"{sol.residual_norm:.3g} N); stop the range before this angle or raise "
            "solver.max_iterations")


def _edge_note(scene: Scene, done: list[FlexPoint]) -> str:
    """Where the last solved angle's contact was nearest the femoral surface's edge: ``;
    at A° the C centre of pressure was D mm from the edge of the femoral surface (x, y, z
    mm)`` ('' for none solved or a closed femoral surface)."""
    from scipy.spatial import cKDTree

    from fecheck.contact.pair import boundary_vertices

    if not done:
        return ""
    femur = femoral_master(scene)
    edge = femur.points[boundary_vertices(femur)]
    if not len(edge):
        return ""
    last = done[-1]
    best = (math.inf, "", np.zeros(3))
    for name, c in last.compartments.items():
        x = last.rot @ np.array([c["cop_x_mm"], c["cop_y_mm"], c["cop_z_mm"]]) + last.t
        dist, i = cKDTree(edge).query(x)
        if np.isfinite(dist) and dist < best[0]:
            best = (float(dist), name, edge[i])
    dist, name, at = best
    if not name:
        return ""
    out = (f"; at {last.flexion_deg:g}° the {name} centre of pressure was {dist:.1f} mm "
           f"from the edge of the femoral surface (at {at[0]:.1f}, {at[1]:.1f}, {at[2]:.1f} mm)")
    return out + (": the femoral cartilage runs out there" if dist < EDGE_MM else "")


def _point(scene: Scene, comps, eq, results: dict, names, springs, axis: FlexionAxis,
           q_rot: np.ndarray, phi_deg: float, sign: float) -> FlexPoint:
    """The `FlexPoint` of one equilibrium."""
    rot, t = eq.rot, eq.t
    compartments, fields = {}, {}
    for c in comps:
        r = results[c.name]
        x, y, z = _cop(c.pair.slave, r.face_pressure_MPa, r.face_area_mm2)
        compartments[c.name] = {"force_N": r.force_N, "axial_force_N": r.axial_force_N,
                                "area_mm2": r.area_mm2, "max_pressure_MPa": r.max_pressure_MPa,
                                "cop_x_mm": float(x), "cop_y_mm": float(y),
                                "cop_z_mm": float(z)}
        fields[c.name] = np.asarray(r.face_pressure_MPa, dtype=float)
    ligaments = {}
    for name, spring in zip(names, springs, strict=True):
        length = float(np.linalg.norm(spring.femur_point - (rot @ spring.tibia_point + t)))
        ligaments[name] = float(spring.tension(length))
    d = q_rot.T @ (rot @ axis.point + t - axis.point)
    return FlexPoint(float(phi_deg), math.degrees(eq.q[3]), sign * math.degrees(eq.q[4]), d,
                     compartments, ligaments, rot, t, fields, eq.solution.iterations,
                     eq.seconds, np.asarray(eq.q, dtype=float),
                     "right" if sign > 0 else "left")
