"""The scanned knee with menisci: tibia and both menisci as rigid bodies.

``menisci.dir`` (a folder, or ``"fecheck:knee/smith2019_menisci"``) adds the menisci of the
smith2019 model (OpenSim-JAM; Smith, Brandon & Thelen 2019, J. Biomech. 82:124-133) to a
femur-tibia scene. Bodies of the block Newton (`fecheck.statics.newton`): the femur (fixed,
the world frame), the tibia (the scene's free DOFs) and each meniscus (menisci.free: all six
coordinates by default). Contact, each an EF interface (`fecheck.statics.interfaces.Interface`) per
compartment:

* femoral ↔ tibial cartilage: the femur-tibia scene's own pairs and laws;
* femoral cartilage ↔ meniscus, and meniscus ↔ tibial cartilage: the cartilage sheet is the
  slave and the meniscus's closed volume surface the master. The volume's top and bottom
  are the meniscus's superior and inferior articular surfaces (within 0.22 mm, the data
  set's README); a closed master has an inside everywhere, whereas an open articular
  surface as the master, or the cartilage sheet as the master of the meniscus surface,
  gives the depth's side-of-normal sign jumps behind the sheet's rim
  (`fecheck.contact.mesh_master`), which a meniscus reaching past the cartilage's edge
  (43-76 mm² of each) turns into force jumps that stall Newton. Inside or outside the
  volume is its generalised winding number, with the tree's closest face: the side of the
  closest face's normal put femoral cartilage points outside the medial meniscus's
  anterior rim up to 7.3 mm inside it (25 N of spurious force at the 800 N pose), and a
  closest-face walk from the last call can stop at a local closest face of the thin
  rim; either made the contact wrench depend on the calls before, not on the pose alone,
  and stalled the line search (200 and 2000 N and a 120 MPa meniscus did not converge,
  800 N took 24 iterations; now 9-13 iterations from 200 to 2000 N and 1 to 120 MPa).

A meniscus interface uses the linear EF of the law registry (contact.law = "ef") with the
meniscus layer (menisci.youngs_MPa, menisci.poisson, menisci.thickness_mm: smith2019's
1 MPa, 0.45, 3 mm) and one cartilage layer (the contact material over half of
contact.thickness_mm, which holds both layers) combined as menisci.layers says:
"lumped" (smith2019's use_lumped_contact_model, Bei & Fregly 2003, as OpenSim-JAM's
Smith2018ArticularContactForce computes it): one layer of the mean modulus and mean
Poisson's ratio over the summed thickness, k = (1−ν̄)Ē/((1+ν̄)(1−2ν̄)(h_m + h_c)); the
smith2019 meniscus modulus (1 MPa) belongs to this convention. "series": the two layers as
springs in series, 1/k = 1/k_meniscus + 1/k_cartilage (softer: 1.11 against 3.18 N/mm³
with the packaged scene's values).
The 15 meniscal ligaments of ``meniscal_ligaments.json`` (coronary, horn roots, transverse)
are Blankevoort 1991 springs between tibia and meniscus (the transverse one between the two
menisci). The femur sits at smith2019's default knee pose, the matrix G of the data set's
menisci.json: the tibia and the menisci start at G⁻¹ composed with the scene's dofs.* start
pose, where the menisci just touch the femur and the cartilages are 2.3 mm apart. The
menisci carry no weight (about 1 g each).

Result (`MenisciResult`, in `RunResult.menisci`): per compartment the axial load into the
tibia through the meniscus and through cartilage-cartilage contact and the meniscal share of
their sum, each body's pose, and each body's balance on its free coordinates.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws.calibrated import (
    MENISCI_INTERFACES,
    Calibration,
    calibrated_params,
    check_fingerprint,
    read_calibration,
)
from fecheck.laws.fused import compiled_law, linear_law
from fecheck.laws.kernel import CALIBRATED
from fecheck.laws.materials import ef_stiffness
from fecheck.laws.registry import spec_of
from fecheck.model.assembly import applied_load, force_scale, free_indices, start_pose
from fecheck.model.equilibrium import axial_force, compartment_result, not_converged_note
from fecheck.model.fingerprint import scene_fingerprint
from fecheck.model.knee_surfaces import femoral_master, tibial_slaves
from fecheck.model.menisci_shape import (
    FitMap,
    PartialMap,
    drop_inner,
    fit_fields,
    partial_map,
    touching_femur,
)
from fecheck.model.plausibility import before_solve
from fecheck.model.results import Pose, RunResult, SolveRecord
from fecheck.scene import SCHEMA, Scene
from fecheck.scene.constants import COMPARTMENTS
from fecheck.scene.packaged import PACKAGE_PREFIX, data_dir
from fecheck.scene.surfaces import read_surface
from fecheck.scene.unit_hints import load_warning, no_equilibrium_hint
from fecheck.statics.frames import rot_y
from fecheck.statics.interfaces import Interface
from fecheck.statics.ligaments import BodySpring
from fecheck.statics.newton import (
    BODY_DOFS,
    TIBIA_COORDINATES,
    Body,
    NoEquilibrium,
    NoStiffness,
    Problem,
    body_basis,
    body_pose,
    on_body,
    solve,
    tibia_body,
)
from fecheck.statics.root_spring import RootSpring
from geometry.mesh import TriMesh, is_closed

FEMUR, TIBIA = 0, 1
"""Body indices: the femur (fixed, the world frame) and the tibia; the menisci follow."""
VOLUME = "smith2019_R_meniscus_{side}.stl"
"""File name of a meniscus's closed volume surface."""


