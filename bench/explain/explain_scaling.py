#!/usr/bin/env python3
"""explain's cost against the number of runs (issue 26 section 1; docs/performance.md, "explain").

Imports the OptiOdom sets (../shared/realdata/optiodom), pools the runs of the sets recorded with
the same beliefs (84 mm wheels, 200 mm track: 56 runs, ~1800 poses each) into one session in a
fixed order, and cuts it to each size asked for; beyond 56 runs the runs repeat, renamed
(c1_..., c2_...). Each size is explained by each binary under /usr/bin/time -v: wall, CPU
(user + system), peak memory, and the effects named.

  python3 bench/explain/explain_scaling.py --runs 10 20 40 80 160
  python3 bench/explain/explain_scaling.py --runs 10 20 --odocal build/odocal /tmp/odocal.before
"""
import argparse
import os
import re
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "bench", "realdata"))
from realdata import merge_sessions  # noqa: E402

# The sets of one belief (84 mm wheels, 200 mm track), squares first.
SETS = ["square/230620202317", "square/230620202042", "ivanjko/250620201738",
        "ivanjko/250620201618", "circular/250620202251", "circular/250620202104"]


def repeated_files(line, out, k):
    """A repeated run reads copies of its files: runs that share a recording are cut from it by
    time, so two runs naming one file would be taken for one recording."""
    for key in ("poses: ", "telemetry: "):
        i = line.find(key)
        if i < 0:
            continue
        j = i + len(key)
        end = min(x for x in (line.find(",", j), line.find("}", j)) if x >= 0)
        source = os.path.join(out, line[j:end].strip())
        copy = os.path.join("repeats", f"{k}_{os.path.basename(source)}")
        os.makedirs(os.path.join(out, "repeats"), exist_ok=True)
        shutil.copyfile(source, os.path.join(out, copy))
        line = line[:j] + copy + line[end:]
    return line


def pooled_session(imported, out, n):
    """A session of the first n pooled runs (repeated, renamed, past the last)."""
    os.makedirs(out, exist_ok=True)
    all_path = os.path.join(out, "all.yaml")
    merge_sessions([os.path.join(imported, s, "session.yaml") for s in SETS], all_path)
    with open(all_path) as f:
        lines = f.read().splitlines()
    header = [l for l in lines if not l.startswith("  - ")]
    runs = [l for l in lines if l.startswith("  - ")]
    chosen = []
    for k in range(n):
        line = runs[k % len(runs)]
        if k >= len(runs):
            line = line.replace("name: ", f"name: c{k // len(runs)}_", 1)
            line = repeated_files(line, out, k)
        chosen.append(line)
    path = os.path.join(out, "session.yaml")
    with open(path, "w") as f:
        f.write("\n".join(header + chosen) + "\n")
    return path


def timed(cmd):
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{p.stderr[-2000:]}")
    def field(name):
        return re.search(re.escape(name) + r": (.*)", p.stderr).group(1).strip()
    wall = field("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":")
    wall_s = sum(float(x) * 60 ** i for i, x in enumerate(reversed(wall)))
    cpu_s = float(field("User time (seconds)")) + float(field("System time (seconds)"))
    peak_mb = int(field("Maximum resident set size (kbytes)")) / 1024
    effects = [l[2:].split(":")[0] for l in p.stdout.splitlines() if l.startswith("+ ")]
    return wall_s, cpu_s, peak_mb, effects


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, nargs="+", default=[10, 20, 40, 80, 160])
    ap.add_argument("--odocal", nargs="+", default=[os.path.join(ROOT, "build", "odocal")])
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "realdata", "optiodom"))
    ap.add_argument("--out", default=os.path.join("out", "explain_scaling"))
    ap.add_argument("--threads", type=int, default=0, help="explain --threads (0: one per core)")
    a = ap.parse_args()
    imported = os.path.join(a.out, "od")
    if not os.path.isdir(imported):
        subprocess.run([a.odocal[0], "import", "optiodom", a.data, "--out", imported], check=True,
                       capture_output=True)
    print("| runs | binary | wall | CPU | peak memory | effects named | load average before |")
    print("|---|---|---|---|---|---|---|")
    for n in a.runs:
        session = pooled_session(imported, os.path.join(a.out, f"runs{n}"), n)
        for b, binary in enumerate(a.odocal):
            out = os.path.join(a.out, f"runs{n}", f"explain{b}")
            cmd = [binary, "explain", session, "--out", out, "--no-record"]
            if a.threads:
                cmd += ["--threads", str(a.threads)]
            load = os.getloadavg()[0]  # other work on the machine stretches the wall time
            wall, cpu, peak, effects = timed(cmd)
            print(f"| {n} | {binary} | {wall:.1f} s | {cpu:.1f} s | {peak:.0f} MB | "
                  f"{', '.join(effects) or 'none'} | {load:.1f} |", flush=True)


if __name__ == "__main__":
    main()
