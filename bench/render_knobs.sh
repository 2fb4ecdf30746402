#!/usr/bin/env bash
# The renderer's knobs and what they cost (docs/render.md, "Knobs and what they cost"): the Sun
# example rendered for a fixed number of passes with the defaults and with one knob changed at
# a time; prints a Markdown table of the wall time, the mean relative pixel error of the total
# and of each component, and the total flux with its error.
#
#   bench/render_knobs.sh [build/veil] [passes]
set -euo pipefail
cd "$(dirname "$0")/.."
veil=${1:-build/veil}
passes=${2:-8}
scene=examples/scenes/longfocus_360mm_sun.toml
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT

knobs=(
  ""
  "--rays-per-pixel 4"
  "--photons 25k"
  "--photons 400k"
  "--ghost-photons 4096"
  "--ghost-photons 65536"
  "--photon-points random"
  "--radius 0.5"
  "--radius 4"
  "--alpha 0.9"
  "--backward split"
  "--area-samples 0"
  "--guide 0"
  "--guide 0.9"
)
echo "| knob | time (s) | total | visible | caustic | secondary | total flux (W) |"
echo "| --- | ---: | ---: | ---: | ---: | ---: | --- |"
for k in "${knobs[@]}"; do
  dir="$out/run"
  rm -rf "$dir"
  # shellcheck disable=SC2086
  "$veil" render "$scene" --passes "$passes" --time-limit none --quiet -o "$dir" $k > /dev/null
  python3 - "$dir/summary.json" "${k:-defaults}" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
pct = lambda v: "-" if v is None else f"{100 * v:.1f} %"
c = s["components"]
print(f"| {sys.argv[2]} | {s['seconds_this_run']:.1f} | {pct(s['mean_relative_error'])} | "
      f"{pct(c['visible']['mean_relative_error'])} | {pct(c['caustic']['mean_relative_error'])} | "
      f"{pct(c['secondary']['mean_relative_error'])} | "
      f"{s['total']['flux']:.4e} +- {pct(s['total']['relative_error'])} |")
EOF
done
