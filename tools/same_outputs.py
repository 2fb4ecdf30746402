#!/usr/bin/env python3
"""Fixed-seed outputs of every example, to show that a change left them byte for byte alone.

    tools/same_outputs.py run VEIL DIR        run VEIL (the executable) on every example into DIR
                                              (a new or empty folder)
    tools/same_outputs.py compare DIR1 DIR2   compare two such folders file by file (cmp)

What `run` writes, per example scene (examples/scenes/*.toml): a forward trace (EXR, PNG,
summary), a 3-pass render (checkpoint, EXR, PNGs, summary), and for every example lens and
Zemax file the ghost table and `info` (text and JSON); then sweeps (trace, render, ghosts),
PSTs (forward and rendered), `objects`, a ghost coating what-if, `glare` and `scatter`. Every
command has a fixed seed and runs on 2 threads (veil's results do not depend on the thread
count).

Clocks are the one thing two runs may differ in: `compare` drops JSON members whose name says
they are a time (`seconds`, `*_seconds*`), the run manifest `veil-run.json` (its id and time,
and file sizes that follow from the rest), the `seconds` column of sweep tables, and durations,
rates and trailing blanks in what the commands print (NAME.stdout); everything else must be the
same bytes.
Exit status 0 when every file matches, 1 otherwise. Used before and after a change that must
not alter a result (a move, a refactor): run it with the old and the new executable.
"""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEED = "7"


def jobs(veil):
    scenes = sorted((ROOT / "examples/scenes").glob("*.toml"))
    lenses = sorted((ROOT / "examples/lenses").glob("*.toml")) + sorted(
        (ROOT / "examples/zmx").glob("*.zmx"))
    common = ["--seed", SEED, "--threads", "2", "--quiet"]
    for s in scenes:
        yield f"trace/{s.stem}", [veil, "trace", str(s), "-n", "2k"] + common
        yield f"render/{s.stem}", [
            veil, "render", str(s), "--passes", "3", "--photons", "4k", "--rays-per-pixel", "2",
            "--time-limit", "none"] + common
    for lens in lenses:
        yield f"ghosts/{lens.stem}", [veil, "ghosts", str(lens), "-n", "1k", "--no-images",
                                      "--top", "0"] + common
        yield f"info/{lens.stem}.json", [veil, "info", str(lens), "--json"]
        yield f"info/{lens.stem}.txt", [veil, "info", str(lens)]
    sun = str(ROOT / "examples/scenes/longfocus_360mm_sun.toml")
    dg = str(ROOT / "examples/scenes/double_gauss_50mm.toml")
    yield "sweep/trace", [
        veil, "sweep", sun, "--vary", "properties.black_anodized.scatter.reflectance=0.01,0.05",
        "-n", "1k", "--batches", "3", "--where", "scatter"] + common
    yield "sweep/ghosts", [veil, "sweep", dg, "--vary", "system.surfaces.2.coating=ideal_ar",
                           "--measure", "ghosts"] + common
    yield "pst/trace", [veil, "pst", dg, "--angles", "0:40:20", "-n", "1k", "--batches",
                        "3"] + common
    yield "pst/render", [veil, "pst", sun, "--angles", "6,9", "--measure", "render",
                         "--batches", "2", "--photons", "3k", "--rays-per-pixel", "1"] + common
    yield "render/sun_criteria", [veil, "render", sun, "--passes", "2", "--photons", "4k",
                                  "--rays-per-pixel", "2", "--where", "scatter",
                                  "--where", "fresnel{2}", "--time-limit", "none"] + common
    yield "render/fig13_split_pruned", [
        veil, "render", str(ROOT / "examples/scenes/seed_fig13_butt_ends.toml"), "--passes", "2",
        "--photons", "4k", "--rays-per-pixel", "2", "--backward", "split", "--where",
        "scatter(L*.edge)", "--prune", "--photon-points", "random", "--time-limit", "none"] + common
    yield "objects/sun", [veil, "objects", sun, "-n", "2k"] + common
    yield "ghosts/double_gauss_images", [veil, "ghosts", dg, "-n", "1k", "--top", "3"] + common
    yield "ghosts/double_gauss_whatif", [veil, "ghosts", str(ROOT / "examples/lenses/double_gauss_50mm.toml"),
                                         "-n", "1k", "--no-images", "--coating", "L3.*=ideal_ar"] + common
    yield "glare/singlet", [veil, "glare", str(ROOT / "examples/lenses/singlet.toml"), "--field", "0,0",
                            "--field", "0,3.5", "--passes", "3", "--photons", "5k",
                            "--rays-per-pixel", "16"] + common
    yield "scatter/painted", [veil, "scatter", str(ROOT / "examples/scenes/double_gauss_50mm_painted.toml")]
    yield "sweep/render", [veil, "sweep", sun, "--vary", "properties.black_anodized.scatter.reflectance=0.01,0.05",
                           "--measure", "render", "--batches", "2", "--photons", "3k",
                           "--rays-per-pixel", "1"] + common


