"""Block Newton over several rigid bodies: contact interfaces between two moving bodies,
springs and rods between bodies, against hand statics and finite differences."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fecheck.contact.analytic import Sphere
from fecheck.contact.pair import ContactPair
from fecheck.errors import FecheckError
from fecheck.laws.fused import linear_law
from fecheck.reference.closed_forms import column_stiffness, ef_cap_depth
from fecheck.statics.interfaces import Interface
from fecheck.statics.ligaments import BodySpring, SpringLigament, blankevoort_tension, body_rod
from fecheck.statics.newton import (
    Body,
    Problem,
    _System,
    body_pose,
    on_body,
    point_force,
    solve,
)
from geometry.plateau import plane_patch

R_UP, R_LOW = 30.0, 20.0          # sphere radii of the upper and lower bodies, mm
PLATE_MM = 4.0                    # the middle plate's thickness
OFFSET_MM = 3.0                   # the lower sphere's centre, off the upper one's axis along x
LOAD_N = 300.0                    # pushes the lower body up
K_UP = column_stiffness(10.0, 0.3, 3.0)     # EF stiffness of each interface, N/mm³
K_LOW = column_stiffness(20.0, 0.3, 2.0)
UP, PLATE, LOW = 0, 1, 2


def _disc(z: float, normal_z: float):
    return plane_patch((0.0, 0.0, z), (0.0, 0.0, normal_z), radius=12.0, size=1.0,
                       refine_point=(0.0, 0.0, z), refine_size=0.2, refine_radius=9.0)


@pytest.fixture(scope="module")
def stack():
    """A fixed body with a sphere (R_UP, lowest point at z = 0) over a plate (its top face
    at z = 0, bottom at -PLATE_MM in its frame) over a body with a sphere (R_LOW, centre
    OFFSET_MM along x) pushed up by LOAD_N: both plate faces are EF slaves, the spheres
    masters. The lower interface's master moves."""
    top = Interface("upper", ContactPair(_disc(0.0, 1.0), Sphere([0.0, 0.0, R_UP], R_UP)),
                    linear_law(K_UP), PLATE, UP)
    centre_low = np.array([OFFSET_MM, 0.0, -PLATE_MM - R_LOW])
    bottom = Interface("lower", ContactPair(_disc(-PLATE_MM, -1.0), Sphere(centre_low, R_LOW)),
                       linear_law(K_LOW), PLATE, LOW)
    return top, bottom, centre_low


def _load(poses):
    rot, t = poses[LOW]
    w, dw = point_force(rot @ np.zeros(3) + t, np.array([0.0, 0.0, LOAD_N]))
    return (LOW,), w, dw


def _hand_stack():
    """Hand statics of the stack: the plate is a two-force member, so both contact forces
    lie on the line through the sphere centres, which the plate's normal n then follows:
    sin α = e / D with D = R_up + R_low + h - d_up - d_low the centre distance; the lower
    body's vertical balance gives |F| = P / cos α; each depth is the EF cap depth at |F|
    (F = k π d² (R - d/3)). Returns α (rad), |F| (N), the plate's z and the lower body's z
    (mm)."""
    alpha = 0.0
    for _ in range(50):
        force = LOAD_N / math.cos(alpha)
        d_up, d_low = ef_cap_depth(force, R_UP, K_UP), ef_cap_depth(force, R_LOW, K_LOW)
        dist = R_UP + R_LOW + PLATE_MM - d_up - d_low
        alpha = math.asin(OFFSET_MM / dist)
    n = np.array([-math.sin(alpha), 0.0, math.cos(alpha)])      # from the lower centre up
    c_up = np.array([0.0, 0.0, R_UP])
    foot = c_up - (R_UP - d_up) * n                             # on the plate's top face
    z_plate = float(n @ foot) / n[2]                            # top face through (0, 0, z)
    z_low = R_UP + PLATE_MM + R_LOW - dist * math.cos(alpha)
    return alpha, force, z_plate, z_low


