"""Which scene keys have no effect in a scene's configuration, and why.

A key is inert when no verb (``run``, ``sweep``, ``fe``) reads it for the scene's model,
law, plateau and options: ``mesh.sphere_subdivisions`` when the condyles are exact
spheres, ``scanned.*`` on a sphere-plane scene, spring stiffnesses without springs. The
rules mirror how `fecheck.model` and `fecheck.fe` read each key, in one table (`rules`;
the law keys' rules from the declared laws, `fecheck.scene.law_keys`);
`load_scene` warns (`InertKeyWarning`) for the inert keys a user gave.

>>> from fecheck.scene.load import load_scene
>>> scene = load_scene()
>>> inert_keys(scene, ["mesh.sphere_subdivisions", "contact.poisson"])[0][0]
'mesh.sphere_subdivisions'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import Any, Protocol

from fecheck.scene.constants import COMPARTMENTS, LIGAMENTS
from fecheck.scene.knee import PRESETS
from fecheck.scene.law_keys import LAWS, readers

MESH_DETECTION = ("bvh", "ray-parity", "fcl")
"""Detection methods that need a mesh master: the analytic surface is meshed instead."""

SCANNED_KINDS = ("sphere-tibia", "femur-tibia")
"""Model kinds that read the scanned tibial cartilage."""


class InertKeyWarning(UserWarning):
    """A scene key the user gave has no effect in the scene's configuration."""


class SceneValues(Protocol):
    """A `Scene`, or any mapping of every dotted scene key to its value."""

    def __getitem__(self, key: str) -> Any: ...


Reason = Callable[[SceneValues], "str | None"]
"""A rule's test: the scene → why its keys have no effect there, or None if they do."""


def hertz_point_contact(scene: SceneValues) -> bool:
    """Whether a sphere-plane scene uses the closed-form point contact (a law with a
    point-contact form, `LawKeys.point_contact`: Hertz; plane plateaus, analytic
    detection, clipped areas): no mesh enters its solve."""
    return (LAWS[scene["contact.law"]].point_contact
            and scene["plateau.kind"] in ("transverse", "inclined")
            and scene["contact.detection"] not in MESH_DETECTION
            and scene["contact.area"] == "clipped")


_HERTZ_POINT = ("the Hertz law on plane plateaus with analytic detection and clipped areas "
                "is the closed-form sphere-plane point contact")


def _rigid(scene: SceneValues) -> str | None:
    if scene["model.kind"] == "rigid":
        return ("model.kind = 'rigid' has point contacts solved directly: no contact law, "
                "mesh or Newton iteration")
    return None


def _condyle_not_meshed(scene: SceneValues) -> str | None:
    kind = scene["model.kind"]
    if kind == "sphere-plane":
        if hertz_point_contact(scene):
            return _HERTZ_POINT + " (no condyle mesh)"
        if (scene["contact.master"] == "condyle"
                and scene["contact.detection"] not in MESH_DETECTION):
            return ("contact.master = 'condyle' with analytic detection meshes only the "
                    "plateau; the condyle is an exact sphere")
        return None
    if kind == "sphere-tibia" and scene["scanned.condyle"] == "sphere":
        return "scanned.condyle = 'sphere' makes the condyles exact spheres"
    if kind == "femur-tibia":
        return "model.kind = 'femur-tibia' contacts the scanned femoral cartilage, not spheres"
    return None


def _plateau_not_meshed(scene: SceneValues) -> str | None:
    kind = scene["model.kind"]
    if kind in SCANNED_KINDS:
        return f"model.kind = '{kind}' contacts the scanned tibial cartilage (no plateau disc)"
    if kind == "sphere-plane" and not hertz_point_contact(scene) \
            and scene["contact.master"] == "plateau":
        return ("contact.master = 'plateau' keeps the plateau analytic (a box for mesh "
                "detection); only the condyle is meshed")
    return None


def _master_fixed(scene: SceneValues) -> str | None:
    kind = scene["model.kind"]
    if kind in SCANNED_KINDS:
        return f"model.kind = '{kind}' always takes the scanned tibial cartilage as the mesh"
    if kind == "sphere-plane" and hertz_point_contact(scene):
        return _HERTZ_POINT
    return None


