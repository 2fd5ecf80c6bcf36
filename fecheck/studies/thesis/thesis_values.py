"""The thesis's numbers, transcribed once (B. Istace, UCLouvain 2024; table/figure ids).

Units: N, MPa, mm², mm, degrees, µm. Compartment results are keyed by the metric names
of `fecheck.model.results.CompartmentResult`: force_N, max_pressure_MPa, mean_pressure_MPa,
area_mm2, max_depth_mm. Figure values are the numbers its text states about the figure
(the plotted curves themselves are not given as numbers).
"""

from __future__ import annotations

METRICS = ("max_pressure_MPa", "mean_pressure_MPa", "force_N", "area_mm2", "max_depth_mm")
METRIC_LABELS = {"max_pressure_MPa": "max pressure MPa", "mean_pressure_MPa":
                 "mean pressure MPa", "force_N": "force N", "area_mm2": "contact area mm²",
                 "max_depth_mm": "max depth mm"}


def _case(medial: tuple, lateral: tuple) -> dict[str, dict[str, float]]:
    return {"medial": dict(zip(METRICS, medial, strict=True)),
            "lateral": dict(zip(METRICS, lateral, strict=True))}


# Table 3.1: mesh characteristics (plan, icosphere gmsh/pygmsh, trimesh, tibia/femur split,
# total).
TABLE_3_1 = {
    "plane box": {"euler": 2, "winding_consistent": True, "convex": True, "watertight": True,
                  "empty": False},
    "icosphere gmsh": {"euler": 2, "winding_consistent": True, "convex": False,
                       "watertight": True, "empty": False},
    "icosphere trimesh": {"euler": 2, "winding_consistent": True, "convex": True,
                          "watertight": True, "empty": False},
    "tibia/femur split": {"euler": 2, "winding_consistent": True, "convex": False,
                          "watertight": False, "empty": False},
    "tibia/femur total": {"euler": 2, "winding_consistent": True, "convex": False,
                          "watertight": True, "empty": False},
}

# Fig. 3.3: icosphere volume within a 0.5 % band; radius 31.8 mm (lateral condyle).
FIG_3_3_BAND_PCT = 0.5
FIG_3_3_RADIUS_MM = 31.8
# Fig. 3.24: above 0.65 µm depth, ray casting detects every vertex.
FIG_3_24_SURE_DEPTH_UM = 0.65
# Figs. 3.21 / 3.25: detection time linear (collision) and quadratic (ray casting) in faces.
FIG_3_21_EXPONENT = 1.0
FIG_3_25_EXPONENT = 2.0

# Table 2.1: plane angles (λ sagittal, γ frontal, deg) and mean errors (mm), free and
# transverse planes, with and without outliers.
TABLE_2_1 = {
    "with outliers": {"medial": {"lambda_deg": -0.57, "gamma_deg": -6.23, "me_free_mm": 2.27,
                                 "me_transverse_mm": 2.57},
                      "lateral": {"lambda_deg": -0.52, "gamma_deg": 10.14, "me_free_mm": 2.01,
                                  "me_transverse_mm": 2.63}},
    "without outliers": {"medial": {"lambda_deg": -0.36, "gamma_deg": -5.93,
                                    "me_free_mm": 1.88, "me_transverse_mm": 2.04},
                         "lateral": {"lambda_deg": -0.34, "gamma_deg": 9.82,
                                     "me_free_mm": 1.62, "me_transverse_mm": 2.01}},
}
# Table 2.4: tibial polynomial z = f(x, y), degree (k = m) → mean error mm (medial, lateral).
TABLE_2_4 = {0: (2.61, 2.83), 1: (2.33, 2.03), 2: (1.46, 1.35), 3: (1.19, 1.19),
             4: (0.89, 1.01)}
# Table 2.5: femoral r = f(θ, φ), degree → mean error mm (medial, lateral).
TABLE_2_5 = {0: (2.02, 1.96), 1: (1.91, 1.87), 2: (1.52, 1.11), 3: (1.223, 0.926),
             4: (1.186, 0.856), 5: (1.113, 0.852), 6: (1.108, 0.848)}

# Fig. 4.4: log-log slopes of force against depth; Fig. 4.5: of max pressure.
FIG_4_4_SLOPES = {"ef": 2.0, "volumetric": 2.0, "hertz": 1.5}
FIG_4_5_SLOPES = {"ef": 1.0, "volumetric": 1.0, "hertz": 0.5}
# Fig. 4.6 is at a fixed depth d = 1 mm.
FIG_4_6_DEPTH_MM = 1.0

# Table 5.1 / 5.2: rigid model force distribution (N); ligament rods ~0 (5.2).
TABLE_5_1 = {"medial": 323.71, "lateral": 456.67}
TABLE_5_2_LIGAMENTS_N = {"MCL": 3.63e-08, "ACL": 3.28e-09, "PCL": 2.64e-08}
# Fig. 5.2: equal compartment forces about 4 mm from the reference point (towards medial).
FIG_5_2_EQUAL_FORCE_SHIFT_MM = -4.0
# Fig. 5.4 hand check: symmetric condyles ±25 mm, r = 30 mm, 800 N, offset 3.5 mm.
FIG_5_4 = {"half_span_mm": 25.0, "radius_mm": 30.0, "force_N": 800.0, "offset_mm": 3.5,
           "F1_N": 344.0, "F2_N": 456.0}

