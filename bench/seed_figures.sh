#!/usr/bin/env bash
# The renderer on the seed paper's studies (issue 42's bench): for each scene, `veil render`
# on its default settings for a fixed wall time, the stray light it was asked for (`--where`,
# the row's criterion) as the target, then per row the flux with its error (the radius bias
# included when detected), the mean pixel error reached, the time to 5 % extrapolated from it
# (t (e / 5 %)^(2 / alpha), the progressive rate with alpha = 2/3) and the agreement with a
# long forward Monte Carlo reference (bench/seed_figures_reference.tsv, computed once with the
# command stored there): z = (render - reference) / sqrt(sigma_r^2 + sigma_f^2).
#
#   bench/seed_figures.sh [build/veil] [seconds per row] [rows...]
#
# SEED_FIGURES_ARGS: more options for every row's render (a knob against the defaults, such as
# "--photons 100k").
# Rows: sun fig09_15deg fig10a fig10b fig12 fig13 catadioptric_butt_ends mounts_0.1 mounts_5
# mounts_30 (all by default). Prints a markdown table for docs/performance.md.
set -euo pipefail
cd "$(dirname "$0")/.."
veil=${1:-build/veil}
seconds=${2:-600}
shift $(( $# > 2 ? 2 : $# ))
rows=("$@")
[ ${#rows[@]} -gt 0 ] || rows=(sun fig09_15deg fig10a fig10b fig12 fig13 catadioptric_butt_ends mounts_0.1 mounts_5 mounts_30)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
lens=$(pwd)/examples/lenses/longfocus_360mm.toml

mounts() {  # the figure 10a scene with its mounts' Lambertian reflectance set
  local scene="$out/mounts_$1.toml"
  sed -e "s|^lens = .*|lens = \"$lens\"|" \
      -e "/^\[properties.mount\]/,/^\[/ s|reflectance = 0.05|reflectance = $1|" \
      examples/scenes/seed_fig10a_mounts_lambertian.toml > "$scene"
  grep -q "model = \"lambertian\", reflectance = $1 }" "$scene" ||
    { echo "seed_figures.sh: could not set the mounts' reflectance in $scene" >&2; exit 1; }
  echo "$scene"
}

echo "| row | passes | time (s) | flux | mean pixel error | time to 5 % (s) | reference | z |"
echo "| --- | ---: | ---: | --- | ---: | ---: | --- | ---: |"
for row in "${rows[@]}"; do
  where=scatter
  extra=()
  case "$row" in
    sun) scene=examples/scenes/longfocus_360mm_sun.toml ;;
    fig09_15deg) scene=examples/scenes/seed_fig09_stop_edge.toml; extra=(--field 0,15) ;;
    fig10a) scene=examples/scenes/seed_fig10a_mounts_lambertian.toml ;;
    fig10b) scene=examples/scenes/seed_fig10b_mounts_gaussian.toml ;;
    fig12) scene=examples/scenes/seed_fig12_catadioptric.toml ;;
    fig13) scene=examples/scenes/seed_fig13_butt_ends.toml ;;
    catadioptric_butt_ends) scene=examples/scenes/catadioptric_2000mm_window.toml
                            where="scatter(L*.edge | L*.flat*)" ;;
    mounts_0.1) scene=$(mounts 0.001) ;;
    mounts_5) scene=$(mounts 0.05) ;;
    mounts_30) scene=$(mounts 0.30) ;;
    *) echo "seed_figures.sh: unknown row '$row'" >&2; exit 2 ;;
  esac
  # shellcheck disable=SC2086  # the knobs split into words
  "$veil" render "$scene" "${extra[@]}" ${SEED_FIGURES_ARGS:-} --where "$where" --target-on where1 \
      --time-limit "${seconds}s" --quiet --json -o "$out/$row" > "$out/$row.json"
  python3 - "$out/$row.json" "$row" bench/seed_figures_reference.tsv <<'PY'
import json, math, sys
s = json.load(open(sys.argv[1]))
row = sys.argv[2]
ref = {}
for line in open(sys.argv[3]):
    if line.startswith("#") or not line.strip():
        continue
    f = line.rstrip("\n").split("\t")
    ref[f[0]] = f
c = s["criteria"][0]
flux, rel = c["flux"], c["relative_error"]
err = c["mean_relative_error"]
t = s["seconds_this_run"]
alpha = s["options"]["alpha"]
to5 = t * (err / 0.05) ** (2.0 / alpha) if err is not None else float("inf")
unit = s["unit"]
bias = c.get("radius_bias", {})  # absent before the radius bias was measured
note = ""
if bias.get("detected"):
    note = ", bias detected" + ("" if bias.get("bounded", True) else ", not bounded")
if s.get("few_photons"):
    note += f", few photons ({s['gathered_effective_photons']:.0f})"
z = "-"
refText = "-"
r = ref.get(row)
if r and r[1] != "-":
    rf, rr = float(r[1]), float(r[2])
    refText = f"{rf:.3e} +- {100 * rr:.1f} %"
    if rel is not None:
        z = f"{(flux - rf) / math.hypot(flux * rel, rf * rr):+.1f}"
relText = f"{100 * rel:.1f} %" if rel is not None else "-"
errText = f"{100 * err:.1f} %" if err is not None else "-"
print(f"| {row} | {s['passes']} | {t:.0f} | {flux:.3e} {unit} +- {relText}{note} | {errText} | {to5:.2e} | {refText} | {z} |")
PY
done