def menisci_dir(scene: Scene) -> Path:
    """The folder ``menisci.dir`` names (``fecheck:NAME``, or a path relative to the
    scene file's folder)."""
    given = scene["menisci.dir"]
    if given.startswith(PACKAGE_PREFIX):
        folder = data_dir(given, "menisci.dir")
    else:
        folder = Path(os.path.expandvars(given)).expanduser()
        if not folder.is_absolute():
            folder = (Path(scene.source).expanduser().resolve().parent / folder).resolve()
    if not folder.is_dir():
        raise FecheckError(f"{scene.source}: menisci.dir = {given!r}: no folder at {folder}; "
                           "give the smith2019_menisci folder or 'fecheck:knee/"
                           "smith2019_menisci'")
    needed = ["menisci.json", "meniscal_ligaments.json",
              *(VOLUME.format(side=s) for s in _sides(scene))]
    missing = [name for name in needed if not (folder / name).is_file()]
    if missing:
        raise FecheckError(f"menisci.dir = {given!r}: {folder} holds no {', '.join(missing)}; "
                           "give the smith2019_menisci folder or 'fecheck:knee/"
                           "smith2019_menisci'")
    return folder


def femur_pose(folder: Path) -> tuple[float, np.ndarray]:
    """(θy rad, t (3,) mm) of the matrix G of menisci.json, which moves the femur to
    smith2019's default pose: a rotation about y and a translation."""
    g = np.asarray(json.loads((folder / "menisci.json").read_text(encoding="utf-8"))[
        "transform_femur_lenhart2015_rest_to_smith2019_default"]["matrix"], dtype=float)
    theta = math.atan2(g[0, 2], g[0, 0])
    if np.abs(g[:3, :3] - rot_y(theta)).max() > 1e-9:
        raise FecheckError(f"{folder / 'menisci.json'}: the femur's pose G is not a rotation "
                           "about y; the menisci model composes only such a pose")
    return theta, g[:3, 3].copy()


def start_coordinates(scene: Scene, theta_g: float, t_g: np.ndarray) -> np.ndarray:
    """Body coordinates (6,) of the tibia (and of each meniscus on it) at the start: G⁻¹
    composed with the scene's start pose (the femur at G, the tibia at the scene's pose)."""
    q = start_pose(scene)
    t = rot_y(-theta_g) @ (q[:3] - t_g)
    return np.array([t[0], t[1], t[2], 0.0, q[3] - theta_g, q[4]])


def meniscus_stiffness(scene: Scene, youngs_MPa: float | None = None) -> float:
    """EF stiffness of a meniscus interface, N/mm³: the meniscus layer (modulus
    `youngs_MPa`, default menisci.youngs_MPa) and one cartilage layer combined as
    menisci.layers says (module docstring)."""
    men = (scene["menisci.youngs_MPa"] if youngs_MPa is None else youngs_MPa,
           scene["menisci.poisson"], scene["menisci.thickness_mm"])
    cart = (scene["contact.youngs_MPa"], scene["contact.poisson"],
            0.5 * scene["contact.thickness_mm"])
    if scene["menisci.layers"] == "lumped":
        return ef_stiffness(0.5 * (men[0] + cart[0]), 0.5 * (men[1] + cart[1]),
                            men[2] + cart[2])
    return 1.0 / (1.0 / ef_stiffness(*men) + 1.0 / ef_stiffness(*cart))


LUMPED_WARN_CHANGE = 0.25
"""With menisci.layers = 'lumped', a menisci.youngs_MPa at least twice or half the default
that moves the interface stiffness by less than this share of the default's is told that
the modulus barely counts there."""


