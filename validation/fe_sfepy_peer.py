"""Peer comparison: the baseline medial compartment in SfePy (penalty contact + Newton).

SfePy is NOT a fecheck dependency: install it beside fecheck (``pip install sfepy``);
without it this script says so and exits. The file is both the SfePy problem description
(`define`, read by ``ProblemConf``) and the driver (``__main__``), modelled on SfePy's
``examples/linear_elasticity/elastic_contact_sphere.py``: ``dw_lin_elastic`` +
``dw_contact_sphere`` (penalty k, gap along the sphere normal in the deformed
configuration), Newton with a direct solver. The rigid sphere (R 25.5 mm) presses a 6 mm
layer (E 20 MPa, ν 0.3) bonded at its base, on the same mesh as fecheck's general FE path
(the extruded layer of `fecheck.fe.reference.sphere_layer.sphere_on_flat_layer`), with quadratic
elements like fecheck. SfePy is displacement controlled: a secant on the sphere position
finds the load (323.71 N, the rigid Table 5.1 medial force), one Newton solve per step.

    python validation/fe_sfepy_peer.py [--quick] [MESH [D0 D1]]

MESH is a layer mesh (VTU, top at z = 0, base at z = -6); without MESH the script writes
the general path's layer itself (`fecheck.fe.reference.sphere_layer.flat_layer`, 0.8 mm under the
contact). D0 and D1 (mm) start the secant. --quick refines to 2 mm under the contact
instead of 0.8 mm and stops after 4 Newton solves instead of 8. Prints δ, the contact
force of each step and the CPU time of the Newton solves; compare with the CPU time of
``sphere_on_flat_layer(323.71, 25.5, 20, 0.3, 6)``.
"""

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import Missing, require

RADIUS_MM, LOAD_N, PENALTY = 25.5, 323.71, 1e4   # penalty N/mm³: 4 MPa -> 0.4 µm overlap


def define() -> dict:
    """The SfePy problem (read by ``ProblemConf``): the mesh file and the sphere's lowering
    δ (mm) come from the environment variables PEER_MESH and PEER_DELTA."""
    from sfepy.mechanics.matcoefs import stiffness_from_youngpoisson

    delta = float(os.environ.get("PEER_DELTA", "0"))
    return {
        "filename_mesh": os.environ.get("PEER_MESH", ""),
        "options": {"nls": "newton", "ls": "ls"},
        "fields": {"displacement": ("real", 3, "Omega", 2)},
        "materials": {"solid": ({"D": stiffness_from_youngpoisson(3, 20.0, 0.3)},),
                      "cs": ({"f": [PENALTY, 1e-2], ".c": [0.0, 0.0, RADIUS_MM - delta],
                              ".r": RADIUS_MM},)},
        "variables": {"u": ("unknown field", "displacement", 0),
                      "v": ("test field", "displacement", "u")},
        "regions": {"Omega": "all",
                    "Bottom": ("vertices in (z < -5.999)", "facet"),
                    "Top": ("vertices in (z > -0.001)", "facet")},
        "ebcs": {"fixed": ("Bottom", {"u.all": 0.0})},
        "equations": {"elasticity": """dw_lin_elastic.2.Omega(solid.D, v, u)
                              + dw_contact_sphere.6.Top(cs.f, cs.c, cs.r, v, u) = 0"""},
        "solvers": {"ls": ("ls.scipy_direct", {}),
                    "newton": ("nls.newton", {"i_max": 50, "eps_a": 1e-10, "eps_r": 1e-8,
                                              "eps_mode": "or", "step_red": 0.8,
                                              "ls_on": 2.0})},
    }


def layer_mesh(refine_size_mm: float, folder: Path) -> Path:
    """The general path's medial layer (`flat_layer`, linear tetrahedra) in `folder`."""
    from fecheck.fe.reference.sphere_layer import flat_layer
    from geometry.io import save_mesh

    layer, _ = flat_layer(LOAD_N, RADIUS_MM, 20.0, 0.3, 6.0, refine_size_mm=refine_size_mm)
    return save_mesh(layer.solid.mesh, folder / "layer.vtu")


def contact_force(delta_mm: float, cpu: list) -> float:
    """Total vertical contact force (N) with the sphere lowered by delta_mm."""
    import numpy as np
    from sfepy.base.conf import ProblemConf, get_standard_keywords
    from sfepy.discrete import Problem

    os.environ["PEER_DELTA"] = repr(delta_mm)
    conf = ProblemConf.from_file(__file__, *get_standard_keywords())
    pb = Problem.from_conf(conf)
    t = time.process_time()
    pb.solve(save_results=False)
    cpu.append(time.process_time() - t)
    f = pb.evaluate("dw_contact_sphere.6.Top(cs.f, cs.c, cs.r, v, u)", mode="weak",
                    dw_mode="vector")
    return float(np.sum(f.reshape(-1, 3)[:, 2]))


def secant(d0: float, d1: float, max_solves: int) -> dict:
    """Sphere lowering (mm) at which the contact force is LOAD_N, by secant steps."""
    cpu: list = []
    f0, f1 = contact_force(d0, cpu), contact_force(d1, cpu)
    print(f"delta {d0:.5f} mm: {f0:.3f} N\ndelta {d1:.5f} mm: {f1:.3f} N", flush=True)
    while abs(f1 - LOAD_N) > 1e-4 * LOAD_N and len(cpu) < max_solves:
        d0, f0, d1 = d1, f1, d1 + (LOAD_N - f1) * (d1 - d0) / (f1 - f0)
        f1 = contact_force(d1, cpu)
        print(f"delta {d1:.5f} mm: {f1:.3f} N", flush=True)
    return {"delta_mm": d1, "force_N": f1, "newton_solves": len(cpu), "cpu_s": sum(cpu)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="2 mm under the contact, at most 4 Newton solves")
    parser.add_argument("mesh", nargs="?", type=Path,
                        help="layer mesh (VTU); default: the general path's layer, written here")
    parser.add_argument("d0", nargs="?", type=float, default=0.930, help="first δ, mm")
    parser.add_argument("d1", nargs="?", type=float, default=0.9315, help="second δ, mm")
    args = parser.parse_args(argv)
    try:
        require("sfepy", "pip install sfepy")
    except Missing as err:
        print(f"skipped: {err}")
        return 0
    from sfepy.base.base import output

    output.set_output(quiet=True)
    with tempfile.TemporaryDirectory() as folder:
        mesh = args.mesh or layer_mesh(2.0 if args.quick else 0.8, Path(folder))
        os.environ["PEER_MESH"] = str(mesh)
        result = secant(args.d0, args.d1, 4 if args.quick else 8)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
