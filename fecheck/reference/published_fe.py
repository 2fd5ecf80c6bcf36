"""Published FE knees with menisci to compare with: the modelling choices of Donahue et al.
2002 as scene values, each with its source, and the tibial contact of a subject-specific FE
at 1150 N. Donahue 2002's results themselves are `fecheck.reference.closed_forms.DONAHUE_2002`.

Donahue et al. 2002 (J Biomech Eng 124:273-280): a cadaver knee at full extension under 800 N
along the tibia, the joint free to compress and in varus-valgus, both cartilage layers
deformable and bonded to their bones, the menisci transversely isotropic linear elastic with
the stiff direction along the arc, each horn tied to the tibia by a linear spring. Its
material constants and the spring stiffness are written as the studies that cite the Haut
Donahue models quote them (the paper's text was not opened here; `MENISCUS_SOURCE`,
`ROOT_SOURCE`); the cartilage's E 15 MPa and ν 0.475 are attributed to it without a
source found that states them (`CARTILAGE_SOURCE`). Devaraj, Acharya & Adhikari 2020 (Open
Biomed Eng J 14:74-83, doi 10.2174/1874120702014010074): MRI knees of healthy subjects,
1150 N axial at full extension, the largest compressive stress and the contact area on each
tibial cartilage (mean ± SD).
Units: mm, N, MPa.

>>> SUBJECT_FE_2020["medial"].area_mm2, SUBJECT_FE_2020["lateral"].p_max_MPa
(701.0, 2.57)
"""

from __future__ import annotations

from dataclasses import dataclass

DONAHUE_SOURCE = "Donahue et al. 2002, J Biomech Eng 124:273"
"""Where the loading, the free rotations, the layers and the cartilage come from."""
CARTILAGE_SOURCE = (f"{DONAHUE_SOURCE}, attributed to it, not verified: neither the paper's "
                    "text nor a study quoting these values for it was found")
"""The cartilage's E and ν (linear elastic isotropic)."""
MENISCUS_SOURCE = ("Haut Donahue lab models after Donahue 2002, as a citing study quotes "
                   "them: 'Sensitivity of the tibio-femoral response ...' (excerpt on "
                   "scite.ai)")
"""The meniscus's transversely isotropic constants."""
ROOT_SOURCE = ("Haut Donahue et al. 2003, J Biomech 36:19, as later FE knee studies cite it: "
               "'linear springs with spring constants of 2000 N/mm'")
"""The horn springs."""
SUBJECT_SOURCE = "Devaraj, Acharya & Adhikari 2020, Open Biomed Eng J 14:74"
"""The subject-specific FE at 1150 N."""


@dataclass(frozen=True)
class Choice:
    """One modelling choice: what it is, the scene key that makes it (None: fixed in
    fecheck, e.g. the meniscus material), the published value and its source."""

    what: str
    key: str | None
    value: object
    source: str


DONAHUE_2002_CHOICES: tuple[Choice, ...] = (
    Choice("load along the tibial axis, N", "load.force_N", 800.0, DONAHUE_SOURCE),
    Choice("flexion (full extension), deg", "dofs.flexion_deg", 0.0, DONAHUE_SOURCE),
    Choice("the tibia's free DOFs (compression, varus-valgus)", "dofs.free",
           ["z", "abduction"], DONAHUE_SOURCE),
    Choice("both cartilage layers deformable, bonded to bone", "fe.cartilage", "two-layer",
           DONAHUE_SOURCE),
    Choice("cartilage Young's modulus, MPa", "contact.youngs_MPa", 15.0, CARTILAGE_SOURCE),
    Choice("cartilage Poisson's ratio", "contact.poisson", 0.475, CARTILAGE_SOURCE),
    Choice("both menisci present", "menisci.sides", ["medial", "lateral"], DONAHUE_SOURCE),
    Choice("horn attachments: a linear spring a horn", "menisci.roots", "springs",
           ROOT_SOURCE),
    Choice("horn spring stiffness, N/mm", "menisci.root_N_per_mm", 2000.0, ROOT_SOURCE),
    Choice("meniscus E_theta / E_r = E_z, MPa; nu_theta / nu_rz", None,
           (140.0, 20.0, 0.3, 0.2), MENISCUS_SOURCE),
)
"""Donahue 2002's modelling choices (module docstring), in the order `fecheck fe` prints
them. The meniscus's constants are (E along the arc, E across it, ν along, ν across)."""


@dataclass(frozen=True)
class PublishedContact:
    """A published tibial contact of one compartment: area (mm²) and largest pressure or
    compressive stress (MPa), each with its standard deviation (NaN: not reported), under
    the whole joint's load (N)."""

    area_mm2: float
    area_sd_mm2: float
    p_max_MPa: float
    p_max_sd_MPa: float
    load_N: float


SUBJECT_FE_2020: dict[str, PublishedContact] = {
    "medial": PublishedContact(701.0, 89.0, 2.98, 0.51, 1150.0),
    "lateral": PublishedContact(617.0, 63.0, 2.57, 0.53, 1150.0),
}
"""The subject-specific FE at 1150 N (module docstring): the tibial cartilage's contact area
and its largest compressive stress, per compartment, mean ± SD over the subjects."""
