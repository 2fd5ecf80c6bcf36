"""Sparse solvers for the FE contact condensation, measured (picked by numbers).

The contact solve needs the layer's normal compliance at the m contact candidates,
C = R K⁻¹ Rᵀ (`fecheck.fe.solve.joint`). On the baseline medial layer of the general path
(`fecheck.fe.reference.sphere_layer.flat_layer`, 323.71 N on R 25.5 mm, E 20 MPa, ν 0.3, h 6 mm;
0.8 mm under the contact, or --size) this times CHOLMOD with the candidates ordered last
(`fecheck.fe.contact.compliance.condensed_compliance`, what `fecheck fe` runs), CHOLMOD and SuperLU
(scipy) factorizations followed by m solves, and pyamg smoothed-aggregation
preconditioned CG (rtol 1e-10), and reports each total over the Schur complement's, in
one run. CPU times (time.process_time), as the machine is shared.

    python validation/fe_solvers.py [--quick] [--size MM]

--quick meshes 3 mm under the contact and times 20 right-hand sides, scaled to m (SuperLU
takes minutes at 0.8 mm). pyamg is optional (``pip install pyamg``):
without it that line is skipped.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from fecheck.fe.bodies.pose import FramePose
from fecheck.fe.contact.compliance import condensed_compliance
from fecheck.fe.reference.sphere_layer import candidate_margin, flat_layer
from fecheck.fe.solve.press import rigid_gaps

if __name__ == "__main__" and not __package__:  # python validation/x.py: as python -m
    sys.path[0] = str(Path(__file__).resolve().parents[1])

from fecheck.studies.thesis.report import Missing, require

LOAD_N, RADIUS_MM, E_MPA, NU, H_MM = 323.71, 25.5, 20.0, 0.3, 6.0


def stiffness(size_mm: float):
    """Kept-dof stiffness K (N/mm) of the medial layer, and at the contact candidates (the
    top vertices within `candidate_margin` of the sphere) its normal rows, vertex dofs and
    normals."""
    layer, _ = flat_layer(LOAD_N, RADIUS_MM, E_MPA, NU, H_MM, refine_size_mm=size_mm)
    gaps = rigid_gaps(layer, FramePose.identity("W", "T"))
    cand = np.flatnonzero(gaps < candidate_margin(LOAD_N, RADIUS_MM, E_MPA, NU))
    solid = layer.solid
    return (sp.csc_matrix(solid.K), solid.normal_rows[cand], solid.vertex_dofs[cand],
            solid.normals[cand])


def cpu(fn):
    t = time.process_time()
    out = fn()
    return out, time.process_time() - t


def amg_pcg(pyamg, K, rhs, x_ref) -> tuple[float, float, float]:
    """pyamg smoothed-aggregation setup time, time per preconditioned-CG solve (CPU s,
    from up to 5 right-hand sides) and the solutions' largest relative error."""
    from scipy.sparse.linalg import cg

    ml, t_f = cpu(lambda: pyamg.smoothed_aggregation_solver(K.tocsr(), max_coarse=500))
    M = ml.aspreconditioner()
    k_amg = min(rhs.shape[1], 5)

    def pcg():
        return np.column_stack([cg(K, rhs[:, j], rtol=1e-10, M=M)[0] for j in range(k_amg)])

    x, t_s = cpu(pcg)
    err = np.abs(x - x_ref[:, :k_amg]).max() / np.abs(x_ref[:, :k_amg]).max()
    return t_f, t_s / k_amg, err


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--size", type=float, help="mm under the contact (default 0.8, "
                        "--quick 3)")
    args = parser.parse_args()
    K, rows, dofs, normals = stiffness(args.size or (3.0 if args.quick else 0.8))
    m = rows.shape[0]
    n_rhs = min(m, 20) if args.quick else m
    rhs = rows[:n_rhs].T.toarray()
    print(f"{K.shape[0]} dofs, {K.nnz} nonzeros, {m} candidate contact vertices "
          f"(timing {n_rhs} right-hand sides, scaled to {m})")
    (C, _), t_schur = cpu(lambda: condensed_compliance(K, dofs, normals))
    results = {"CHOLMOD, candidates last (Schur)": (t_schur, 0.0)}

    from sksparse.cholmod import cholesky
    factor, t_f = cpu(lambda: cholesky(K, ordering_method="metis"))
    x_ref, t_s = cpu(lambda: factor.solve_A(rhs))
    assert np.allclose(rows[:n_rhs] @ x_ref, C[:n_rhs, :n_rhs], atol=1e-9 * np.abs(C).max())
    results["CHOLMOD + m solves"] = (t_f, t_s * m / n_rhs)

    from scipy.sparse.linalg import splu
    lu, t_f = cpu(lambda: splu(K, permc_spec="MMD_AT_PLUS_A"))
    x, t_s = cpu(lambda: lu.solve(rhs))
    assert np.allclose(x, x_ref, atol=1e-9 * np.abs(x_ref).max())
    results["SuperLU + m solves"] = (t_f, t_s * m / n_rhs)

    notes = {}
    try:
        pyamg = require("pyamg", "pip install pyamg")
    except Missing as err:
        print(f"pyamg-PCG skipped: {err}")
    else:
        t_f, t_s, rel = amg_pcg(pyamg, K, rhs, x_ref)
        results["pyamg-PCG"] = (t_f, t_s * m)
        notes["pyamg-PCG"] = f"  (relative error {rel:.1e})"
    base = t_schur
    for name, (t_f, t_s) in results.items():
        note = notes.get(name, "")
        print(f"{name:32s} factorize/setup {t_f:7.2f} s  solves {t_s:8.2f} s  total "
              f"{t_f + t_s:8.2f} s = {(t_f + t_s) / base:6.1f}x the Schur path{note}")


if __name__ == "__main__":
    main()