def _no_margin(scene: SceneValues) -> str | None:
    if scene["model.kind"] == "sphere-plane" and hertz_point_contact(scene):
        return _HERTZ_POINT + " (no broad phase)"
    return None


def _law_does_not_read(key: str) -> Reason:
    def reason(scene: SceneValues) -> str | None:
        law = scene["contact.law"]
        if key in LAWS[law].keys:
            return None
        titles = [r.title for r in readers(key)]
        which = (f"the {titles[0]} law reads" if len(titles) == 1
                 else f"the {', '.join(titles[:-1])} and {titles[-1]} laws read")
        return f"contact.law = '{law}' (only {which} it)"

    return reason


def law_rules() -> tuple[tuple[tuple[str, ...], Reason], ...]:
    """One rule per key that some declared law reads (`fecheck.scene.law_keys`): inert
    under a law that does not read it (the femoral layer's keys: `_one_layer`, the
    two-layer FE reads them whatever the law)."""
    keys = dict.fromkeys(k for law in LAWS.values() for k in law.keys if k not in _LAYER_KEYS)
    return tuple(((k,), _law_does_not_read(k)) for k in keys)


def _rigid_indenter(scene: SceneValues) -> str | None:
    if math.isinf(scene["contact.indenter_youngs_MPa"]):
        return "contact.indenter_youngs_MPa = inf makes the indenter rigid"
    return None


def _plateau_is_not(kind: str, what: str) -> Reason:
    def reason(scene: SceneValues) -> str | None:
        if scene["plateau.kind"] != kind:
            return (f"plateau.kind = '{scene['plateau.kind']}' (only {kind} plateaus read "
                    f"{what})")
        return None

    return reason


def _preset_knee(scene: SceneValues) -> str | None:
    if scene["knee.preset"] == "fit":
        return "knee.preset = 'fit' fits the condyle spheres to the femoral surface"
    if scene["knee.preset"] != "custom":
        return (f"knee.preset = '{scene['knee.preset']}' gives the landmarks; side and "
                f"landmarks are read only for knee.preset = 'custom' or 'fit'")
    return None


def _side_from_preset(scene: SceneValues) -> str | None:
    if scene["knee.preset"] == "fit":
        return None
    if scene["model.kind"] == "femur-tibia" and scene["ligaments.model"] == "none":
        return None                    # no landmark read: the side names the compartments
    preset = PRESETS.get(scene["knee.preset"])
    if preset is not None and preset.side != scene["knee.side"]:
        return (f"knee.preset = '{scene['knee.preset']}' is a {preset.side} knee and gives "
                f"its own landmarks (for a {scene['knee.side']} knee: knee.preset = 'custom' "
                "with knee.landmarks)")
    return _preset_knee(scene)


def _no_springs(scene: SceneValues) -> str | None:
    if scene["ligaments.model"] != "spring":
        return (f"ligaments.model = '{scene['ligaments.model']}' (only spring ligaments have "
                f"a stiffness and a strain)")
    return None


def _no_gravity(scene: SceneValues) -> str | None:
    if not scene["gravity"]:
        return "gravity = false: the tibia's weight is not applied"
    return None


def _no_scanned_tibia(scene: SceneValues) -> str | None:
    if scene["model.kind"] not in SCANNED_KINDS:
        return (f"model.kind = '{scene['model.kind']}' reads no tibial surface file (only "
                f"sphere-tibia and femur-tibia do)")
    return None


def _no_tibia_solid(scene: SceneValues) -> str | None:
    if not scene["geometry.tibia_solid"]:
        return "no geometry.tibia_solid: the FE extrudes the sheet into a bonded layer"
    if scene["fe.body"] == "layer":
        return "fe.body = 'layer' extrudes the sheet into a bonded layer"
    return _no_scanned_tibia(scene)


def _not_sphere_tibia(scene: SceneValues) -> str | None:
    if scene["model.kind"] != "sphere-tibia":
        return (f"model.kind = '{scene['model.kind']}' (only sphere-tibia has condyle spheres "
                f"on the scanned tibia)")
    return None


def _no_hemisphere(scene: SceneValues) -> str | None:
    if scene["model.kind"] == "sphere-tibia" and scene["scanned.condyle"] != "hemisphere":
        return "scanned.condyle = 'sphere' (only hemispheres are cut)"
    return _not_sphere_tibia(scene)