def _stack_problem(stack, plate_free, low_free, extra=(), constraints=(), q_plate=None,
                   q_low=None) -> Problem:
    top, bottom, _ = stack
    q_plate = np.array([0.0, 0.0, 0.3, 0.0, 0.0, 0.0]) if q_plate is None else q_plate
    q_low = np.array([0.0, 0.0, 0.6, 0.0, 0.0, 0.0]) if q_low is None else q_low
    bodies = (Body("upper", np.zeros(6), ()), Body("plate", q_plate, plate_free),
              Body("lower", q_low, low_free))

    def wrench(poses):
        return [top(poses), bottom(poses), _load(poses)] + [part(poses) for part in extra]

    return Problem(bodies, wrench, tuple(constraints), force_scale_N=LOAD_N,
                   touching=lambda: top.max_depth_mm > 0 and bottom.max_depth_mm > 0)


def test_a_free_plate_between_two_spheres_meets_the_hand_statics(stack):
    # The plate (free z, flexion, abduction) between the fixed upper sphere and the lower
    # body (free z) pushed up by 300 N, its sphere 3 mm off the upper one's axis: the plate
    # tilts until its normal runs through both centres. Tolerances: the meshed discs
    # (0.2 mm faces under the contact) integrate the EF cap force within ~3e-3 (the
    # calibrated-law test), which moves each depth by up to half that (~1.3e-3 mm of
    # 0.85 mm; the lower body's z adds both: 2e-3 mm, measured 4e-4) and the centre of
    # pressure by a small fraction of a face, seen by α against a lever of D ≈ 52 mm
    # (1e-4, measured 8e-6); |F| = P / cos α is statics (1e-6, measured 3e-8); the balance
    # is the solver's tolerance (1e-8 of the load) and exact in direction (both forces on
    # the plate normal).
    top, bottom, _ = stack
    sol = solve(_stack_problem(stack, (2, 3, 4), (2,)))
    assert sol.converged
    alpha, force, z_plate, z_low = _hand_stack()
    q_plate, q_low = sol.q[PLATE], sol.q[LOW]
    assert q_plate[4] == pytest.approx(-alpha, rel=1e-4)          # abduction: tilt about y
    assert abs(q_plate[3]) < 1e-6                                 # no tilt about x
    assert q_plate[2] == pytest.approx(z_plate, abs=2e-3)
    assert q_low[2] == pytest.approx(z_low, abs=2e-3)
    poses = [body_pose(q) for q in sol.q]
    on_plate_up, on_plate_low = top.wrench_on_slave(poses), bottom.wrench_on_slave(poses)
    assert np.linalg.norm(on_plate_up[:3] + on_plate_low[:3]) <= 1e-7 * LOAD_N
    assert np.linalg.norm(on_plate_low[:3]) == pytest.approx(force, rel=1e-6)
    n = poses[PLATE][0][:, 2]                                     # the plate's normal
    assert np.linalg.norm(np.cross(on_plate_low[:3], n)) <= 1e-9 * force
    # the lower body: its contact force (minus the plate's) carries the load vertically
    assert -on_plate_low[2] + LOAD_N == pytest.approx(0.0, abs=1e-7 * LOAD_N)


def test_a_sliding_middle_body_is_named_with_the_key_that_drives_it(stack):
    # The plate free along y too: frictionless flat faces do not resist the slide, and the
    # stacked null space names that one DOF of that one body, with its body's key.
    problem = _stack_problem(stack, (1, 2, 3, 4), (2,))
    plate = dataclasses.replace(problem.bodies[PLATE], free_key="bodies.plate.free",
                                start_keys="bodies.plate.*_mm/_deg")
    bodies = problem.bodies[:PLATE] + (plate,) + problem.bodies[PLATE + 1:]
    with pytest.raises(FecheckError, match=r"^the DOFs plate y have no stiffness .*setting "
                                           r"bodies\.plate\.free = \['z', 'flexion', "
                                           r"'abduction'\] \(their values come from "
                                           r"bodies\.plate\.\*_mm/_deg\)"):
        solve(dataclasses.replace(problem, bodies=bodies))


