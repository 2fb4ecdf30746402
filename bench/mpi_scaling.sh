#!/usr/bin/env bash
# veil render across MPI ranks on this machine (docs/scaling.md, docs/performance.md): a
# render at fixed passes with K ranks of one thread each (K = 1, 2 and, oversubscribed on a
# 2-core machine, 4) and with one rank of two threads, the same seed, so every run computes
# the same image (the script checks that the EXRs are identical). Per run: the whole
# process's wall time (scene built on every rank), the pass loop's, its backward and photon
# stages (summary.json), and what rank 0 moved and waited in MPI calls (summary.json "ranks").
#
#   bench/mpi_scaling.sh [SCENE] [PASSES] [PHOTONS] [RAYS_PER_PIXEL]
#
# Needs a veil built with MPI in build/ and mpirun; as root, OMPI_ALLOW_RUN_AS_ROOT=1 and
# OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 are set here.
set -euo pipefail
cd "$(dirname "$0")/.."
scene=${1:-examples/scenes/longfocus_360mm_sun.toml}
passes=${2:-4}
photons=${3:-100k}
rpp=${4:-16}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
args=(render "$scene" --passes "$passes" --photons "$photons" --rays-per-pixel "$rpp"
      --time-limit none --seed 1 --quiet)
echo "# $(date -u +%F) $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg); $scene," \
     "$passes passes, $photons photons, $rpp rays per pixel"
printf '| ranks x threads | process wall (s) | pass loop (s) | backward (s) | photons (s) | s per pass | rank 0 received (MB) | rank 0 in MPI calls (s) |\n'
printf '| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n'
run() {
  local ranks=$1 threads=$2 dir="$out/k$1t$2"
  local start end
  start=$(date +%s.%N)
  if [ "$ranks" -eq 1 ]; then
    ./build/veil "${args[@]}" --threads "$threads" -o "$dir" > /dev/null
  else
    mpirun -np "$ranks" --oversubscribe --bind-to none ./build/veil "${args[@]}" \
      --threads "$threads" -o "$dir" > /dev/null
  fi
  end=$(date +%s.%N)
  python3 - "$dir/summary.json" "$ranks" "$threads" "$start" "$end" "$passes" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
ranks, threads, start, end, passes = sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), int(sys.argv[6])
r = s.get("ranks", {})
loop = s["seconds_this_run"]
print(f"| {ranks} x {threads} | {end - start:.1f} | {loop:.1f} | {s['backward_seconds_this_run']:.1f} | "
      f"{s['photon_seconds_this_run']:.1f} | {loop / passes:.2f} | "
      f"{r.get('rank0_bytes_received', 0) / 1e6:.1f} | {r.get('rank0_seconds_in_mpi', 0):.2f} |")
PY
}
run 1 1
run 2 1
run 4 1
run 1 2
for d in "$out"/k2t1 "$out"/k4t1 "$out"/k1t2; do
  cmp -s "$out/k1t1/render.checkpoint" "$d/render.checkpoint" ||
    { echo "error: $d differs from one process" >&2; exit 1; }
done
echo "(every run's checkpoint bitwise the one-process run's)"
