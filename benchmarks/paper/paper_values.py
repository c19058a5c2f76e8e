"""The numbers printed in Zhou & Shimada (2000), Tables 1-5 and Sections 5.2-5.3, transcribed."""

# Table 1 (triangle mesh): min angle, max angle, (a) angles < 20, (b) angles > 130, (c) max/min area ratio.
# (c) of the original mesh is printed as "6.05E10 ³", read here as 6.05e3 (= 60.36 / 0.01 of Table 3).
TABLE1 = {
    "original": {"min_angle": 0.061, "max_angle": 179.76, "angles_below_20": 281, "angles_above_130": 48, "area_ratio": 6.05e3},
    "laplacian": {"min_angle": 9.99, "max_angle": 156.20, "angles_below_20": 13, "angles_above_130": 5, "area_ratio": 86},
    "smart-laplacian": {"min_angle": 11.85, "max_angle": 154.06, "angles_below_20": 11, "angles_above_130": 6, "area_ratio": 75},
    "angle": {"min_angle": 20.01, "max_angle": 136.32, "angles_below_20": 0, "angles_above_130": 1, "area_ratio": 17},
}

# Table 2 (tri-quad mixed mesh): min angle, max angle, (a) angles < 20, (b) angles > 150.
TABLE2 = {
    "original": {"min_angle": 1.37, "max_angle": 176.56, "angles_below_20": 116, "angles_above_150": 37},
    "laplacian": {"min_angle": 8.82, "max_angle": 174.02, "angles_below_20": 13, "angles_above_150": 13},
    "smart-laplacian": {"min_angle": 11.44, "max_angle": 226.28, "angles_below_20": 4, "angles_above_150": 32},
    "angle": {"min_angle": 19.17, "max_angle": 155.57, "angles_below_20": 4, "angles_above_150": 5},
}

# Table 3: min / max element area.
TABLE3 = {
    "triangle": {"original": (0.01, 60.36), "laplacian": (0.35, 35.56), "angle": (1.42, 24.17)},
    "quad": {"original": (1.55, 197.95), "laplacian": (2.95, 126.35), "angle": (8.54, 109.02)},
}

# Table 4: per pass 1..10, (min angle, min area, max area) for Laplacian and angle-based.
TABLE4 = {
    "laplacian": [
        (8.84, 1.69, 56.84), (11.45, 1.71, 59.82), (10.88, 1.64, 61.04), (10.93, 1.60, 61.61), (11.01, 1.59, 61.89),
        (11.07, 1.59, 61.96), (11.12, 1.61, 61.94), (11.17, 1.62, 61.85), (11.20, 1.64, 61.74), (11.23, 1.65, 61.62),
    ],
    "angle": [
        (8.70, 1.40, 58.75), (12.25, 2.85, 56.52), (13.56, 3.45, 55.34), (14.20, 3.69, 54.69), (14.91, 3.90, 54.32),
        (15.63, 4.09, 54.12), (16.33, 4.22, 54.01), (17.01, 4.31, 53.96), (17.65, 4.37, 53.94), (18.25, 4.42, 53.95),
    ],
}

# Table 5: L2 surface-approximation error, Laplacian vs angle-based, improvement = (L - A) / A.
TABLE5 = {
    "f1": {"laplacian": 95.38, "angle": 77.08, "improvement_pct": 23.74},
    "f2": {"laplacian": 0.23, "angle": 0.19, "improvement_pct": 21.05},
    "f3": {"laplacian": 1.16e8, "angle": 1.00e8, "improvement_pct": 16.00},
}

# Section 5.3 / Figure 12: displacement of pass 10 relative to pass 1.
FIG12_RATIO_PCT = 0.1

# Section 5.2 / 2.3 claims on cost per pass, relative to Laplacian.
COST_CLAIMS = {
    "optimization": "30-40x Laplacian (citing Freitag); about 5x smart Laplacian",
    "smart-laplacian": "between Laplacian and optimization",
    "angle": "cheaper than smart Laplacian and optimization per pass (12 angles + 6 rotations vs 36 angles per node)",
}