def test_a_sliding_body_without_a_key_is_named_with_what_would_hold_it(stack):
    # The same slide, on a body whose DOFs no key fixes (the patella's "" key): no key is
    # offered to set, the message says that nothing holds it and how to keep it held.
    problem = _stack_problem(stack, (1, 2, 3, 4), (2,))
    plate = dataclasses.replace(problem.bodies[PLATE], free_key="")
    bodies = problem.bodies[:PLATE] + (plate,) + problem.bodies[PLATE + 1:]
    with pytest.raises(FecheckError) as error:
        solve(dataclasses.replace(problem, bodies=bodies))
    assert str(error.value).startswith("the DOFs plate y have no stiffness")
    assert str(error.value).endswith(
        "add ligaments; nothing holds the plate here: it may have left the surface it rests "
        "on (approach this pose in smaller steps)")
    assert " = [" not in str(error.value)


def test_block_tangent_matches_central_differences_of_the_stacked_residual(stack):
    # Every coordinate of the plate and the lower body free, a Blankevoort spring between
    # them and a rod from the fixed body to the lower one (with a multiplier), at a
    # non-equilibrium pose with both interfaces in contact: the Jacobian of the stacked
    # residual (contact blocks of both bodies' twists, spring blocks, geometric terms,
    # rod columns) against central differences in the scaled coordinates. h = 1e-6 as
    # for the one-body contact test (the clipped EF area is piecewise smooth); rounding
    # ~1e-16·|res|/h and truncation stay near 1e-9 of the largest entry (measured 8e-10),
    # so 1e-7 leaves room while any missing block or transport term is of order 1e-1.
    spring = BodySpring(PLATE, np.array([8.0, 3.0, -2.0]), LOW, np.array([-6.0, 5.0, -30.0]),
                        20.0, 900.0, 0.06)
    rod = body_rod(UP, np.array([10.0, -12.0, 40.0]), LOW, np.array([4.0, -7.0, -35.0]), 80.0)
    q_plate = np.array([0.2, -0.1, 0.4, math.radians(1.5), math.radians(-2.0), 0.03])
    q_low = np.array([-0.3, 0.2, 0.9, math.radians(-1.0), math.radians(1.2), -0.02])
    problem = _stack_problem(stack, tuple(range(6)), tuple(range(6)), [spring], [rod],
                             q_plate, q_low)
    system = _System(problem)
    z = np.concatenate([system.z_of([b.q_start for b in problem.bodies]), [150.0]])
    res, jac = system(z)
    assert stack[0].max_depth_mm > 0 and stack[1].max_depth_mm > 0
    assert spring.tension([body_pose(b.q_start) for b in problem.bodies]) > 0
    cols = []
    for j in range(len(z)):
        e = np.zeros(len(z))
        e[j] = 1e-6
        cols.append((system(z + e)[0] - system(z - e)[0]) / 2e-6)
    fd = np.column_stack(cols)
    assert np.abs(fd - jac).max() <= 1e-7 * np.abs(fd).max()
    assert np.abs(jac[:6, 6:12]).max() > 0.1 * np.abs(fd).max()   # the bodies are coupled


def test_interface_blocks_with_a_moving_mesh_master_match_central_differences():
    # A meshed ball (icosphere, 20,480 faces, the walked BVH path of the hot path) as the
    # master on one free body pressing a disc on another, every coordinate of both free:
    # the master's blocks come from the relative-pose invariance (`interface_part`), so a
    # kernel tangent that is not the slave's (master held) shows here. Measured 2e-9 of
    # the largest entry at h = 1e-6 (faceted master: the depth is smooth within a facet).
    from geometry.icosphere import icosphere

    pair = ContactPair(_disc(0.0, 1.0), icosphere(20.0, 5, (0.0, 0.0, 20.0)), method="bvh")
    contact = Interface("ball", pair, linear_law(K_UP), 0, 1)
    q_disc = np.array([0.2, -0.1, 0.4, math.radians(1.5), math.radians(-2.0), 0.03])
    q_ball = np.array([-0.3, 0.2, -0.3, math.radians(-1.0), math.radians(1.2), -0.02])
    system = _System(Problem((Body("disc", q_disc, tuple(range(6))),
                              Body("ball", q_ball, tuple(range(6)))),
                             lambda poses: [contact(poses)]))
    z = system.z_of([q_disc, q_ball])
    _, jac = system(z)
    assert pair.resolved_method == "bvh" and contact.max_depth_mm > 0.5
    cols = []
    for j in range(len(z)):
        e = np.zeros(len(z))
        e[j] = 1e-6
        cols.append((system(z + e)[0] - system(z - e)[0]) / 2e-6)
    fd = np.column_stack(cols)
    assert np.abs(fd - jac).max() <= 1e-7 * np.abs(fd).max()


