"""Unit hints on a scene's inputs: a material or load outside the range a knee lives in.

A value outside the range of a knee (cartilage E ~0.1-100 MPa, loads of 10 N-10 kN, with
or without gravity) is most often a unit typed wrong: `input_warnings` names the likely
mistake. A modulus or volumetric stiffness no unit slip explains, and a zero load that
nothing balances, make the solve meaningless: `input_errors`. Each rule reads only the
scene's keys and returns its one-line message ("" when the value is plausible); the model
raises or warns with them before its solve (`fecheck.model.plausibility.before_solve`).
Units mm, N, MPa.
"""

from __future__ import annotations

import math

import numpy as np

from fecheck.scene import Scene
from fecheck.scene.constants import GRAVITY_MPS2
from fecheck.scene.law_keys import LAWS

CARTILAGE_E_MPA = (0.1, 100.0)
"""Young's modulus of articular cartilage, MPa: ~0.1-1 MPa (equilibrium, soft, OA) to
~10-100 MPa (instantaneous, impact). Below the range: a value in GPa typed as MPa."""

IMPLANT_E_MPA = 5000.0
"""Stiffest plausible bearing material without an implant key in the scene, MPa: UHMWPE
is ~460-1000 MPa, PEEK ~3600 MPa. Above it the modulus is no knee material: a warning,
"kPa typed as MPa?" (an error from `ABSURD_E_MPA`: cartilage's 2e7 Pa typed as MPa)."""

ABSURD_E_MPA = (1e-4, 1e6)
"""Young's moduli no unit slip of a knee material explains, MPa: below 1e-4 MPa (100 Pa)
even cartilage's 0.1 MPa read as GPa, at or above 1e6 MPa (1 TPa, stiffer than diamond)
cartilage's 2e7 Pa typed as MPa. Outside this the solve means nothing: an error."""

INDENTER_E_MPA = 5e5
"""Stiffest plausible indenting condyle (the Hertz law's contact.indenter_youngs_MPa),
MPa: CoCr ~210 GPa, alumina and zirconia ceramics ~200-400 GPa."""

KNEE_LOAD_N = (10.0, 10000.0)
"""External knee loads, N: a limb's own weight (tens of N) to the tibiofemoral peaks of
running and landing (~4-8 body weights, under ~7 kN). Below the range: kN typed as N;
above it: mN typed as N (a warning, whatever the gravity)."""

ABSURD_VOLUMETRIC_N_PER_MM3 = 1e5
"""A volumetric stiffness (N/mm³) at or above this presses 1e5 MPa at 1 mm depth: the
thesis's 1e7 N/m³ typed as N/mm³ (it is 1e-2 N/mm³). An error."""


def tibia_weight_N(scene: Scene) -> float:
    """The tibia's weight as the scene applies it, N (0 without gravity)."""
    return scene["tibia.mass_kg"] * GRAVITY_MPS2 * scene["gravity"]


def upward_load_N(scene: Scene) -> float:
    """The external load's component along +z (towards the femur), N."""
    d = np.asarray(scene["load.direction"], dtype=float)
    norm = float(np.linalg.norm(d))
    return scene["load.force_N"] * d[2] / norm if norm > 0 else 0.0


def has_ligaments(scene: Scene) -> bool:
    """Whether ligaments (the three rods or springs, or the scanned knee's bundles) can
    hold the tibia on the femur without an external load."""
    return scene["ligaments.model"] != "none" or scene["scanned.ligaments"] != "none"


def load_hint(scene: Scene) -> str:
    """Why no equilibrium can exist when the load does not lift the tibia's weight
    (kN typed as N?) and neither a ligament nor a driven z holds the tibia; "" when it
    does or nothing weighs."""
    weight, up = tibia_weight_N(scene), upward_load_N(scene)
    if weight <= 0 or up >= weight or has_ligaments(scene) or "z" not in scene.free_dofs:
        return ""
    return (f"the load presses the tibia up with {up:.4g} N, less than the tibia's weight "
            f"{weight:.4g} N (tibia.mass_kg · g): nothing holds the tibia on the femur "
            f"(load.force_N = {scene['load.force_N']:g}: kN typed as N? knee loads are "
            "hundreds of N)")


