#!/usr/bin/env python3
"""odocal end to end through each camera preset: the per-preset table of docs/vision.md.

    python3 bench/presets/presets.py [--odocal build/odocal] [--out out/presets] [--presets ...]

For each camera (odocal's own renderer, then the machine-vision, webcam and phone presets of
vision/image_formation.h) it renders bench/presets/presets_720p.yaml with `odocal simulate` (the
robot's tag printed 0.5 % large, four taped floor tags) and measures it with `odocal batch`;
then it tabulates, against the simulator's truth.json:
  - the return errors at rests (every run): x, y and heading error, mean |.| and max |.|;
  - Ed (UMBMark, coupled), the turn gain Eb/Es and Es (trajectory fit; Es also CVRA), errors;
  - the camera scale: its source, the robot tag's print scale found (true 1.005).
Every number comes from the odocal CLI; this script only runs it and reads its JSON.
About 2 min of rendering per preset on one core. Standard library only.
"""
import argparse
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SCENE = os.path.join(HERE, "presets_720p.yaml")
CAMERAS = {
    # odocal's renderer as the other scenarios use it: Gaussian blur, linear, CRF 12.
    "renderer": "  noise_sigma: 0.5\n  blur_sigma_px: 0.8\n  crf: 12\n",
    "machine-vision": "  profile: machine-vision\n",
    "webcam": "  profile: webcam\n",
    "webcam-mjpeg": "  profile: webcam\n  codec: {mjpeg: 80}\n",
    "phone": "  profile: phone\n",
}


def run(args):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write(" ".join(args) + "\n" + r.stdout[-3000:] + r.stderr[-3000:])
        raise SystemExit(f"failed: {' '.join(args[:2])} (exit {r.returncode})")
    return r.stdout


def one(odocal, out, name, extra, no_floor=False, batch_args=()):
    with open(SCENE) as f:
        text = f.read()
    text = text.replace("  exposure_ms: 4\n", "  exposure_ms: 4\n" + extra)
    if no_floor:
        # The tag printed at its stated size and no floor tags: the scale is the tag's apparent size.
        start = text.index("  tag: {print_scale: 1.005}\n")
        text = text[:start] + text[text.index("effects:"):]
    d = os.path.join(out, name)
    os.makedirs(d, exist_ok=True)
    scenario = os.path.join(d, "scenario.yaml")
    with open(scenario, "w") as f:
        f.write(text)
    if not os.path.exists(os.path.join(d, "sim", "truth.json")):
        run([odocal, "simulate", "--scenario", scenario, "--out", os.path.join(d, "sim")])
    rep = os.path.join(d, "rep" + "".join(batch_args).replace("-", "_"))
    run([odocal, "batch", os.path.join(d, "sim", "session.yaml"), "--out", rep, *batch_args])
    truth = json.load(open(os.path.join(d, "sim", "truth.json")))
    report = json.load(open(os.path.join(rep, "report.json")))
    return truth, report


def row(name, truth, report):
    # The truth of a return error: the true relative pose minus the odometry's own, componentwise
    # (calibration::TrueMinusOdometry), as batch measures it.
    def true_minus_odometry(r):
        t, o = r["true_return_error"], r["odometry_end"]
        h = (t["theta_deg"] - o["heading_deg"] + 180.0) % 360.0 - 180.0
        return {"x_mm": t["x_mm"] - o["x_mm"], "y_mm": t["y_mm"] - o["y_mm"], "theta_deg": h}

    true_runs = {r["name"]: true_minus_odometry(r) for r in truth["runs"]}
    ex, ey, eh, z = [], [], [], []
    for r in report["runs"]:
        m = r["return_error"]
        if m is None:
            continue
        t = true_runs[r["name"]]
        ex.append(m["x_mm"] - t["x_mm"])
        ey.append(m["y_mm"] - t["y_mm"])
        eh.append(m["theta_deg"] - t["theta_deg"])
        # Does the stated sigma cover the error? (x, y and heading: error / sigma)
        sg = r["sigma"]
        z += [abs(ex[-1]) / sg["x_mm"], abs(ey[-1]) / sg["y_mm"], abs(eh[-1]) / sg["theta_deg"]]
    pos = [abs(v) for v in ex + ey]
    T = truth["truth"]
    fit = report["trajectory_fit"]
    ed_umb = report["umbmark"]["estimate"]["Ed"] if report.get("umbmark") else float("nan")
    gain_true = T["Eb"] / T["Es"]
    scale = report["sessions"][0]["camera_scale"]
    ps = scale.get("tag_print_scale", {})
    shift = scale.get("edge_shift", {})
    es_cvra = report.get("cvra", {}).get("scale", {}).get("scale", float("nan"))
    return (
        f"| {name} | {sum(pos) / len(pos):.3f} / {max(pos):.3f} | "
        f"{sum(abs(v) for v in eh) / len(eh):.4f} / {max(abs(v) for v in eh):.4f} | "
        f"{sum(ex) / len(ex):+.3f}, {sum(ey) / len(ey):+.3f} | "
        f"{ed_umb - T['Ed']:+.6f} | {fit['Ed']['value'] - T['Ed']:+.6f} | "
        f"{fit['turn_gain']['value'] - gain_true:+.6f} | "
        f"{100 * (fit['Es']['value'] / T['Es'] - 1):+.3f} % (σ {100 * fit['Es']['sigma']:.3f} %) | "
        f"{100 * (es_cvra / T['Es'] - 1):+.3f} % | "
        f"{ps.get('value', float('nan')):.4f} ± {ps.get('sigma', float('nan')):.4f} | "
        f"{scale['camera_height_mm'] - 2000.0:+.2f} ± {scale['sigma_camera_height_mm']:.2f} mm | "
        f"{shift.get('shift_px', float('nan')):+.3f} ± {shift.get('sigma_px', float('nan')):.3f} px | "
        f"{(sum(v * v for v in z) / len(z)) ** 0.5:.2f} / {max(z):.2f} |"
    )


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--odocal", default="build/odocal")
    p.add_argument("--out", default="out/presets")
    p.add_argument("--presets", nargs="*", default=list(CAMERAS))
    p.add_argument("--no-floor-reference", action="store_true",
                   help="tag printed at its stated size, no floor tags: the scale from the tag's apparent size")
    p.add_argument("--batch-args", default="", help="extra batch arguments, e.g. '--edge-shift-views=0'")
    a = p.parse_args()
    if a.no_floor_reference and a.out == "out/presets":
        a.out = "out/presets-no-floor"
    print("| camera | return error position mean / max (mm) | heading mean / max (°) | "
          "bias x, y (mm) | Ed UMBMark | Ed fit | turn gain | Es fit | Es CVRA | tag print scale | "
          "camera height − truth | edge shift removed | "
          "return error / stated sigma, RMS / max |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in a.presets:
        truth, report = one(a.odocal, a.out, name, CAMERAS[name], a.no_floor_reference, a.batch_args.split())
        print(row(name, truth, report), flush=True)


if __name__ == "__main__":
    main()