STIFF_1, STIFF_2, TOE = 2000.0, 500.0, 0.06      # N per unit strain; transition strain


def _strain_at(force_N: float, stiffness_N: float) -> float:
    """Blankevoort strain at a tension in its linear range, ε = f/k + ε_t/2."""
    assert force_N > 0.5 * stiffness_N * TOE          # beyond the toe (ε > ε_t)
    return force_N / stiffness_N + 0.5 * TOE


def test_spring_between_two_free_bodies_pulls_them_equally_and_in_series():
    # Body a hangs from the world by a spring (slack 30 mm), body b from a by a second
    # spring (slack 20 mm, attached 5 mm off a's origin); 100 N pulls b along x. Both
    # springs carry 100 N; their lengths follow from the linear branch of the law.
    load = 100.0
    world = SpringLigament(np.zeros(3), np.zeros(3), 30.0, STIFF_1, TOE)
    link = BodySpring(0, np.array([5.0, 0.0, 0.0]), 1, np.zeros(3), 20.0, STIFF_2, TOE)

    def wrench(poses):
        pull = point_force(poses[1][1], np.array([load, 0.0, 0.0]))
        return [*on_body(lambda r, t: [world(r, t)], 0)(poses), link(poses),
                ((1,), *pull)]

    bodies = (Body("a", np.array([31.0, 0, 0, 0, 0, 0]), (0,)),
              Body("b", np.array([58.0, 0, 0, 0, 0, 0]), (0,)))
    sol = solve(Problem(bodies, wrench, force_scale_N=load, tolerance=1e-12))
    assert sol.converged
    x_a = 30.0 * (1 + _strain_at(load, STIFF_1))
    x_b = x_a + 5.0 + 20.0 * (1 + _strain_at(load, STIFF_2))
    assert sol.q[0][0] == pytest.approx(x_a, rel=1e-10)
    assert sol.q[1][0] == pytest.approx(x_b, rel=1e-10)


def test_spring_wrenches_are_equal_and_opposite_at_rotated_poses():
    # At rotated, translated poses the spring's wrenches on its two bodies (about the world
    # origin) sum to zero, and the force on b has the law's tension along b → a.
    link = BodySpring(0, np.array([5.0, -2.0, 7.0]), 1, np.array([-3.0, 4.0, 1.0]), 20.0,
                      STIFF_2, TOE)
    poses = [body_pose(np.array([1.0, 2.0, -3.0, 0.3, -0.2, 0.5])),
             body_pose(np.array([34.0, -6.0, 5.0, -0.4, 0.1, 0.2]))]
    (a, b), w, _ = link(poses)
    assert (a, b) == (0, 1)
    assert np.abs(w[:6] + w[6:]).max() <= 1e-12 * np.abs(w).max()
    x_a, x_b = link.ends(poses)
    length = float(np.linalg.norm(x_a - x_b))
    tension = float(blankevoort_tension((length - 20.0) / 20.0, STIFF_2, TOE)[0])
    assert tension > 0
    np.testing.assert_allclose(w[6:9], tension * (x_a - x_b) / length, rtol=1e-12)


def test_two_bodies_of_one_name_are_refused():
    # messages name a DOF by its body's name: two bodies of one name would be ambiguous
    with pytest.raises(FecheckError, match=r"share a name"):
        Problem((Body("meniscus", np.zeros(6), (2,)), Body("meniscus", np.zeros(6), (2,))),
                lambda poses: [])