def no_equilibrium_hint(scene: Scene) -> str:
    """What the load says about a solve that found no equilibrium in contact: `load_hint`,
    or for a scene without load held by ligaments that they may hold the tibia apart."""
    hint = load_hint(scene)
    if hint or scene["load.force_N"] != 0 or not has_ligaments(scene):
        return hint
    weight = " and the tibia's weight" if tibia_weight_N(scene) > 0 else ""
    return (f"with load.force_N = 0 only the ligaments{weight} act on the tibia: they may "
            "hold it apart from the femur, where no contact equilibrium exists; give the "
            "knee load in N (hundreds of N)")


def load_warning(force_N: float) -> str:
    """The warning on a load.force_N `force_N` (N, > 0) outside `KNEE_LOAD_N`, naming the
    unit that would put it inside (kN below, mN above), or ""."""
    low, high = KNEE_LOAD_N
    span = f"({low:g} N-{high / 1000:g} kN)"
    if force_N < low:
        as_kn = force_N * 1000.0
        likely = (f"kN typed as N? ({force_N:g} kN = {as_kn:g} N)" if as_kn >= low else
                  "even read as kN; give the load in N (knee loads are hundreds of N)")
        return f"load.force_N = {force_N:g} N is below any knee load {span}: {likely}"
    if force_N > high:
        as_n = force_N / 1000.0
        likely = (f"mN typed as N? ({force_N:g} mN = {as_n:g} N)" if as_n <= high else
                  "even read as mN; give the load in N (knee loads are hundreds of N)")
        return f"load.force_N = {force_N:g} N is above any knee load {span}: {likely}"
    return ""


def zero_load_error(scene: Scene) -> str:
    """Why a scene without external load cannot be solved, or "": the tibia is free along
    z and neither a load nor a ligament holds it on the femur, so it either falls away
    under its weight or has no contact at all (every pose out of contact balances). A
    ligament-only scene, a driven z and the rigid model (forces of the given pose) are
    solvable without load."""
    if (scene["load.force_N"] != 0 or has_ligaments(scene) or "z" not in scene.free_dofs
            or scene["model.kind"] == "rigid"):
        return ""
    weight = tibia_weight_N(scene)
    fix = "give the knee load in N (hundreds of N, e.g. load.force_N = 800)"
    if weight > 0:
        return (f"load.force_N = 0: nothing holds the tibia on the femur against its weight "
                f"({weight:.4g} N, tibia.mass_kg · g), so no equilibrium exists; {fix}")
    return ("load.force_N = 0 and no weight (gravity = false): nothing presses the tibia on "
            "the femur, so the equilibrium is no contact (zero forces, any pose apart) and "
            f"there is nothing to solve; {fix}")


def _out_of(e: float, low: float, high: float) -> str:
    return (f"softer than any cartilage ({low:g}-{high:g} MPa)" if e < low else
            f"stiffer than cartilage ({low:g}-{high:g} MPa)")