def _lumped_note(scene: Scene) -> None:
    """Warn when the lumped interface hides a meniscus modulus set far from its default:
    the lumped model averages it with the cartilage's, so it barely moves the share
    (scanned knee decimated to 1,500 faces, 800 N: medial / lateral share 11.1 / 10.1 %
    at 1e-9 MPa, 11.2 / 10.5 % at 1 MPa; 'series' 7.6 / 4.3 % at 1 MPa)."""
    default = SCHEMA["menisci.youngs_MPa"].default
    given = scene["menisci.youngs_MPa"]
    if scene["menisci.layers"] != "lumped" or default / 2 < given < 2 * default:
        return
    k = meniscus_stiffness(scene)
    k0 = meniscus_stiffness(scene, default)
    if abs(k / k0 - 1.0) >= LUMPED_WARN_CHANGE:
        return
    warnings.warn(f"menisci.youngs_MPa = {given:g}: with menisci.layers = 'lumped' the meniscus "
                  f"interface takes the mean of its modulus and the cartilage's "
                  f"({scene['contact.youngs_MPa']:g} MPa), so its stiffness is only "
                  f"{100 * (k / k0 - 1):+.1f} % from the {default:g} MPa default's and the "
                  "share barely moves; set menisci.layers = 'series' for the meniscus's own "
                  "modulus to count", stacklevel=2)


def meniscus_law(scene: Scene):
    """The registry's linear EF for a meniscus interface (`meniscus_stiffness`)."""
    if not spec_of(scene).linear:
        raise FecheckError(f"menisci.dir: the meniscus interfaces use the linear EF; set "
                           f"contact.law = 'ef' (got {scene['contact.law']!r})")
    _lumped_note(scene)
    return linear_law(meniscus_stiffness(scene))


def calibrated_meniscus_law(cal: Calibration):
    """The calibrated law p = C·d·(d + d_s)^(n − 1) of `cal` as a meniscus interface's
    compiled law (`fecheck.laws.calibrated`)."""
    return compiled_law(CALIBRATED, calibrated_params(cal))


def law_text(law) -> str:
    """A meniscus interface's law in words: the linear EF's k, or the calibrated C and n."""
    if law.kind == CALIBRATED:
        return (f"calibrated p = C·d·(d + {law.params[2]:g})^(n−1), C {law.params[0]:.4g} "
                f"MPa/mm^n, n {law.params[1]:.4g} (menisci.calibration)")
    return f"linear EF k = {law.params[0]:.4g} N/mm³"


def meniscus_calibration(scene: Scene) -> dict[str, Calibration] | None:
    """{side: Calibration} of ``menisci.calibration`` (a path relative to the scene file's
    folder; written by `fecheck calibrate` on a scene with menisci), or None where unset.
    Warns when the file was fitted to another knee (`menisci_fingerprint`)."""
    value = scene["menisci.calibration"]
    if not value:
        return None
    path = Path(os.path.expandvars(value)).expanduser()
    if not path.is_absolute():
        path = Path(scene.source).expanduser().resolve().parent / path
    out = read_calibration(path, MENISCI_INTERFACES, "menisci.calibration")
    check_fingerprint(path, menisci_fingerprint(scene), "menisci.calibration")
    return out


