#!/usr/bin/env python3
"""Writes sample_data/session/manual.csv: tape readings made from the renderer's truth
(sample_data/session_truth/truth.json) plus a known bias and scatter, as a careful operator
with a slightly stretched tape might read them.

    python3 sample_data/make_manual_csv.py   # from the repository root

Bias (what odocal validate should report): x +1.2 mm, y -0.8 mm, theta +0.3 deg.
Scatter (1 sigma of one reading): x 1.5 mm, y 1.5 mm, theta 0.4 deg.
Five readings a run (five operators), seed 5.
"""
import json
import random
from pathlib import Path

ROOT = Path(__file__).resolve().parent
BIAS = {"x_mm": 1.2, "y_mm": -0.8, "theta_deg": 0.3}
SCATTER = {"x_mm": 1.5, "y_mm": 1.5, "theta_deg": 0.4}
READINGS_PER_RUN = 5

rng = random.Random(5)
truth = json.loads((ROOT / "session_truth" / "truth.json").read_text())
lines = [
    "# Tape readings of the sample session (made by sample_data/make_manual_csv.py:",
    "# truth + bias x +1.2 mm, y -0.8 mm, theta +0.3 deg + scatter 1.5 mm, 1.5 mm, 0.4 deg).",
    "run,x_mm,y_mm,theta_deg",
]
for run in truth["runs"]:
    e = run["true_return_error"]
    for _ in range(READINGS_PER_RUN):
        values = [e[k] + BIAS[k] + rng.gauss(0.0, SCATTER[k]) for k in ("x_mm", "y_mm", "theta_deg")]
        lines.append(f"{run['name']},{values[0]:.1f},{values[1]:.1f},{values[2]:.2f}")
(ROOT / "session" / "manual.csv").write_text("\n".join(lines) + "\n")
