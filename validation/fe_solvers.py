"""Sparse solvers for the FE contact condensation, measured (issue 5: pick by numbers).

The contact solve needs one factorization of the layer's stiffness and one solve per
candidate contact node (`fecheck.fe.contact`). On the baseline medial 3D problem (the
default 1.5 mm mesh, or --size) this times CHOLMOD (scikit-sparse), SuperLU (scipy)
and pyamg smoothed-aggregation preconditioned CG (rtol 1e-10) for the factorization
(or setup) and for the m right-hand sides, and reports each total over CHOLMOD's, in one
run. CPU times (time.process_time), as the machine is shared.

    python validation/fe_solvers.py [--quick] [--size MM]

--quick times 20 right-hand sides and scales to m. pyamg is optional (``pip install pyamg``):
without it that line is skipped.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse as sp
from report import Missing, require

from fecheck.reference.closed_forms import hertz_sphere_on_plane


def stiffness(size_mm: float):
    """Free-dof stiffness of the default medial layer and its top-vertex z dofs."""
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from geometry.layer import cartilage_layer

    a = np.sqrt(hertz_sphere_on_plane(323.71, 25.5, 20.0, 0.3).area_mm2 / np.pi)
    layer = cartilage_layer("ellipse", (0.0, 0.0), 30.0, 30.0, 6.0, size=5.0,
                            refine_point=(0.0, 0.0), refine_size=size_mm,
                            refine_radius=1.3 * a)
    mesh = MeshTet(layer.points.T, layer.tets.T)
    basis = Basis(mesh, ElementVector(ElementTetP2()), intorder=2)
    K = asm(linear_elasticity(*lame_parameters(20.0, 0.3)), basis)
    fixed = basis.get_dofs(lambda x: np.isclose(x[2], -6.0)).all()
    free = np.setdiff1d(np.arange(basis.N), fixed)
    index = np.full(basis.N, -1)
    index[free] = np.arange(len(free))
    top = np.unique(layer.boundaries["top"])
    near = top[np.hypot(*layer.points[top, :2].T) <= 1.3 * a]
    return sp.csc_matrix(K[free][:, free]), index[basis.nodal_dofs[2, near]]


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
    parser.add_argument("--size", type=float, default=1.5)
    args = parser.parse_args()
    K, cand = stiffness(args.size)
    m = len(cand)
    n_rhs = min(m, 20) if args.quick else m
    rhs = np.zeros((K.shape[0], n_rhs))
    rhs[cand[:n_rhs], np.arange(n_rhs)] = 1.0
    print(f"{K.shape[0]} dofs, {K.nnz} nonzeros, {m} candidate contact nodes "
          f"(timing {n_rhs} right-hand sides, scaled to {m})")
    results = {}

    from sksparse.cholmod import cholesky
    factor, t_f = cpu(lambda: cholesky(K))
    x_ref, t_s = cpu(lambda: factor.solve_A(rhs))
    results["CHOLMOD"] = (t_f, t_s * m / n_rhs)

    from scipy.sparse.linalg import splu
    lu, t_f = cpu(lambda: splu(K, permc_spec="MMD_AT_PLUS_A"))
    x, t_s = cpu(lambda: lu.solve(rhs))
    assert np.allclose(x, x_ref, atol=1e-9 * np.abs(x_ref).max())
    results["SuperLU"] = (t_f, t_s * m / n_rhs)

    notes = {}
    try:
        pyamg = require("pyamg", "pip install pyamg")
    except Missing as err:
        print(f"pyamg-PCG skipped: {err}")
    else:
        t_f, t_s, rel = amg_pcg(pyamg, K, rhs, x_ref)
        results["pyamg-PCG"] = (t_f, t_s * m)
        notes["pyamg-PCG"] = f"  (relative error {rel:.1e})"
    base = sum(results["CHOLMOD"])
    for name, (t_f, t_s) in results.items():
        note = notes.get(name, "")
        print(f"{name:10s} factorize/setup {t_f:7.2f} s  {m} solves {t_s:8.2f} s  total "
              f"{t_f + t_s:8.2f} s = {(t_f + t_s) / base:6.1f}x CHOLMOD{note}")


if __name__ == "__main__":
    main()
