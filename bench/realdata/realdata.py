#!/usr/bin/env python3
"""odocal on a real robot: the figures of docs/realdata.md, one command each.

    python3 bench/realdata/realdata.py conventions   # UMBMark vs the authors' published numbers
    python3 bench/realdata/realdata.py beliefs       # one robot, several believed parameter sets
    python3 bench/realdata/realdata.py heldout       # calibrate on squares + Ivanjko, check on circles
    python3 bench/realdata/realdata.py explain       # what explain finds, with cross-validation
    python3 bench/realdata/realdata.py sigma         # the model's sigma and the runs' disagreement
    python3 bench/realdata/realdata.py choice        # batch's default export (auto) against each candidate
    python3 bench/realdata/realdata.py all

Options: --data DIR (default ../shared/realdata/optiodom), --odocal BIN (default build/odocal),
--out DIR (default out/realdata). Every number comes from the odocal CLI (import, batch, explain,
check); this script only runs it and tabulates its JSON. Standard library only.
"""
import argparse
import json
import math
import os
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
PUBLISHED = os.path.join(HERE, "published")


def run(args, quiet=True):
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:
        sys.stderr.write(" ".join(args) + "\n" + r.stdout[-2000:] + r.stderr[-2000:])
        raise SystemExit(f"failed: {args[1]} (exit {r.returncode})")
    if not quiet:
        sys.stdout.write(r.stdout)
    return r.stdout


def load(path):
    with open(path) as f:
        return json.load(f)


def read_firmware(path):
    d = {}
    with open(path) as f:
        for line in f:
            line = line.split("#")[0].strip()
            if ":" in line:
                k, v = line.split(":", 1)
                d[k.strip()] = float(v)
    return d