def modulus_warning(e: float, key: str = "contact.youngs_MPa",
                    stiffest_MPa: float = IMPLANT_E_MPA) -> str:
    """The message on a Young's modulus `e` (MPa) of scene key `key` outside the range of
    knee materials (`CARTILAGE_E_MPA` up to `stiffest_MPa`), naming the likely unit, or
    "". Beyond `ABSURD_E_MPA` no unit slip of cartilage explains it (`modulus_error`)."""
    low, high = CARTILAGE_E_MPA
    if e < ABSURD_E_MPA[0]:
        return (f"{key} = {e:g} MPa ({e * 1e6:.3g} Pa) is {_out_of(e, low, high)} even read "
                "as GPa: a value converted the wrong way? (fecheck takes MPa: cartilage "
                "~20 MPa = 0.02 GPa = 2e7 Pa)")
    if e < low:
        return (f"{key} = {e:g} MPa is {_out_of(e, low, high)}: GPa typed as MPa? "
                "(20 MPa = 0.02 GPa)")
    if e <= stiffest_MPa:
        return ""
    what = (f"{_out_of(e, low, high)} and than any bearing implant (UHMWPE ~460-1000 MPa)"
            if stiffest_MPa <= IMPLANT_E_MPA else
            f"{_out_of(e, low, high)} and than any implant metal or ceramic (up to "
            f"{stiffest_MPa:g} MPa)")
    if e >= ABSURD_E_MPA[1]:
        likely = "Pa typed as MPa? (20 MPa = 2e7 Pa)"
    elif e < 1e5:                          # in kPa: 5-100 MPa; in Pa: under 0.1 MPa
        likely = f"kPa typed as MPa? ({e:g} kPa = {e / 1000:g} MPa)"
    else:
        likely = f"Pa or kPa typed as MPa? ({e:g} Pa = {e * 1e-6:g} MPa)"
    return f"{key} = {e:g} MPa is {what}: {likely}"


def modulus_error(e: float) -> bool:
    """Whether a modulus `e` (MPa) is absurd (outside `ABSURD_E_MPA`): an error."""
    return not ABSURD_E_MPA[0] <= e < ABSURD_E_MPA[1]


def moduli(scene: Scene) -> list[tuple[str, float, float]]:
    """(key, E MPa, stiffest plausible MPa) of each modulus the scene's solve reads."""
    out = []
    if scene["model.kind"] != "rigid":
        out.append(("contact.youngs_MPa", scene["contact.youngs_MPa"], IMPLANT_E_MPA))
        if scene["contact.femoral_youngs_MPa"] is not None:
            out.append(("contact.femoral_youngs_MPa", scene["contact.femoral_youngs_MPa"],
                        IMPLANT_E_MPA))
        indenter = scene["contact.indenter_youngs_MPa"]
        if "contact.indenter_youngs_MPa" in LAWS[scene["contact.law"]].keys \
                and math.isfinite(indenter):
            out.append(("contact.indenter_youngs_MPa", indenter, INDENTER_E_MPA))
    return out


def volumetric_error(scene: Scene) -> str:
    """The error on a volumetric stiffness typed in N/m³ (the thesis's unit), or ""."""
    key = "contact.volumetric_stiffness_N_per_mm3"
    k = scene[key]
    if (scene["model.kind"] == "rigid" or key not in LAWS[scene["contact.law"]].keys
            or k < ABSURD_VOLUMETRIC_N_PER_MM3):
        return ""
    return (f"{key} = {k:g} N/mm³ would press {k:g} MPa at 1 mm depth, no knee's contact: "
            f"N/m³ typed as N/mm³? ({k:g} N/m³ = {k * 1e-9:g} N/mm³; the thesis gives k_V "
            "in N/m³)")


def input_errors(scene: Scene) -> list[str]:
    """Errors on inputs no unit slip of a knee explains (a zero load nothing balances, an
    absurd modulus or volumetric stiffness): the solve would mean nothing."""
    out = [zero_load_error(scene), volumetric_error(scene)]
    out += [modulus_warning(e, key, top) for key, e, top in moduli(scene) if modulus_error(e)]
    return [m for m in out if m]


def input_warnings(scene: Scene) -> list[str]:
    """Warnings on the scene's material and load (none for values a knee can have): a
    load outside `KNEE_LOAD_N` whatever the gravity, and one that does not lift the
    tibia's weight (`load_hint`) where that says more."""
    out = [modulus_warning(e, key, top) for key, e, top in moduli(scene)]
    force = scene["load.force_N"]
    load = load_warning(force) if force > 0 else ""
    out.append(load or load_hint(scene))
    return [w for w in out if w]