def menisci_fingerprint(scene: Scene) -> str:
    """sha256 (hex) of what a meniscus calibration is fitted to: the scene's contact
    surfaces and material (`fecheck.model.fingerprint.scene_fingerprint`) and its
    ``menisci.*`` keys (menisci.calibration aside)."""
    keys = {k: scene[k] for k in SCHEMA
            if k.startswith("menisci.") and k != "menisci.calibration"}
    text = json.dumps([scene_fingerprint(scene), keys], sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def meniscus_laws(scene: Scene, sides: Sequence[str]) -> dict:
    """{side: the law of that meniscus's two interfaces}: the linear EF (`meniscus_law`),
    or with ``menisci.calibration`` the calibrated law of that file's side."""
    linear = meniscus_law(scene)                     # its checks hold either way
    cal = meniscus_calibration(scene)
    if cal is None:
        return dict.fromkeys(sides, linear)
    missing = [s for s in sides if s not in cal]
    if missing:
        raise FecheckError(f"menisci.calibration: {scene['menisci.calibration']} holds no "
                           f"{', '.join(missing)} meniscus; calibrate this scene with "
                           "`fecheck calibrate SCENE -o FILE`")
    return {s: calibrated_meniscus_law(cal[s]) for s in sides}


def _sides(scene: Scene) -> tuple[str, ...]:
    """The menisci present: menisci.sides less menisci.remove."""
    sides = tuple(scene["menisci.sides"])
    unknown = [s for s in sides if s not in COMPARTMENTS]
    if unknown or len(set(sides)) < len(sides):
        raise FecheckError(f"menisci.sides = {list(sides)}: give each of 'medial', 'lateral' "
                           "at most once ([] = no meniscus, the menisci removed)")
    removed = set(scene["menisci.remove"])
    return tuple(s for s in COMPARTMENTS if s in sides and s not in removed)


def present_sides(scene: Scene) -> tuple[str, ...]:
    """The menisci of `scene` that are present (menisci.sides less menisci.remove)."""
    return _sides(scene)


ROOT_GROUPS = {"anterior": "AHORN", "posterior": "PHORN"}
"""Horn → the group of its root bundles in meniscal_ligaments.json."""
BUNDLES_WARNING = ("menisci.roots = 'bundles': the horn roots are smith2019's AHORN / PHORN "
                   "bundles, an EF model's placeholders (6-13 N/mm a bundle, about a hundred "
                   "times softer than the 2000 N/mm a horn of FE knee models)")


def _torn(scene: Scene) -> set[tuple[str, str]]:
    """{(side, horn)} of menisci.torn_roots."""
    return {tuple(name.split("-")) for name in scene["menisci.torn_roots"]}


def _kept(scene: Scene, item: dict) -> bool:
    """Whether the data set's meniscal ligament `item` is modelled (menisci.roots,
    menisci.coronary, menisci.transverse, menisci.torn_roots)."""
    group = item.get("group")
    if group in ROOT_GROUPS.values():
        horn = next(h for h, g in ROOT_GROUPS.items() if g == group)
        return (scene["menisci.roots"] == "bundles"
                and (item["meniscus"], horn) not in _torn(scene))
    if group == "COR":
        return bool(scene["menisci.coronary"])
    return bool(scene["menisci.transverse"])


def root_line(folder: Path, side: str, horn: str) -> tuple[np.ndarray, np.ndarray]:
    """(tibial point, meniscal point) (3,) mm of a horn's root: the means of its root
    bundles' tibial and meniscal points in meniscal_ligaments.json."""
    data = json.loads((folder / "meniscal_ligaments.json").read_text(encoding="utf-8"))
    items = [it for it in data["ligaments"]
             if it.get("meniscus") == side and it.get("group") == ROOT_GROUPS[horn]]
    if not items:
        raise FecheckError(f"{folder / 'meniscal_ligaments.json'}: no root bundle of the "
                           f"{side} {horn} horn; the root spring's direction is read there")
    pts = np.array([it["points_mm"] for it in items], dtype=float)
    return pts[:, 0].mean(axis=0), pts[:, 1].mean(axis=0)


def root_springs(scene: Scene, folder: Path, index: dict[str, int], shapes: dict
                 ) -> list[tuple[str, RootSpring]]:
    """The horn roots as linear springs along their direction (menisci.roots =
    'springs'): one per horn not in menisci.torn_roots, at the horn's meniscal root point
    (moved with the meniscus's shape), unstretched at the start."""
    if scene["menisci.roots"] != "springs":
        return []
    torn, out = _torn(scene), []
    for side, body in index.items():
        for horn in ROOT_GROUPS:
            if (side, horn) in torn:
                continue
            tibial, meniscal = root_line(folder, side, horn)
            point = shapes[side](meniscal[None])[0]
            out.append((f"{side} {horn} root", RootSpring(
                TIBIA, point, body, point.copy(), point - tibial,
                float(scene["menisci.root_N_per_mm"]))))
    return out


def _springs(scene: Scene, folder: Path, index: dict[str, int], shapes: dict
             ) -> list[tuple[str, BodySpring]]:
    """The meniscal ligaments modelled (`_kept`) between bodies present (`index`:
    meniscus side → body), their meniscal points moved with the menisci's shape."""
    data = json.loads((folder / "meniscal_ligaments.json").read_text(encoding="utf-8"))
    bone = {"tibia": TIBIA, **{f"meniscus_{s}": b for s, b in index.items()}}
    out = []
    for item in data["ligaments"]:
        if not all(b in bone for b in item["points_bone"]) or not _kept(scene, item):
            continue                                # on a removed meniscus, or not asked
        p = item["parameters"]
        (a, b), (xa, xb) = item["points_bone"], item["points_mm"]
        xa, xb = (np.asarray(x, dtype=float) for x in (xa, xb))
        xa = shapes[a[len("meniscus_"):]](xa[None])[0] if a in bone and a != "tibia" else xa
        xb = shapes[b[len("meniscus_"):]](xb[None])[0] if b != "tibia" else xb
        out.append((item["name"], BodySpring(
            bone[a], xa, bone[b], xb,
            1000.0 * float(p["slack_length"]["value"]), float(p["linear_stiffness"]["value"]),
            float(p["transition_strain"]["value"]))))
    return out


def read_volume(folder: Path, side: str):
    """The closed volume surface of the `side` meniscus in `folder` (mm)."""
    path = folder / VOLUME.format(side=side)
    volume = read_surface(path)
    if not is_closed(volume):
        raise FecheckError(f"{path}: the {side} meniscus volume is not closed; the "
                           "menisci model needs the data set's watertight volume")
    return volume


@dataclass(frozen=True, eq=False)
class Shape:
    """A meniscus's shape in the scene (`fecheck.model.menisci_shape`): the fit's map
    (None: as shipped), the partial meniscectomy's (None: whole), the shipped closed
    volume and the shaped one; called on points (n, 3) (tibia frame, mm) it moves them."""

    side: str
    fit: FitMap | None
    cut: PartialMap | None
    shipped: TriMesh
    volume: TriMesh

    def __call__(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        if self.fit is not None:
            p = self.fit(p)
        return self.cut(p) if self.cut is not None else p

    def sheet(self, mesh: TriMesh) -> TriMesh:
        """An articular surface (or region) of the meniscus moved with it, less its faces
        in a resected inner third."""
        if self.cut is not None:
            mesh = drop_inner(mesh, self.cut)
        return TriMesh(self(mesh.points), mesh.faces)


def _touching(scene: Scene, folder: Path) -> TriMesh:
    """The femoral sheet in the tibia frame at the touching pose
    (`fecheck.model.menisci_shape.touching_femur`)."""
    rot, t = body_pose(start_coordinates(scene, *femur_pose(folder)))
    femur = femoral_master(scene)
    femur = TriMesh((femur.points - t) @ rot, femur.faces)
    return touching_femur(femur, tibial_slaves(scene), "abduction" in scene.free_dofs)[0]


def shapes(scene: Scene, sides: Sequence[str] | None = None) -> dict[str, Shape]:
    """{side: `Shape`} of the menisci present (or of `sides`): fitted to the joint with
    menisci.fit = 'fitted', the inner third cut with menisci.partial."""
    folder = menisci_dir(scene)
    sides = _sides(scene) if sides is None else tuple(sides)
    fitted = scene["menisci.fit"] == "fitted"
    femur = _touching(scene, folder) if fitted and sides else None
    tibia = tibial_slaves(scene) if fitted else {}
    out = {}
    for side in sides:
        volume = read_volume(folder, side)
        fit = None
        if fitted:
            inf, sup = (read_surface(folder / VOLUME.format(side=f"{side}_{face}"))
                        for face in ("inferior", "superior"))
            fit = fit_fields(volume, inf, sup, tibia[side], femur)
        cut = partial_map(volume) if side in scene["menisci.partial"] else None
        shape = Shape(side, fit, cut, volume, volume)
        out[side] = Shape(side, fit, cut, volume, TriMesh(shape(volume.points), volume.faces))
    return out


def _interfaces(scene: Scene, comps, index: dict[str, int],
                volumes: dict[str, TriMesh]) -> list[Interface]:
    """Cartilage-cartilage interfaces (one per compartment), then per meniscus its
    interfaces with the femoral and with the tibial cartilage under that meniscus's law
    (`meniscus_laws`): the cartilage sheet is the slave, the meniscus's closed volume the
    master (module docstring)."""

    out = [Interface(c.name, c.pair, c.law, TIBIA, FEMUR) for c in comps]
    laws = meniscus_laws(scene, tuple(index))
    femur, tibia = femoral_master(scene), tibial_slaves(scene)
    opts = {"method": scene["contact.detection"], "area": scene["contact.area"],
            "margin_mm": scene["contact.margin_mm"], "mesh_sign": "winding"}
    for side, body in index.items():
        volume = volumes[side]
        out.append(Interface(f"{side} femur-meniscus", ContactPair(femur, volume, **opts),
                             laws[side], FEMUR, body))
        out.append(Interface(f"{side} meniscus-tibia",
                             ContactPair(tibia[side], volume, **opts), laws[side], TIBIA, body))
    return out


def _check(scene: Scene) -> None:
    if scene["model.kind"] != "femur-tibia":
        raise FecheckError(f"menisci.dir needs model.kind = 'femur-tibia' (got "
                           f"{scene['model.kind']!r})")
    if scene["scanned.ligaments"] != "none" or scene["ligaments.model"] != "none":
        raise FecheckError("menisci.dir: ligaments other than the meniscal ones are not "
                           "modelled with the menisci yet; set scanned.ligaments = 'none' "
                           "and ligaments.model = 'none'")
    if scene["dofs.flexion_deg"] != 0.0 or scene["constraints.equal_forces"]:
        raise FecheckError("menisci.dir: the knee with menisci is modelled at full "
                           "extension without constraints; set dofs.flexion_deg = 0 and "
                           "constraints.equal_forces = false")


def balance(problem: Problem, q: Sequence[np.ndarray]) -> dict[str, float]:
    """{body: largest |generalised force| on its free coordinates (N; moments over
    `Problem.length_scale_mm`)} at coordinates `q`: zero at an equilibrium."""
    poses = [body_pose(qb) for qb in q]
    w = [np.zeros(6) for _ in q]
    for bodies, wp, _ in problem.wrench(poses):
        for i, b in enumerate(bodies):
            w[b] += wp[6 * i:6 * i + 6]
    out = {}
    for b, body in enumerate(problem.bodies):
        if body.free:
            gen = body_basis(q[b]).T @ w[b]
            scale = np.where(np.arange(6) >= 3, 1.0 / problem.length_scale_mm, 1.0)
            out[body.name] = float(np.abs((gen * scale)[list(body.free)]).max())
    return out


@dataclass(frozen=True, eq=False)
class MenisciKnee:
    """The knee with menisci built once (`build_knee`): the bodies at their start, the
    contact interfaces, the meniscal springs by name, the cartilage compartments, the
    menisci present and their `Shape`. `with_laws` and `with_start` give the same knee
    under other meniscus laws or from other start coordinates without rebuilding it."""

    bodies: tuple[Body, ...]
    interfaces: tuple[Interface, ...]
    springs: dict
    comps: list
    sides: tuple[str, ...]
    shapes: dict[str, Shape]

    def with_laws(self, laws: dict) -> MenisciKnee:
        """The same knee with each meniscus's two interfaces under `laws[side]` (their
        contact pairs reused)."""
        names = {f"{s} {kind}": s for s in laws for kind in ("femur-meniscus",
                                                             "meniscus-tibia")}
        return replace(self, interfaces=tuple(
            Interface(i.name, i.pair, laws[names[i.name]], i.slave, i.master)
            if i.name in names else i for i in self.interfaces))

    def with_start(self, q: Sequence[np.ndarray]) -> MenisciKnee:
        """The same knee starting from the coordinates `q` (one (6,) per body)."""
        return replace(self, bodies=tuple(replace(b, q_start=np.asarray(qb, dtype=float))
                                          for b, qb in zip(self.bodies, q, strict=True)))


def build_knee(scene: Scene) -> MenisciKnee:
    """The knee of `scene` with its menisci (`MenisciKnee`; module docstring)."""
    from fecheck.model.scanned import build_compartments

    _check(scene)
    folder = menisci_dir(scene)
    sides = _sides(scene)
    theta_g, t_g = femur_pose(folder)
    comps = build_compartments(scene)
    before_solve(scene, comps)
    q0 = start_coordinates(scene, theta_g, t_g)
    index = {s: 2 + i for i, s in enumerate(sides)}
    free = tuple(i for i, d in enumerate(BODY_DOFS) if d in scene["menisci.free"])
    if sides and "z" not in scene["menisci.free"]:
        warnings.warn(f"menisci.free = {list(scene['menisci.free'])} holds each meniscus's z "
                      "where it starts, fixed to the femur while the tibia moves: it props "
                      "the joint, so its meniscal share is a prop's (up to 100 %), not a "
                      "meniscus's; free 'z' at least (the default frees all six)",
                      stacklevel=2)
    bodies = (Body("femur", np.zeros(6), ()),
              Body("tibia", q0, tibia_body(q0[list(TIBIA_COORDINATES)],
                                           free_indices(scene)).free),
              *(Body(f"{s} meniscus", q0.copy(), free, "menisci.free", "the tibia's start")
                for s in sides))
    shaped = shapes(scene, sides)
    interfaces = _interfaces(scene, comps, index, {s: m.volume for s, m in shaped.items()})
    if scene["menisci.roots"] == "bundles" and sides:
        warnings.warn(BUNDLES_WARNING, stacklevel=2)
    springs = dict(_springs(scene, folder, index, shaped)
                   + root_springs(scene, folder, index, shaped))
    return MenisciKnee(bodies, tuple(interfaces), springs, comps, sides, shaped)


def knee_problem(scene: Scene, knee: MenisciKnee) -> Problem:
    """The equilibrium `Problem` of `knee` under `scene`'s load and solver settings."""
    interfaces, springs = knee.interfaces, list(knee.springs.values())
    load = on_body(lambda r, t: [applied_load(scene)(r, t)], TIBIA)

    def wrench(poses):
        return [i(poses) for i in interfaces] + [s(poses) for s in springs] + load(poses)

    return Problem(knee.bodies, wrench, (), force_scale(scene),
                   tolerance=scene["solver.tolerance"],
                   max_iterations=scene["solver.max_iterations"],
                   touching=lambda: any(i.max_depth_mm > 0 for i in interfaces))


def build_problem(scene: Scene):
    """(problem, interfaces, springs {name: spring}, compartments, sides, shapes {side:
    `Shape`}): the knee with the scene's menisci as a `Problem`."""
    knee = build_knee(scene)
    return (knee_problem(scene, knee), list(knee.interfaces), knee.springs, knee.comps,
            knee.sides, knee.shapes)


def footprint_outline(volume, rot: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(k, 2, 3) world segments (mm) of the edge of a closed meniscus volume's footprint
    at pose x = R p + t: the edges that bound its downward-facing faces (world n_z < 0),
    whose x-y projection covers the footprint; loops shorter than a tenth of the longest
    (small folds where a wall's faces turn over) are left out."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pts = volume.points @ np.asarray(rot).T + t
    tri = pts[volume.faces]
    down = volume.faces[np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])[:, 2] < 0.0]
    edges = np.sort(np.concatenate([down[:, [0, 1]], down[:, [1, 2]], down[:, [2, 0]]]),
                    axis=1)
    unique, count = np.unique(edges, axis=0, return_counts=True)
    edge = unique[count == 1]
    n = len(pts)
    graph = coo_matrix((np.ones(len(edge)), (edge[:, 0], edge[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    length = np.linalg.norm(pts[edge[:, 0], :2] - pts[edge[:, 1], :2], axis=1)
    loop = np.bincount(label[edge[:, 0]], weights=length, minlength=n)
    return pts[edge[loop[label[edge[:, 0]]] >= 0.1 * loop.max()]]


def _maps(interfaces: Sequence[Interface], poses, volumes: dict) -> dict[str, dict]:
    """Per meniscus side (`volumes`: side → its closed volume): its pressure on the tibial
    faces, the edge of its footprint, and its contact area and peak pressure on the tibia
    (`RunResult.meniscus_maps`)."""
    by_name = {i.name: i for i in interfaces}
    out = {}
    for side, volume in volumes.items():
        down = by_name[f"{side} meniscus-tibia"]
        res = down.law(down.pair.evaluate(poses[down.slave], poses[down.master]))
        out[side] = {"pressure_MPa": res.face_pressure(), "area_mm2": float(res.area),
                     "max_pressure_MPa": float(res.max_pressure),
                     "outline": footprint_outline(volume, *poses[down.master])}
    return out


def spring_on_tibia(spring, poses) -> np.ndarray:
    """(3,) force (N, world) of a meniscal spring (`RootSpring` or `BodySpring`) on the
    tibia (zero for one that does not end on the tibia)."""
    if isinstance(spring, RootSpring):
        return -spring.force(poses)
    x_a, x_b = spring.ends(poses)
    if TIBIA not in (spring.body_a, spring.body_b) or np.allclose(x_a, x_b):
        return np.zeros(3)
    pull = spring.tension(poses) * (x_b - x_a) / np.linalg.norm(x_b - x_a)   # on end a
    return pull if spring.body_a == TIBIA else -pull


def _meniscus_of(spring, index: dict[str, int]) -> str | None:
    body = spring.meniscus if isinstance(spring, RootSpring) else (
        spring.body_b if spring.body_a == TIBIA else
        spring.body_a if spring.body_b == TIBIA else None)
    return next((s for s, b in index.items() if b == body), None)


def _shares(interfaces: Sequence[Interface], poses, sides, springs: dict | None = None
            ) -> dict[str, dict[str, float]]:
    """Per compartment: axial load into the tibia through cartilage and meniscus (N, +
    compressive; the meniscus's: its tibial contact plus its springs to the tibia,
    `springs`), the meniscal share, the femur's load on the meniscus, the depths."""
    rot = poses[TIBIA][0]
    by_name = {i.name: i for i in interfaces}
    index = {s: 2 + i for i, s in enumerate(sides)}
    through = dict.fromkeys(sides, 0.0)
    for spring in (springs or {}).values():
        side = _meniscus_of(spring, index)
        if side is not None:
            through[side] += axial_force(spring_on_tibia(spring, poses), rot)
    out = {}
    for c in COMPARTMENTS:
        cart = by_name[c]
        row = {"cartilage_N": axial_force(cart.wrench_on_slave(poses)[:3], rot),
               "cartilage_max_depth_mm": cart.max_depth_mm, "meniscus_N": 0.0,
               "femur_on_meniscus_N": 0.0}
        if c in sides:
            down, up = by_name[f"{c} meniscus-tibia"], by_name[f"{c} femur-meniscus"]
            row["meniscus_contact_N"] = axial_force(down.wrench_on_slave(poses)[:3], rot)
            row["meniscus_springs_N"] = through[c]
            row["meniscus_N"] = row["meniscus_contact_N"] + through[c]
            row["meniscus_tibia_max_depth_mm"] = down.max_depth_mm
            row["femur_on_meniscus_N"] = -axial_force(up.wrench_on_slave(poses)[:3], rot)
            row["femur_meniscus_max_depth_mm"] = up.max_depth_mm
        total = row["cartilage_N"] + row["meniscus_N"]
        row["meniscal_share"] = row["meniscus_N"] / total if total > 0 else math.nan
        out[c] = row
    return out


def pose_record(q: np.ndarray) -> dict[str, list[float]]:
    """A body's solved coordinates (6,) for the result: ``q`` as solved (x y z mm, θx θy
    θz rad), and the same as ``translation_mm`` and ``rotation_deg``."""
    q = [float(v) for v in q]
    return {"q": q, "translation_mm": q[:3], "rotation_deg": [math.degrees(v) for v in q[3:]]}


NO_HEADWAY = 0.5
"""A solve that stops with its residual above this share of the load made no headway
toward a balance: no equilibrium carries that load (not an iteration budget)."""


def _refuse_no_headway(scene: Scene, sol) -> None:
    """`FecheckError` when the solve stopped with the load still unbalanced (residual above
    `NO_HEADWAY` of it): more iterations would not help; say the likely cause."""
    load = max(scene["load.force_N"], 1e-300)
    if sol.converged or sol.residual_norm < NO_HEADWAY * load:
        return
    raise FecheckError(f"no equilibrium with the menisci: after {sol.iterations} iterations "
                       f"{sol.residual_norm:.3g} N of the {scene['load.force_N']:.4g} N load "
                       "is still unbalanced (no headway, so more iterations will not help): "
                       "the contact cannot carry that load (a knee's load is 10 N-10 kN: "
                       "check load.force_N and its unit) or the start pose is far from "
                       "contact (dofs.*, solver.start_gap_mm)")


STIFF_RATIO = 10.0
"""A meniscus this many times stiffer than the cartilage (menisci.youngs_MPa over
contact.youngs_MPa) gets the stiffness note on a DOF nothing resists: on the scanned knee
(decimated to 1,500 faces, cartilage 20 MPa) 1,000 MPa solved and 10,000 MPa did not."""


def _stiff_note(scene: Scene) -> str:
    """Why a meniscus DOF may have no stiffness when the meniscus is much stiffer than the
    cartilage, for the end of that error ("" otherwise)."""
    ratio = scene["menisci.youngs_MPa"] / scene["contact.youngs_MPa"]
    if ratio < STIFF_RATIO:
        return ""
    return (f"; here menisci.youngs_MPa = {scene['menisci.youngs_MPa']:g} is {ratio:.3g} "
            "times contact.youngs_MPa: so stiff a meniscus sinks too little into the "
            "cartilage to touch on more than a few faces, which do not hold it: lower "
            "menisci.youngs_MPa (smith2019's EF uses 1 MPa)")


def run_menisci(scene: Scene, warm_start: np.ndarray | None = None) -> RunResult:
    """Solve a femur-tibia scene with its menisci (module docstring). `warm_start` is not
    taken (the menisci have their own coordinates)."""
    t_start = time.perf_counter()
    return solve_knee(scene, build_knee(scene), t_start)


def solve_knee(scene: Scene, knee: MenisciKnee, t_start: float | None = None) -> RunResult:
    """Solve the knee `knee` (`build_knee`) under `scene`'s load (`run_menisci`);
    `t_start`: the `time.perf_counter()` its build began at (None: now)."""
    t_built = time.perf_counter()
    t_start = t_built if t_start is None else t_start
    problem = knee_problem(scene, knee)
    interfaces, springs, comps, sides, shaped = (knee.interfaces, knee.springs, knee.comps,
                                                 knee.sides, knee.shapes)
    try:
        sol = solve(problem)
    except NoStiffness as err:
        raise FecheckError(f"{err}{_stiff_note(scene)}") from None
    except NoEquilibrium as err:
        force = scene["load.force_N"]
        hint = no_equilibrium_hint(scene) or (load_warning(force) if force > 0 else "")
        raise FecheckError(f"{err}; {hint}" if hint else str(err)) from None
    seconds = time.perf_counter() - t_built
    _refuse_no_headway(scene, sol)
    poses = [body_pose(q) for q in sol.q]
    rot, t = poses[TIBIA]
    compartments = {}
    for comp in comps:
        res, w, _ = comp.evaluate(rot, t)
        compartments[comp.name] = compartment_result(comp, res, w, rot, t)
    maps = _maps(interfaces, poses, {s: m.volume for s, m in shaped.items()})
    shares = _shares(interfaces, poses, sides, springs)
    for side, m in maps.items():
        shares[side]["meniscus_tibia_area_mm2"] = m["area_mm2"]
        shares[side]["meniscus_tibia_max_pressure_MPa"] = m["max_pressure_MPa"]
    menisci = {"compartments": shares,
               "balance_N": balance(problem, sol.q),
               "poses": {b.name: pose_record(q)
                         for b, q in zip(problem.bodies, sol.q, strict=True) if b.free},
               "ligaments_N": {n: s.tension(poses) for n, s in springs.items()},
               "laws": {s: law_text(i.law) for i in interfaces for s in sides
                        if i.name == f"{s} meniscus-tibia"}}
    q_tibia = sol.q[TIBIA][list(TIBIA_COORDINATES)]
    record = SolveRecord(0, {i.name: i.pair.slave.n_faces for i in interfaces},
                         {i.name: i.pair.describe() for i in interfaces}, tuple(sol.history))
    timing = {"total": time.perf_counter() - t_start, "build": t_built - t_start,
              "solve": seconds}
    return RunResult(scene.label, scene["model.kind"], scene["contact.law"],
                     sol.converged, sol.iterations, sol.residual_norm,
                     Pose.of(q_tibia, side=scene.side),
                     compartments, {}, timing, {}, tuple(not_converged_note(sol)), record,
                     menisci, {s: {k: m[k] for k in ("pressure_MPa", "outline")}
                               for s, m in maps.items()},
                     {b.name: np.array(q, dtype=float)
                      for b, q in zip(problem.bodies, sol.q, strict=True) if b.free})