class Bench:
    def __init__(self, a):
        self.odocal = os.path.abspath(a.odocal)
        self.data = os.path.abspath(a.data)
        self.out = os.path.abspath(a.out)
        self.sessions = os.path.join(self.out, "sessions")
        os.makedirs(self.out, exist_ok=True)
        if not os.path.isdir(self.sessions):
            run([self.odocal, "import", "optiodom", self.data, "--out", self.sessions])

    def sets(self, category):
        d = os.path.join(self.sessions, category)
        return sorted(s for s in os.listdir(d) if os.path.isfile(os.path.join(d, s, "session.yaml")))

    def session(self, category, name):
        return os.path.join(self.sessions, category, name, "session.yaml")

    def nominal(self, category, name):
        return load(self.batch(category, name))["trajectory_fit"]  # ensures the batch ran

    def batch(self, category, name, extra=(), tag=""):
        out = os.path.join(self.out, "batch", f"{category}_{name}{tag}")
        report = os.path.join(out, "report.json")
        if not os.path.exists(report) or extra:
            # --estimator umbmark: `corrected` is UMBMark's (the beliefs table reads it as such).
            run([self.odocal, "batch", self.session(category, name), "--out", out, "--estimator", "umbmark", *extra])
        return report

    # --- conventions -----------------------------------------------------------------
    def conventions(self):
        print("\n## UMBMark on the motion-capture rests vs the authors' UMBmark\n")
        print("| set | believed b, D [mm] | authors b, D_R, D_L [mm] | odocal first order (x) | "
              "odocal coupled | Δ track (first order, coupled) | Δ diameters max |")
        print("|---|---|---|---|---|---|---|")
        for name in self.sets("square"):
            rep = load(self.batch("square", name))
            u = rep["umbmark"]
            nominal_b = u["track_mm"]
            pub = read_firmware(os.path.join(PUBLISHED, f"umbmark_square_{name}.yaml"))
            sess = load_session_nominal(self.session("square", name))
            d = sess["left_wheel_diameter_mm"]
            fo = u["first_order_x"]
            b_fo = nominal_b * fo["Eb"]
            dr_fo, dl_fo = d * fo["c_right"], d * fo["c_left"]
            co = u["estimate"]
            b_co = nominal_b * co["Eb"]
            dr_co, dl_co = d * co["c_right"], d * co["c_left"]
            rel = lambda a, b: 100.0 * (a - b) / b
            dd = max(abs(rel(dr_fo, pub["right_wheel_diameter_mm"])), abs(rel(dl_fo, pub["left_wheel_diameter_mm"])),
                     abs(rel(dr_co, pub["right_wheel_diameter_mm"])), abs(rel(dl_co, pub["left_wheel_diameter_mm"])))
            print(f"| {name} | {nominal_b:.0f}, {d:.0f} | {pub['track_mm']:.3f}, {pub['right_wheel_diameter_mm']:.3f}, "
                  f"{pub['left_wheel_diameter_mm']:.3f} | {b_fo:.3f}, {dr_fo:.3f}, {dl_fo:.3f} | "
                  f"{b_co:.3f}, {dr_co:.3f}, {dl_co:.3f} | {rel(b_fo, pub['track_mm']):+.3f} %, "
                  f"{rel(b_co, pub['track_mm']):+.3f} % | {dd:.4f} % |")

    # --- sigma -----------------------------------------------------------------------
    def sigma(self):
        print("\n## How sure: the model's sigma and the runs' disagreement (trajectory fit, track)\n")
        print("| kind | set | runs | track [mm] | model sigma [mm] | between runs [mm] | ratio |")
        print("|---|---|---|---|---|---|---|")
        for kind in ("square", "ivanjko", "circular"):
            rows = []
            for name in self.sets(kind):
                fit = load(self.batch(kind, name))["trajectory_fit"]
                if "corrected" not in fit:
                    continue
                track, eb = fit["corrected"]["track_mm"], fit["Eb"]
                model = track * eb["sigma"] / eb["value"]
                between = eb.get("sigma_between_runs")
                between = None if between is None else track * between / eb["value"]
                rows.append((track, model, between))
                print(f"| {kind} | {name} | {fit.get('jackknife_runs', 0) or fit['runs_used']} | {track:.3f} | "
                      f"{model:.3f} | {'—' if between is None else f'{between:.3f}'} | "
                      f"{'—' if between is None else f'{between / model:.1f}'} |")
            pairs = [(a, b) for i, a in enumerate(rows) for b in rows[i + 1:] if a[2] and b[2]]
            if pairs:
                z_runs = max(abs(a[0] - b[0]) / math.hypot(a[2], b[2]) for a, b in pairs)
                z_model = max(abs(a[0] - b[0]) / math.hypot(a[1], b[1]) for a, b in pairs)
                print(f"| {kind} | largest pairwise difference | | | {z_model:.1f} sigma | {z_runs:.1f} sigma | |")

    # --- beliefs ---------------------------------------------------------------------
    def beliefs(self):
        print("\n## One robot, several beliefs: physical parameters from each set\n")
        print("| set | believed b, D [mm] | trajectory fit: track, D_R, D_L [mm] | UMBMark: track, D_R, D_L [mm] |")
        print("|---|---|---|---|")
        rows = {"trajectory": [], "umbmark": []}
        for cat in ("square", "ivanjko"):
            for name in self.sets(cat):
                rep = load(self.batch(cat, name))
                sess = load_session_nominal(self.session(cat, name))
                tf = rep.get("trajectory_fit", {}).get("corrected")
                um = rep.get("corrected") if "umbmark" in rep else None
                cells = []
                for key, p in (("trajectory", tf), ("umbmark", um)):
                    if p:
                        rows[key].append((p["track_mm"], p["right_wheel_diameter_mm"], p["left_wheel_diameter_mm"]))
                        cells.append(f"{p['track_mm']:.3f}, {p['right_wheel_diameter_mm']:.3f}, {p['left_wheel_diameter_mm']:.3f}")
                    else:
                        cells.append("—")
                print(f"| {cat}/{name} | {sess['track_mm']:.0f}, {sess['left_wheel_diameter_mm']:.0f} | {cells[0]} | {cells[1]} |")
        print("\nSpread over the sets (max − min; sample standard deviation):\n")
        for key, values in rows.items():
            if len(values) < 2:
                continue
            parts = []
            for i, label in enumerate(("track", "D_R", "D_L")):
                col = [v[i] for v in values]
                parts.append(f"{label} {max(col) - min(col):.3f} mm (sd {statistics.stdev(col):.3f})")
            print(f"- {key} ({len(values)} sets): " + ", ".join(parts))

    # --- held-out --------------------------------------------------------------------
    def train(self, label, members, explain=True):
        """Calibrates on the runs of `members` [(category, set)] (same beliefs): UMBMark, trajectory
        fit and explain, each written as a parameter file for check."""
        out = os.path.join(self.out, "train", label)
        os.makedirs(out, exist_ok=True)
        merged = os.path.join(out, "session.yaml")
        merge_sessions([self.session(c, n) for c, n in members], merged)
        files = {}
        run([self.odocal, "batch", merged, "--out", os.path.join(out, "batch"), "--estimator", "umbmark",
             "--export", "firmware", os.path.join(out, "umbmark.yaml")])
        if "umbmark" in load(os.path.join(out, "batch", "report.json")):
            files["odocal UMBMark"] = os.path.join(out, "umbmark.yaml")
        run([self.odocal, "batch", merged, "--out", os.path.join(out, "batch_traj"), "--estimator",
             "trajectory", "--export", "firmware", os.path.join(out, "trajectory.yaml")])
        files["odocal trajectory fit"] = os.path.join(out, "trajectory.yaml")
        if explain:
            if not os.path.exists(os.path.join(out, "explain", "explain.json")):
                run([self.odocal, "explain", merged, "--out", os.path.join(out, "explain")])
            files["odocal explain"] = os.path.join(out, "explain", "explain.json")
        return files

    def square_and_ivanjko_by_belief(self):
        """The square and Ivanjko sets grouped by the parameters the robot believed:
        {(track_mm, left_mm, right_mm): [(category, set), ...]}."""
        by_belief = {}
        for cat in ("square", "ivanjko"):
            for name in self.sets(cat):
                s = load_session_nominal(self.session(cat, name))
                key = (s["track_mm"], s["left_wheel_diameter_mm"], s["right_wheel_diameter_mm"])
                by_belief.setdefault(key, []).append((cat, name))
        return by_belief

    def heldout(self):
        print("\n## Held-out prediction: calibrate on squares and Ivanjko paths, check on the circles\n")
        by_belief = self.square_and_ivanjko_by_belief()
        # Per belief, the first square set and the first Ivanjko set recorded with it
        # (explain with cross-validation over all 40 runs of the 200/84 sets takes
        # half an hour; over 15 runs a few minutes). Explain on the sets whose
        # authors' fits were published (square 230620202042, Ivanjko 250620201618).
        candidates = {}
        for key, members in sorted(by_belief.items()):
            squares = [m for m in members if m[0] == "square"][:1]
            ivanjko = [m for m in members if m[0] == "ivanjko"][:1]
            if not squares or not ivanjko:
                continue
            label = f"b{key[0]:g}_d{key[1]:g}"
            chosen = squares + ivanjko
            names = "+".join(n for _, n in chosen)
            explain = ("square", "230620202042") in chosen
            for method, path in self.train(label, chosen, explain).items():
                candidates[f"{method} ({names})"] = path
        for f in sorted(os.listdir(PUBLISHED)):
            candidates["published " + f[:-5]] = os.path.join(PUBLISHED, f)
        circles = self.sets("circular")
        results = {name: [] for name in ["nominal", *candidates]}
        for circ in circles:
            args = [self.odocal, "check", self.session("circular", circ), "--out",
                    os.path.join(self.out, "check", circ)]
            names = {}
            for i, (name, path) in enumerate(candidates.items()):
                args += ["--params", f"set{i}={path}"]
                names[f"set{i}"] = name
            run(args)
            chk = load(os.path.join(self.out, "check", circ, "check.json"))
            for r in chk["runs"]:
                for res in r["results"]:
                    if res.get("ok"):
                        results[names.get(res["set"], res["set"])].append(
                            (res["final_position_error_mm"], abs(res["final_heading_error_deg"]), res["rms_error_mm"]))
        print(f"{sum(len(v) for v in results.values()) // max(1, len(results))} circle runs in {len(circles)} sets, "
              "none used in any calibration below (except the authors' own circular fit, in-sample).\n")
        print("| parameter set | final error max [mm] | mean [mm] | heading max [deg] | RMS trajectory mean [mm] |")
        print("|---|---|---|---|---|")
        for name, v in sorted(results.items(), key=lambda kv: statistics.mean(x[0] for x in kv[1]) if kv[1] else 1e9):
            if not v:
                continue
            print(f"| {name} | {max(x[0] for x in v):.1f} | {statistics.mean(x[0] for x in v):.1f} | "
                  f"{max(x[1] for x in v):.2f} | {statistics.mean(x[2] for x in v):.1f} |")

    # --- choice ----------------------------------------------------------------------
    def choice(self):
        """batch's default export (--estimator auto) against each candidate it chooses between,
        and the authors' published fits, on runs no calibration saw: train on each square set
        merged with an Ivanjko set of the same beliefs; check on the 32 circle runs (another
        kind, another day than the squares) and on the runs of the other three square sets."""
        print("\n## Which estimator: batch's default export against each candidate, on runs it never saw\n")
        by_belief = self.square_and_ivanjko_by_belief()
        trainings = []  # (label, square set, members)
        for key, members in sorted(by_belief.items()):
            ivanjko = [m for m in members if m[0] == "ivanjko"]
            squares = [m for m in members if m[0] == "square"]
            for i, sq in enumerate(squares):
                if not ivanjko:
                    continue
                iv = ivanjko[i % len(ivanjko)]
                trainings.append((f"{sq[1]}+{iv[1]}", sq[1], [sq, iv]))
        rows = []
        for label, square, members in trainings:
            out = os.path.join(self.out, "choice", label)
            os.makedirs(out, exist_ok=True)
            merged = os.path.join(out, "session.yaml")
            merge_sessions([self.session(c, n) for c, n in members], merged)
            files = {}
            for est in ("auto", "umbmark", "trajectory"):
                report = os.path.join(out, est, "report.json")
                if not os.path.exists(report):
                    run([self.odocal, "batch", merged, "--out", os.path.join(out, est), "--estimator", est,
                         "--export", "firmware", os.path.join(out, est + ".yaml")])
                files[est] = os.path.join(out, est + ".yaml")
            rep = load(os.path.join(out, "auto", "report.json"))
            ch = rep["estimator_choice"]
            # Not a candidate of auto: the mean of the two candidates' parameter sets, to see
            # whether a set between them would hold on both kinds of test runs.
            um, tr = read_firmware(files["umbmark"]), read_firmware(files["trajectory"])
            files["mean of the two"] = os.path.join(out, "mean_of_the_two.yaml")
            with open(files["mean of the two"], "w") as f:
                for k in ("left_wheel_diameter_mm", "right_wheel_diameter_mm", "track_mm", "ticks_per_rev"):
                    f.write(f"{k}: {0.5 * (um[k] + tr[k]):.9g}\n")
            sets = dict(files)
            for f in sorted(os.listdir(PUBLISHED)):
                sets["published " + f[:-5]] = os.path.join(PUBLISHED, f)
            tests = [("circles", "circular", n) for n in self.sets("circular")] + \
                    [("other squares", "square", n) for n in self.sets("square") if n != square]
            errors = {}  # (pool, set) -> {test run: final error mm}
            for pool, cat, name in tests:
                chk_dir = os.path.join(out, "check", f"{cat}_{name}")
                if not os.path.exists(os.path.join(chk_dir, "check.json")):
                    args = [self.odocal, "check", self.session(cat, name), "--out", chk_dir]
                    for k, path in sets.items():
                        args += ["--params", f"{k.replace(' ', '_')}={path}"]
                    run(args)
                chk = load(os.path.join(chk_dir, "check.json"))
                names = {k.replace(" ", "_"): k for k in sets}
                names["nominal"] = "nominal"
                for r in chk["runs"]:
                    for res in r["results"]:
                        if res.get("ok") and res["set"] in names:
                            errors.setdefault((pool, names[res["set"]]), {})[f"{cat}/{name}/{r['name']}"] = \
                                res["final_position_error_mm"]
            rows.append((label, ch, errors, list(sets)))

        def stat(v):
            v = list(v.values()) if isinstance(v, dict) else v
            m = statistics.mean(v)
            se = statistics.stdev(v) / math.sqrt(len(v)) if len(v) > 1 else 0.0
            return m, se, max(v)

        def paired(a, b):
            """mean and standard error of a − b over the test runs both were replayed on"""
            d = [a[k] - b[k] for k in a if k in b]
            return statistics.mean(d), statistics.stdev(d) / math.sqrt(len(d))

        print("Training: one square set (23 June) merged with an Ivanjko set (25 June) recorded with the same "
              "beliefs, through `odocal batch` (default `--estimator auto`, and `umbmark`, `trajectory` each "
              "exported); `auto`'s own figures are from its report.json. Test: `odocal check` on runs none of "
              "them saw. Final position error, mean ± standard error over the test runs (max). Within sigma: "
              "paired, auto − best run by run ≤ its standard error; unpaired, auto's mean ≤ best's mean + "
              "best's standard error:\n")
        pub_optiodom = [k for k in rows[0][3] if k.startswith("published optiodom_square")] if rows else []
        for pool in ("circles", "other squares"):
            print(f"\n### Test: {pool}\n")
            print("| training | auto chose, by (session: LOO trajectory − umbmark paired [mm]; travel scales apart) "
                  "| **default export (auto)** | umbmark | trajectory | best | auto − best, paired [mm] "
                  "| within sigma: paired / unpaired | authors' OptiOdom, mean of their 4 square fits | auto ÷ authors "
                  "| not a candidate: mean of the two sets (− best, paired) |")
            print("|---|---|---|---|---|---|---|---|---|---|---|")
            verdicts = []
            for label, ch, errors, names in rows:
                cand = {k: stat(errors[(pool, k)]) for k in ("auto", "umbmark", "trajectory") if (pool, k) in errors}
                if len(cand) < 3:
                    continue
                best = min(("umbmark", "trajectory"), key=lambda k: cand[k][0])
                d, d_se = paired(errors[(pool, "auto")], errors[(pool, best)])
                ok_paired = d <= d_se + 1e-9
                ok_unpaired = cand["auto"][0] <= cand[best][0] + cand[best][1] + 1e-9
                verdicts.append((ok_paired, ok_unpaired))
                rule = ch.get("rule") or {}
                if rule:
                    pd, sc = rule["paired_difference_mm"], rule["scale_difference"]
                    cvtxt = f"{pd['mean']:+.2f} ± {pd['sigma']:.2f}; {abs(sc['z']):.1f} σ"
                else:
                    cv = {c["name"]: c["heldout_final_error_mm"] for c in ch["candidates"]}
                    cvtxt = ", ".join(f"{cv[k]['mean']:.1f} ± {cv[k]['sigma']:.1f}" if cv.get(k) else "—"
                                      for k in ("umbmark", "trajectory"))
                pubs = [stat(errors[(pool, k)])[0] for k in pub_optiodom if (pool, k) in errors]
                pub = statistics.mean(pubs) if pubs else float("nan")
                f = lambda t: f"{t[0]:.1f} ± {t[1]:.1f} ({t[2]:.1f})"
                mean_of_two = "—"
                if (pool, "mean of the two") in errors:
                    b2, b2_se = paired(errors[(pool, "mean of the two")], errors[(pool, best)])
                    mean_of_two = f"{f(stat(errors[(pool, 'mean of the two')]))} ({b2:+.2f} ± {b2_se:.2f})"
                by = ch.get("basis", "fallback" if not ch["cross_validated"] else "one standard error")
                print(f"| {label} | {ch['chosen']}, {by} ({cvtxt}) | "
                      f"**{f(cand['auto'])}** | {f(cand['umbmark'])} | {f(cand['trajectory'])} | {best} | "
                      f"{d:+.2f} ± {d_se:.2f} | {'yes' if ok_paired else 'NO'} / {'yes' if ok_unpaired else 'NO'} | "
                      f"{pub:.1f} | {cand['auto'][0] / pub:.2f} | {mean_of_two} |")
            counts = sorted({len(errors[(pool, "auto")]) for _, _, errors, _ in rows if (pool, "auto") in errors})
            n = "–".join(str(c) for c in counts)
            print(f"\n{n} test runs per training; auto best or within sigma of the best in "
                  f"{sum(v[0] for v in verdicts)} of {len(verdicts)} trainings by the paired standard error, "
                  f"{sum(v[1] for v in verdicts)} of {len(verdicts)} by the best's unpaired one.")
            if pool != "circles":
                continue  # the other squares differ from training to training
            print("\nThe published sets and the nominal one on the same 32 circle runs:\n")
            print("| parameter set | final error mean ± SE [mm] | max [mm] |")
            print("|---|---|---|")
            allsets = {}
            for label, ch, errors, names in rows:
                for k in names:
                    if (pool, k) in errors and k.startswith("published"):
                        allsets[k] = errors[(pool, k)]
            allsets["nominal"] = []
            for label, ch, errors, names in rows:
                if (pool, "nominal") in errors:
                    allsets["nominal"] = errors[(pool, "nominal")]
            for k, v in sorted(allsets.items(), key=lambda kv: stat(kv[1])[0] if kv[1] else 1e9):
                if v:
                    m, se, mx = stat(v)
                    print(f"| {k} | {m:.1f} ± {se:.1f} | {mx:.1f} |")

    # --- explain ---------------------------------------------------------------------
    def explain(self):
        print("\n## What explain finds on this robot\n")
        print("| set | gap before → after [mm] | named (cross-validated held-out RMS before → after) | unexplained |")
        print("|---|---|---|---|")
        # One set of each kind, those whose authors' fits were published (explain
        # with cross-validation takes 1-4 min a set on two cores).
        for cat, name in (("square", "230620202042"), ("ivanjko", "250620201618"),
                          ("circular", "250620202104")):
            if name not in self.sets(cat):
                continue
            out = os.path.join(self.out, "explain", f"{cat}_{name}")
            if not os.path.exists(os.path.join(out, "explain.json")):
                run([self.odocal, "explain", self.session(cat, name), "--out", out])
            e = load(os.path.join(out, "explain.json"))
            named = []
            for step in e.get("steps", []):
                cv = step.get("cross_validation") or {}
                if cv.get("heldout_rms_before_mm") is not None:
                    named.append(f"{step['effect']} ({cv['heldout_rms_before_mm']:.2f} → {cv['heldout_rms_after_mm']:.2f})")
                else:
                    named.append(step["effect"])
            unexplained = []
            for u in e.get("unexplained", []) or []:
                unexplained.append(f"{u.get('where', '?')} {u.get('motion', '')} {u.get('size_mm', 0):.1f} mm")
            print(f"| {cat}/{name} | {e['gap_before_mm']:.2f} → {e['gap_after_mm']:.2f} | "
                  f"{', '.join(named) or '—'} | {'; '.join(unexplained[:3]) or '—'} |")


