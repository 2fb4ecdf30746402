#!/usr/bin/env bash
# The seed paper's dark-mount claim: the renderer's cost does not depend on how dark the
# mounts are, where forward Monte Carlo's grows as they darken. A scene of the 6-lens lens
# with the Sun 7 degrees off axis, its mounts' Lambertian reflectance set to 0.1 %, 5 % and
# 30 %; for each, veil_render_vs_trace_bench runs the renderer and forward Monte Carlo for the
# same wall time on the scattered light and extrapolates each one's time to 5 % mean pixel
# error (docs/performance.md, "Dark mounts"). Two base scenes:
#   fig10a  examples/scenes/seed_fig10a_mounts_lambertian.toml: ideal AR lens faces, mounts,
#           butt ends and flats all at the reflectance: every scattered photon met them
#   sun     examples/scenes/longfocus_360mm_sun.toml: uncoated faces, 50/50 ground butt ends
#           and a 10 % stop edge kept; only the black anodised mounts change
#
#   bench/dark_mounts.sh [fig10a|sun] [build/bench/veil_render_vs_trace_bench] [seconds] [criterion]
#
# The criterion selects the light both methods image (default `scatter`, all scattered light;
# `scatter{2}`: light scattered exactly twice, the same paths at every reflectance).
set -euo pipefail
cd "$(dirname "$0")/.."
base=${1:-fig10a}
bench=${2:-build/bench/veil_render_vs_trace_bench}
seconds=${3:-120}
where=${4:-scatter}
case "$base" in
  fig10a) example=examples/scenes/seed_fig10a_mounts_lambertian.toml; property=mount ;;
  sun) example=examples/scenes/longfocus_360mm_sun.toml; property=black_anodized ;;
  *) echo "dark_mounts.sh: unknown base scene '$base' (fig10a or sun)" >&2; exit 2 ;;
esac
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
lens=$(pwd)/examples/lenses/longfocus_360mm.toml

for reflectance in 0.001 0.05 0.30; do
  scene="$out/${base}_mounts_$reflectance.toml"
  # The example with an absolute lens path and the mounts' reflectance replaced; the
  # replacement is checked, so a changed example cannot make this silently measure nothing.
  sed -e "s|^lens = .*|lens = \"$lens\"|" \
      -e "/^\[properties.$property\]/,/^\[/ s|reflectance = 0.05|reflectance = $reflectance|" \
      "$example" > "$scene"
  grep -q "model = \"lambertian\", reflectance = $reflectance }" "$scene" ||
    { echo "dark_mounts.sh: could not set the mounts' reflectance in $scene" >&2; exit 1; }
  echo "## $base, mounts $reflectance (Lambertian reflectance), $seconds s per method, light '$where'"
  "$bench" "$scene" "$seconds" "" "$where"
  echo
done
