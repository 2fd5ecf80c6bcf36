"""The contact laws as a scene sees them: each law's name (the value of ``contact.law``),
the scene keys it reads beyond the cartilage's material (``contact.youngs_MPa``,
``contact.poisson``, ``contact.thickness_mm``, which the FE cross-check reads whatever the
law) and its phrase in the documentation of ``contact.law``.

This is the scene's half of the law registry `fecheck.laws.registry`: the schema (the
allowed values and documentation of ``contact.law``) and the inert-key rules
(`fecheck.scene.relevance`) read it, and `scene` comes before `laws` in the pipeline. A
law registered at run time (`fecheck.laws.registry.register`) is declared here too.

>>> law_names()
('ef', 'hertz', 'volumetric', 'blankevoort', 'ef-calibrated')
>>> LAWS["hertz"].keys
('contact.indenter_youngs_MPa', 'contact.indenter_poisson')
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class LawKeys:
    """The scene's view of one contact law.

    name : the ``contact.law`` value
    title : the law in messages ("only the {title} law reads it")
    keys : the scene keys the law reads beyond the cartilage's material
    doc : its phrase in the documentation of ``contact.law``, after the quoted name
    point_contact : on a convex sphere-on-plane pair the law takes the closed-form point
        contact (`fecheck.contact.convex`): no mesh enters its solve
    """

    name: str
    title: str
    keys: tuple[str, ...] = ()
    doc: str = ""
    point_contact: bool = False


LAWS: dict[str, LawKeys] = {law.name: law for law in (
    LawKeys("ef", "EF", ("contact.femoral_share", "contact.femoral_youngs_MPa",
                         "contact.femoral_poisson"),
            doc="= linear elastic foundation (thesis eq. 4.1-4.3, stiffness from "
                "contact.youngs_MPa, contact.poisson and contact.thickness_mm)"),
    LawKeys("hertz", "Hertz", ("contact.indenter_youngs_MPa", "contact.indenter_poisson"),
            "(eq. 4.4-4.8, from the maximum depth)", point_contact=True),
    LawKeys("volumetric", "volumetric", ("contact.volumetric_stiffness_N_per_mm3",),
            "(eq. 4.9, stiffness contact.volumetric_stiffness_N_per_mm3)"),
    LawKeys("blankevoort", "Blankevoort",
            doc="= the nonlinear foundation of Blankevoort et al. 1991"),
    LawKeys("ef-calibrated", "calibrated EF", ("contact.calibration",),
            "= a foundation p = C·d·(d + 0.01 mm)^(n−1) fitted to FE: per compartment from "
            "contact.calibration, or for condyle spheres on a uniform layer from the "
            "built-in table of axisymmetric FE"),
)}
"""The declared laws by name, in the order the documentation lists them."""


def law_names() -> tuple[str, ...]:
    """The allowed values of ``contact.law``."""
    return tuple(LAWS)


def law_doc() -> str:
    """The documentation of ``contact.law``: every declared law with its phrase."""
    return "Contact law: " + ", ".join(f"'{law.name}' {law.doc}" for law in LAWS.values()) + "."


def readers(key: str) -> tuple[LawKeys, ...]:
    """The declared laws that read `key` (none: no law's own key)."""
    return tuple(law for law in LAWS.values() if key in law.keys)
