#!/usr/bin/env bash
# The cost of a heat run against the part's size (docs/PERFORMANCE.md "Parts at full scale").
# `simulate` of closed hemispheres (2 mm edges, the fitted plate, outputs off), each model with
# and without its cost cut (the thin wall's reference: every node every step, the plate's
# uniform grid), one run at a time; one row each into scaling.csv beside this file:
#   model,mode,radius_mm,bead_m,deposits,wall_s,peak_mb
# wall_s is the whole command's (plan, heat, files), peak_mb its peak resident memory.
# COMMAND=dwell runs `waamtwin dwell --no-baselines` instead (the dwell plan: the search, its
# yardstick and bound, the runs without and with the dwells); its rows' mode is "dwell-" and the
# mode they were run with.
# GPU=NAME runs the voxel model alone with `device = "gpu"` and its plate uncut (what the GPU
# asks), one row a dome with mode "gpu-NAME" (NAME the device's: "gpu-H200"), on the binary BIN (a
# build with `--features gpu`, carried to the GPU's machine) instead of building one.
# Usage: [MODELS="thin-wall voxel"] [MODES="reference cut"] [COMMAND=simulate|dwell] [KEEP=DIR]
#        [GPU=NAME BIN=PATH] docs/scaling/measure.sh [RADIUS_MM ...]   (default 50 100 200; rows
#        are appended; the binary is BIN, else $CARGO_TARGET_DIR's, else target/'s)
# Then: cargo run --release -p sim --example scaling_plot -- docs/scaling/scaling.csv docs/img/scaling.png
set -euo pipefail
cd "$(dirname "$0")/../.."
cases=("thin-wall reference local_steps=false,merge_plate=false" "thin-wall cut local_steps=true"
  "voxel reference coarse_plate=false" "voxel cut coarse_plate=true")
device=cpu
device_key=""
if [ -n "${GPU:-}" ]; then
  [ -n "${BIN:-}" ] || { echo "GPU=$GPU: expected BIN=PATH, a build with --features gpu" >&2; exit 2; }
  cases=("voxel gpu-$GPU coarse_plate=false")
  device=gpu
  device_key='device = "gpu"'
fi
if [ -n "${BIN:-}" ]; then
  bin="$BIN"
else
  cargo build --release -p sim --bin waamtwin
  bin="${CARGO_TARGET_DIR:-target}/release/waamtwin"
fi
command="${COMMAND:-simulate}"
case "$command" in
  simulate) extra=() ;;
  dwell) extra=(--no-baselines) ;;
  *) echo "COMMAND=$command: expected simulate or dwell" >&2; exit 2 ;;
esac
radii=("$@")
[ $# -eq 0 ] && radii=(50 100 200)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
table=docs/scaling/scaling.csv
[ -f "$table" ] || echo "model,mode,radius_mm,bead_m,deposits,wall_s,peak_mb" >"$table"
for r in "${radii[@]}"; do
  for case in "${cases[@]}"; do
    read -r model mode key <<<"$case"
    [[ " ${MODELS:-thin-wall voxel} " == *" $model "* ]] || continue
    [[ $device == gpu || " ${MODES:-reference cut} " == *" $mode "* ]] || continue
    cat >"$work/s.toml" <<TOML
[part]
shape = "hemisphere"
radius_mm = $r.0
edge_mm = 2.0
[thermal]
model = "$model"
$(tr , '\n' <<<"${key//=/ = }")
$device_key
[output]
rerun = false
mcap = false
hdf5 = false
plots = false
report = false
frames = 0
TOML
    rm -rf "$work/out"
    /usr/bin/time -f "%e %M" -o "$work/time" "$bin" "$command" "$work/s.toml" "${extra[@]}" \
      -o "$work/out" >"$work/log" 2>&1 || { cat "$work/log"; exit 1; }
    if [ "$command" = dwell ]; then mode="dwell-$mode"; fi
    read -r wall kb <"$work/time"
    stats=$(python3 -c "
import csv, json, math, sys
p = json.load(open('$work/out/plan.json'))
rows = list(csv.DictReader(open('$work/out/path.csv')))
xyz = [[float(r[k]) for k in ('x', 'y', 'z')] for r in rows]
bead = sum(math.dist(a, b) for a, b in zip(xyz, xyz[1:])) / 1e3
print(f'{bead:.2f} {p[\"n_points\"]}')")
    read -r bead n <<<"$stats"
    echo "$model,$mode,$r,$bead,$n,$wall,$((kb / 1024))" | tee -a "$table"
    # KEEP=DIR keeps each run's layers.csv, path.csv and thermal.json (the heat run's own wall_s),
    # to compare a cut run with its reference.
    if [ -n "${KEEP:-}" ]; then
      mkdir -p "$KEEP/$model-$mode-$r"
      cp "$work/out/layers.csv" "$work/out/path.csv" "$work/out/thermal.json" "$KEEP/$model-$mode-$r/"
    fi
  done
done