def run(veil, out):
    # Commands run inside DIR with relative output paths, so that what they print (kept as
    # NAME.stdout) does not depend on where DIR is.
    out = Path(out).resolve()
    if out.exists() and any(out.iterdir()):
        # A sweep resumes the variants it finds: every run starts from an empty folder.
        print(f"{out} is not empty: give a new folder", file=sys.stderr)
        return 2
    out.mkdir(parents=True, exist_ok=True)
    failed = 0
    for name, cmd in jobs(str(Path(veil).resolve())):
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        if name.endswith((".json", ".txt")):  # what the command prints is the output
            with open(out / name, "w") as f:
                rc = subprocess.run(cmd, stdout=f, cwd=out).returncode
        else:
            with open(out / (name + ".stdout"), "w") as f:
                rc = subprocess.run(cmd + ["-o", name], stdout=f, cwd=out).returncode
        print(f"{name}: exit {rc}", flush=True)
        failed += rc != 0
    return 1 if failed else 0


CLOCK = re.compile(r"(^|_)seconds($|_)")
# Durations and rates in printed text: "1.2 s", "3m04s", "12 ms", "8.1e+05 photons/s".
TEXT_CLOCK = re.compile(r"\b\d+(\.\d+)?(e[+-]?\d+)?\s?(h|min|ms|s|m\d+s|[a-z]+/s)\b")


def without_clocks(value):
    if isinstance(value, dict):
        return {k: without_clocks(v) for k, v in value.items() if not CLOCK.search(k)}
    if isinstance(value, list):
        return [without_clocks(v) for v in value]
    return value


def comparable(path):
    data = path.read_bytes()
    if path.suffix == ".json":
        try:
            return json.dumps(without_clocks(json.loads(data)), sort_keys=False).encode()
        except ValueError:
            return data
    if path.suffix == ".stdout":
        # Trailing blanks are invisible on a terminal: not a difference.
        text = TEXT_CLOCK.sub("<clock>", data.decode())
        return "\n".join(l.rstrip() for l in text.split("\n")).encode()
    if path.suffix in (".csv", ".md") and b"seconds" in data:
        # Drop the column headed 'seconds' (sweep tables).
        lines = data.decode().splitlines()
        sep = "," if path.suffix == ".csv" else "|"
        head = [c.strip() for c in lines[0].split(sep)] if lines else []
        if "seconds" in head:
            i = head.index("seconds")
            lines = [sep.join(c for j, c in enumerate(l.split(sep)) if j != i) for l in lines]
        return "\n".join(lines).encode()
    return data


def compare(a, b):
    a, b = Path(a), Path(b)
    files = lambda d: {p.relative_to(d) for p in d.rglob("*")
                       if p.is_file() and p.name != "veil-run.json"}
    fa, fb = files(a), files(b)
    bad = 0
    for f in sorted(fa ^ fb):
        print(f"only in {'the first' if f in fa else 'the second'}: {f}")
        bad += 1
    for f in sorted(fa & fb):
        if comparable(a / f) != comparable(b / f):
            print(f"differs: {f}")
            bad += 1
    print(f"{len(fa & fb)} files compared, {bad} differences")
    return 1 if bad else 0


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "run":
        sys.exit(run(sys.argv[2], sys.argv[3]))
    if len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    print(__doc__, file=sys.stderr)
    sys.exit(2)
