"""`fecheck run --explain`: the plan of a run, then an audit that the run kept to it.

The plan says which meshes the scene needs and whether they come from the on-disk cache
or are built (it does the mesh step itself, the first step of the run, timing it), which
detection path each contact pair takes (`ContactPair.describe`: closed form, BVH, GJK,
the thesis's fcl or ray parity), and which optional parts run (ligaments, plots) — and
so which heavy libraries may be imported. After the run, `Plan.audit` compares the
libraries actually imported and the meshes built during the run with the plan.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field

from geometry import cache

HEAVY = {"gmsh": "Gmsh (meshing)", "skfem": "scikit-fem (FE)", "pyvista": "pyvista (plots)",
         "igl": "libigl (BVH closest point)", "fcl": "python-fcl (thesis stack)",
         "trimesh": "trimesh (thesis stack)"}
"""Heavy optional libraries a run may import, by module name."""


@dataclass
class Plan:
    """What one scene run will do.

    meshes_built, meshes_cached : mesh-cache builds and hits of the mesh step
    mesh_time_s : wall time of the mesh step (building or reading the cache), s
    pairs : {compartment: (slave faces, detection path)}
    parts : {part: what runs, or "skipped"}
    allowed : heavy modules the run may import (names of `HEAVY`)
    """

    scene: str
    model: str
    meshes_built: int = 0
    meshes_cached: int = 0
    mesh_time_s: float = 0.0
    pairs: dict[str, tuple[int, str]] = field(default_factory=dict)
    parts: dict[str, str] = field(default_factory=dict)
    allowed: set[str] = field(default_factory=set)
    _builds_before: int = 0

    def text(self) -> str:
        """The plan as printed lines."""
        lines = [f"plan for scene {self.scene!r} (model {self.model}):"]
        if not self.pairs:
            lines.append("  meshes: none (no mesh is built or read; Gmsh is not imported)")
        elif self.meshes_built + self.meshes_cached == 0:
            lines.append(f"  meshes: read from files in {self.mesh_time_s:.3f} s (no cache "
                         "entry, nothing built)")
        else:
            lines.append(f"  meshes: {self.meshes_cached} from the cache, {self.meshes_built} "
                         f"built, in {self.mesh_time_s:.3f} s"
                         + (" (Gmsh imported to build)" if self.meshes_built else
                            " (Gmsh not needed)"))
        for name, (faces, how) in self.pairs.items():
            lines.append(f"  contact {name}: {faces} slave faces; {how}")
        for part, what in self.parts.items():
            lines.append(f"  {part}: {what}")
        skipped = sorted(set(HEAVY) - self.allowed)
        lines.append("  not imported: " + (", ".join(HEAVY[m] for m in skipped) or "-"))
        return "\n".join(lines)

    def audit(self) -> list[str]:
        """Deviations of the run from the plan (empty: the run kept to it)."""
        out = [f"{HEAVY[m]} was imported but not planned" for m in HEAVY
               if m in sys.modules and m not in self.allowed]
        extra = cache.STATS.builds - self._builds_before
        if extra:
            out.append(f"{extra} meshes were built during the run, outside the mesh step")
        return out


def _pair_modules(pair) -> set[str]:
    method = getattr(pair, "resolved_method", "")
    if method == "bvh":
        return {"igl"}
    if method in ("fcl", "ray-parity"):
        return {"trimesh", "fcl"}
    return set()


def plan_scene(scene, plot: bool = False) -> Plan:
    """The plan of `run_scene(scene)` (the mesh step is done here, so timed for real)."""
    kind = scene["model.kind"]
    plan = Plan(scene.label, kind)
    before = set(sys.modules)
    if kind != "rigid":
        if kind == "sphere-plane":
            from fecheck.model.sphere_plane import build_compartments
        else:
            from fecheck.model.scanned import build_compartments
        hits, builds = cache.STATS.hits, cache.STATS.builds
        t = time.perf_counter()
        comps = build_compartments(scene)
        for comp in comps:          # a point contact's mesh (pressure plots) is lazy
            plan.pairs[comp.name] = (comp.pair.slave.n_faces, comp.describe())
            plan.allowed |= _pair_modules(comp.pair)
        plan.mesh_time_s = time.perf_counter() - t
        plan.meshes_cached = cache.STATS.hits - hits
        plan.meshes_built = cache.STATS.builds - builds
    plan.allowed |= {m for m in HEAVY if m in sys.modules and m not in before}
    plan.allowed |= {m for m in HEAVY if m in before}
    lig = scene["ligaments.model"]
    plan.parts["ligaments"] = ("skipped (ligaments.model = none)" if lig == "none"
                               else f"{lig}s (ACL, PCL, MCL)")
    bundles = scene.values.get("scanned.ligaments", "none")
    if bundles != "none":
        plan.parts["ligaments"] = f"scanned ligament bundles ({bundles})"
    plan.parts["FE cross-check"] = "skipped (not a step of fecheck run)"
    plan.parts["plots"] = "pyvista, off-screen PNGs" if plot else "skipped (no --plot)"
    if plot:
        plan.allowed.add("pyvista")
    plan._builds_before = cache.STATS.builds
    return plan