def _no_files(scene: SceneValues) -> str | None:
    if scene["model.kind"] not in SCANNED_KINDS and scene["scanned.ligaments"] == "none":
        return (f"model.kind = '{scene['model.kind']}' with scanned.ligaments = 'none' reads "
                f"no file")
    return None


def _no_femur_file(scene: SceneValues) -> str | None:
    kind = scene["model.kind"]
    if kind == "sphere-tibia" and scene["scanned.thickness"] == "bone-distance":
        return None                          # the femoral cartilage's own thickness
    if kind != "femur-tibia":
        return (f"model.kind = '{kind}' reads no femoral surface (only femur-tibia does, "
                "and sphere-tibia for scanned.thickness = 'bone-distance')")
    return None


def _no_split(scene: SceneValues) -> str | None:
    if scene["geometry.tibia_lateral"]:
        return "geometry.tibia_lateral is given: each compartment has its own file"
    return _no_scanned_tibia(scene)


def _not_sagittal(scene: SceneValues) -> str | None:
    if scene["geometry.tibia_split"] != "sagittal":
        return f"geometry.tibia_split = '{scene['geometry.tibia_split']}'"
    return _no_split(scene)


def _no_bones(scene: SceneValues) -> str | None:
    if scene["scanned.thickness"] != "bone-distance":
        return "scanned.thickness = 'uniform' reads no bone"
    return _no_scanned_tibia(scene)


def _no_bundle_file(scene: SceneValues) -> str | None:
    if scene["scanned.ligaments"] != "bundles":
        return "scanned.ligaments = 'none' reads no bundle file"
    return None


def _no_axisymmetric(scene: SceneValues) -> str | None:
    if scene["model.kind"] != "sphere-plane":
        return (f"model.kind = '{scene['model.kind']}': the axisymmetric FE reference of "
                "`fecheck fe` runs only for condyle spheres on flat (transverse) layers")
    if scene["plateau.kind"] != "transverse":
        return (f"plateau.kind = '{scene['plateau.kind']}': the axisymmetric FE reference of "
                f"`fecheck fe` runs only for flat (transverse) layers")
    return None


def _one_layer(scene: SceneValues) -> str | None:
    law = scene["contact.law"]
    if set(_LAYER_KEYS) <= set(LAWS[law].keys) or scene["fe.cartilage"] == "two-layer":
        return None
    titles = " and ".join(r.title for r in readers(_LAYER_KEYS[0]))
    return (f"contact.law = '{law}' with fe.cartilage = 'series' reads one cartilage layer "
            f"(only the {titles} law and the two-layer FE read the femoral one apart)")


def _no_wrapped_bundles(scene: SceneValues) -> str | None:
    if scene["scanned.ligaments"] != "bundles" and not scene["patella.dir"]:
        return ("scanned.ligaments = 'none' and patella.dir = '': no ligament bundle has a "
                "wrap object")
    return None


def _no_patella(scene: SceneValues) -> str | None:
    if not scene["patella.dir"]:
        return "patella.dir = '': no patella"
    return None


def _no_menisci(scene: SceneValues) -> str | None:
    if not scene["menisci.dir"]:
        return "menisci.dir = '': no menisci"
    return None


def _no_prepare(scene: SceneValues) -> str | None:
    if scene["fe.prepare"] == "off":
        return "fe.prepare = 'off': `fecheck fe` meshes the EF run's own faces, unprepared"
    return None


_MESH_KEYS = ("mesh.sphere_subdivisions", "mesh.method", "mesh.plateau_radius_mm",
              "mesh.plateau_size_mm", "mesh.plateau_refine_mm", "mesh.plateau_refine_radius_mm")
_PLATEAU_MESH_KEYS = _MESH_KEYS[2:]
_CONTACT_KEYS = ("contact.law", "contact.area", "contact.master", "contact.detection",
                 "contact.margin_mm", "contact.volumetric_stiffness_N_per_mm3",
                 "contact.indenter_youngs_MPa", "contact.indenter_poisson")
