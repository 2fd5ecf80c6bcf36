"""The node-to-surface gap operator: how a gap reads the displacements of the bodies
it pairs, and a deformable master's give.

A slave node with unit normal n (toward the master) faces a master surface point that
its ray hits on a face of nodes a with barycentric weights w_a. With the slave's
displacement u_s and the master's u_a the gap changes by

    δg = (Σ_a w_a u_a − u_s)·n,

so the gap's row holds w_a n on the dofs of each master node a and −n on the slave's
(a slave is its own one-node "face" of weight −1). The contact force λ ≥ 0 (N) along
that row loads the master with +λ w_a n and the slave with −λ n (the transpose). Units:
mm, N.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np


def surface_entries(row: np.ndarray, nodes: np.ndarray, weights: np.ndarray,
                    normals: np.ndarray, dof_of: Callable[[np.ndarray], np.ndarray]
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(rows, columns, values) of the gap rows `row` (m,) on the dofs of `nodes` (m, k),
    each node a's entry w_a n along the unit `normals` (m, d) with the `weights` (m, k).

    `dof_of` maps the nodes (m, k) to the column of each of their d displacement
    components (m, k, d); a negative column (a fixed component, a node not condensed)
    is dropped. The entries come row by row, node by node, component by component.
    """
    cols = dof_of(nodes)
    vals = weights[:, :, None] * normals[:, None, :]
    rows = np.broadcast_to(np.asarray(row)[:, None, None], cols.shape)
    keep = cols >= 0
    return rows[keep], cols[keep], vals[keep]


def kept_dofs(node_dofs: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """`surface_entries`' `dof_of` for a body whose node i's components are its kept dofs
    `node_dofs[i]` (-1: fixed)."""
    return lambda nodes: node_dofs[nodes]


def nodal_displacements(node_dofs: np.ndarray, u: np.ndarray, nodes: np.ndarray
                        ) -> np.ndarray:
    """(k, d) displacements (mm) of `nodes` (k,) of a body from its kept-dof
    displacements `u` (mm), its node i's components at kept dofs `node_dofs[i]` (-1:
    fixed, zero displacement)."""
    dofs = node_dofs[nodes]
    return np.where(dofs >= 0, u[np.maximum(dofs, 0)], 0.0)


def surface_give(at_nodes: np.ndarray, weights: np.ndarray, normals: np.ndarray
                 ) -> np.ndarray:
    """(m,) how far the master surface moves along the unit `normals` (m, 3) at the points
    the rays hit, mm: Σ_a w_a u_a·n, from the displacements `at_nodes` (m, k, 3) of the
    hit faces' nodes (mm) and the barycentric `weights` (m, k). It adds to the gaps."""
    at = np.einsum("mk,mkc->mc", weights, at_nodes)
    return np.einsum("mc,mc->m", at, normals)