def load_session_nominal(path):
    """robot.nominal of a session.yaml written by odocal import (a one-line flow mapping)."""
    with open(path) as f:
        for line in f:
            s = line.strip()
            if s.startswith("nominal:"):
                body = s[s.index("{") + 1:s.rindex("}")]
                return {k.strip(): float(v) for k, v in (p.split(":") for p in body.split(","))}
    raise SystemExit(f"{path}: no robot.nominal")


def merge_sessions(paths, out_path):
    """One session of the runs of several pose-log sessions recorded with the same beliefs
    (paths made relative to the new file; run names prefixed by their set)."""
    header, runs, nominal = None, [], None
    out_dir = os.path.dirname(os.path.abspath(out_path))
    for p in paths:
        base = os.path.dirname(os.path.abspath(p))
        set_name = os.path.basename(base)
        with open(p) as f:
            lines = f.read().splitlines()
        n = next(l for l in lines if l.strip().startswith("nominal:"))
        if nominal is None:
            nominal = n
            header = [l for l in lines if not l.startswith("  - ")]
        elif n.strip() != nominal.strip():
            raise SystemExit(f"{p}: other believed parameters than {paths[0]}; not merged")
        for l in lines:
            if l.startswith("  - "):
                for key in ("poses: ", "telemetry: "):
                    i = l.find(key)
                    if i >= 0:
                        j = i + len(key)
                        k = min(x for x in (l.find(",", j), l.find("}", j)) if x >= 0)
                        rel = os.path.relpath(os.path.join(base, l[j:k].strip()), out_dir)
                        l = l[:j] + rel + l[k:]
                l = l.replace("name: ", f"name: {set_name}_", 1)
                runs.append(l)
    with open(out_path, "w") as f:
        f.write("\n".join(header) + "\n" + "\n".join(runs) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=["conventions", "beliefs", "heldout", "explain", "sigma", "choice", "all"])
    root = os.path.dirname(os.path.dirname(HERE))
    ap.add_argument("--data", default=os.path.join(root, "..", "shared", "realdata", "optiodom"))
    ap.add_argument("--odocal", default=os.path.join(root, "build", "odocal"))
    ap.add_argument("--out", default=os.path.join("out", "realdata"))
    a = ap.parse_args()
    b = Bench(a)
    for what in (["conventions", "beliefs", "heldout", "explain", "sigma", "choice"] if a.what == "all" else [a.what]):
        getattr(b, what)()


if __name__ == "__main__":
    main()