_LAYER_KEYS = ("contact.femoral_share", "contact.femoral_youngs_MPa", "contact.femoral_poisson")
_SOLVER_KEYS = ("solver.start_gap_mm", "solver.max_iterations", "solver.tolerance")
_MENISCI_KEYS = tuple(f"menisci.{k}" for k in (
    "sides", "remove", "torn_roots", "partial", "roots", "root_N_per_mm", "coronary",
    "transverse", "fit", "free", "youngs_MPa", "poisson", "thickness_mm", "layers",
    "calibration"))
_SPRING_KEYS = ("ligaments.transition_strain",) + tuple(
    f"ligaments.{n}.{p}" for n in LIGAMENTS for p in ("stiffness_N", "reference_strain"))

_LEADING_RULES: tuple[tuple[tuple[str, ...], Reason], ...] = (
    (_MESH_KEYS + _CONTACT_KEYS + _SOLVER_KEYS + _LAYER_KEYS, _rigid),
    (("mesh.sphere_subdivisions", "mesh.method"), _condyle_not_meshed),
    (_PLATEAU_MESH_KEYS, _plateau_not_meshed),
    (("contact.master",), _master_fixed),
    (("contact.margin_mm",), _no_margin),
)
"""The rules that come before the laws' (`law_rules`)."""

RULES: tuple[tuple[tuple[str, ...], Reason], ...] = (
    (("contact.indenter_poisson",), _rigid_indenter),
    (tuple(f"plateau.{c}_angles_deg" for c in COMPARTMENTS),
     _plateau_is_not("inclined", "slope angles")),
    (tuple(f"plateau.{c}_coefficients" for c in COMPARTMENTS),
     _plateau_is_not("polynomial", "coefficients")),
    (("knee.side",), _side_from_preset),
    (("knee.landmarks",), _preset_knee),
    (_SPRING_KEYS, _no_springs),
    (("tibia.mass_kg", "tibia.com_mm"), _no_gravity),
    (("scanned.thickness", "scanned.decimate_faces"), _no_scanned_tibia),
    (("scanned.condyle",), _not_sphere_tibia),
    (("scanned.hemisphere_cut_mm",), _no_hemisphere),
    (("geometry.dir",), _no_files),
    (("geometry.femur",), _no_femur_file),
    (("geometry.split_x_mm",), _not_sagittal),
    (("geometry.tibia_split",), _no_split),
    (("geometry.tibia", "geometry.tibia_lateral", "geometry.units", "geometry.rotation_deg",
      "geometry.translation_mm", "geometry.smooth_mm", "geometry.tibia_solid"),
     _no_scanned_tibia),
    (("fe.solid_base_deg",), _no_tibia_solid),
    (("geometry.femur_bone", "geometry.tibia_bone"), _no_bones),
    (("geometry.ligaments", "scanned.ligament_stiffness_scale",
      "scanned.ligament_slack_scale"), _no_bundle_file),
    (("scanned.thickness_scale",), _no_bones),
    (("fe.axisym_size_mm",), _no_axisymmetric),
    (("fe.size_mm", "fe.smooth_mm", "fe.terraces"), _no_prepare),
    (("patella.quadriceps_N",), _no_patella),
    (("ligaments.wrap",), _no_wrapped_bundles),
    (_MENISCI_KEYS, _no_menisci),
    (_LAYER_KEYS, _one_layer),
)
"""(keys, reason): the keys have no effect in a scene where ``reason(scene)`` is not None.
The first rule that applies to a key gives its reason (`rules`: `_LEADING_RULES`, then the
laws' rules, then these)."""


def rules() -> tuple[tuple[tuple[str, ...], Reason], ...]:
    """Every rule, in order: `_LEADING_RULES`, `law_rules` (from the declared laws), `RULES`."""
    return _LEADING_RULES + law_rules() + RULES


def inert_keys(scene: SceneValues, given_keys: Iterable[str]) -> list[tuple[str, str]]:
    """(key, reason) for each of `given_keys` that has no effect in `scene`, in the order
    given (each key once)."""
    out = []
    for key in dict.fromkeys(given_keys):
        for keys, reason in rules():
            why = reason(scene) if key in keys else None
            if why:
                out.append((key, why))
                break
    return out


def inert_message(key: str, reason: str) -> str:
    """The one-line warning for an inert key."""
    return f"{key} has no effect: {reason}"