TABLE_5_3 = _case((3.59, 1.91, 324.1, 168.9, 0.8), (3.81, 2.08, 456.2, 219.2, 0.85))
# Table 5.4: E (MPa) → faces → case; thesis faces (4928/4936 and 13728/13702) ≈ 5000, 13700.
TABLE_5_4 = {
    9.0: {5000: _case((2.51, 1.31, 326.3, 249.8, 1.24), (2.62, 1.42, 454.1, 325.6, 1.29)),
          13700: _case((2.66, 1.44, 328.6, 236.1, 1.32), (2.77, 1.43, 451.8, 323.4, 1.37))},
    15.0: {5000: _case((3.18, 1.73, 326.4, 186.9, 0.95), (3.32, 1.75, 453.9, 262.3, 0.99)),
           13700: _case((3.4, 1.79, 328.5, 184.3, 1.01), (3.52, 1.86, 451.9, 245.9, 1.05))},
    30.0: {5000: _case((4.37, 2.22, 326.2, 145.4, 0.65), (4.54, 2.42, 454.1, 187.5, 0.68)),
           13700: _case((4.70, 2.55, 328.0, 132.8, 0.69), (4.88, 2.5, 452.3, 182.1, 0.72))},
    20.0: {5000: _case((3.59, 1.91, 324.1, 168.9, 0.8), (3.81, 2.08, 456.2, 219.2, 0.85)),
           13700: _case((3.88, 2.09, 328.5, 161.8, 0.86), (4.04, 2.15, 451.9, 214.5, 0.9))},
}
# Table 5.5: ν → case (E = 20 MPa, ≈ 5000 faces).
TABLE_5_5 = {
    0.15: _case((3.24, 1.83, 324.1, 176.8, 0.92), (3.39, 1.81, 456.3, 254.0, 0.96)),
    0.4: _case((4.49, 2.33, 324.3, 138.1, 0.62), (4.67, 2.49, 456.1, 183.9, 0.65)),
    0.45: _case((5.77, 3.34, 324.8, 95.1, 0.45), (6.09, 3.17, 455.7, 140.0, 0.48)),
    0.3: _case((3.59, 1.91, 324.1, 168.9, 0.8), (3.81, 2.08, 456.2, 219.2, 0.85)),
}
TABLE_5_6_HERTZ = _case((2.49, 1.34, 337.8, 262.2, 1.33), (2.43, 1.33, 442.5, 325.5, 1.36))
TABLE_5_9_INCLINED = _case((3.18, 1.79, 352.6, 195.8, 0.71), (4.23, 2.22, 427.4, 198.2, 0.94))
TABLE_5_10_POLYNOMIAL = _case((3.26, 1.78, 332.6, 190.6, 0.81),
                              (4.21, 2.28, 447.8, 204.7, 1.03))
TABLE_5_11_SCANNED = _case((3.4, 1.76, 294.1, 188.2, 0.88), (4.2, 2.12, 486.3, 219.8, 1.11))
TABLE_5_12 = {"baseline": TABLE_5_3, "hertz": TABLE_5_6_HERTZ, "inclined": TABLE_5_9_INCLINED,
              "polynomial": TABLE_5_10_POLYNOMIAL, "scanned": TABLE_5_11_SCANNED}

# Tables 5.7 / 5.8: the thesis's EF results at the equal-force load point, by Donahue's
# element size (mm); Donahue 2002 itself is in `fecheck.reference.closed_forms.DONAHUE_2002`.
TABLE_5_7B_LATERAL = {5.0: (2.62, 1.32, 392.0, 385.0), 2.0: (2.77, 1.41, 395.0, 376.0),
                      1.0: (2.79, 1.43, 393.0, 374.0)}
TABLE_5_8B_MEDIAL = {5.0: (2.51, 1.31, 390.0, 401.0), 2.0: (2.66, 1.39, 387.0, 483.0),
                     1.0: (2.69, 1.41, 389.0, 490.0)}
DONAHUE_KEYS = ("max_pressure_MPa", "mean_pressure_MPa", "force_N", "area_mm2")

# Sweep figures: statements of the text (load point moved along x, mm from the reference).
FIG_5_6_MAX_DIFF_TO_RIGID_PCT = 1.0       # "error relative to the previous model < 1%"
FIG_5_7_EQUAL_SHIFT_CHANGE_MM = 1.0       # ligaments shift the equal point by "just under 1mm"
FIG_5_8 = {"ef": {-8.0: 450.0, 8.0: 210.0}, "hertz": {-8.0: 430.0, 8.0: 250.0}}  # medial N
FIG_5_14_RIGID_LATERAL_SHARE_AT_8MM = 0.75  # "3/4 of the force" through lateral (rigid)
FIG_5_16_EQUAL_SHIFT_OFFSET_MM = 2.0        # femur/tibia: equal point offset by 2 mm
FIG_5_19_EQUAL_SHIFT_MM = -16.9             # femur/tibia with ligaments
FIG_5_22_MAX_DIFF_TO_FIG_5_2_PCT = 1.0      # left knee: "< 1% error" to Fig. 5.2
SWEEP_RANGE_MM = 8.0                        # the figures move the load point ±8 mm
