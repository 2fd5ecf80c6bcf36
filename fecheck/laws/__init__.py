"""Laws: a contact surface and a material → pressure, the wrench on the slave and its tangent.

Owns materials, the foundation and Hertz laws, the law registry (`registry`: every
``contact.law`` value's entry), the compiled resultant kernel and the layer stiffness
from thickness maps. Imports `scene`, `reference`, `contact`, `geometry`.
"""

from fecheck.laws.foundation import (
    BLANKEVOORT_LINEAR_FROM,
    blankevoort_foundation,
    blankevoort_params,
    blankevoort_pressure,
    elastic_foundation,
    foundation,
    volumetric,
)
from fecheck.laws.hertz import hertz, hertz_point
from fecheck.laws.materials import ef_stiffness, hertz_modulus, validate_material
from fecheck.laws.result import LawResult

__all__ = ["BLANKEVOORT_LINEAR_FROM", "LawResult", "blankevoort_foundation",
           "blankevoort_params", "blankevoort_pressure", "ef_stiffness", "elastic_foundation",
           "foundation", "hertz", "hertz_modulus", "hertz_point", "validate_material",
           "volumetric"]
