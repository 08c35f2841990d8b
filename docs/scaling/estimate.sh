#!/usr/bin/env bash
# The cost estimate against the runs it estimates (docs/PERFORMANCE.md "Cost estimates"): runs
# `waamtwin COMMAND` (simulate, or dwell --no-baselines) on each part, every output off, one at
# a time, and prints a CSV row each:
#   name,command,wall_s,peak_mb,est_cells,est_steps,est_updates,est_s,cell_updates,heat_s,search_wall_s
# est_* from the estimate's line on stderr (est_s as rounded there), cell_updates and heat_s
# from thermal.json (the heat model's work and seconds), search_wall_s from dwell.json.
# A part is a scenario of scenarios/ (its name) or domeR, the closed hemisphere of radius R mm
# that measure.sh runs on the thin wall (vdomeR: on the voxel model, its plate coarsened).
# Usage: [BIN=PATH] [RAYON_NUM_THREADS=N] docs/scaling/estimate.sh COMMAND PART...
#   e.g. docs/scaling/estimate.sh simulate dome50 dome100 vase.toml cone_frustum.toml
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-${CARGO_TARGET_DIR:-target}/release/waamtwin}"
[ -x "$bin" ] || { echo "$bin: expected the waamtwin binary (cargo build --release -p sim --bin waamtwin, or BIN=PATH)" >&2; exit 2; }
command=${1:?"expected COMMAND (simulate or dwell) and parts"}
shift
case "$command" in
  simulate) extra=() ;;
  dwell) extra=(--no-baselines) ;;
  *) echo "COMMAND=$command: expected simulate or dwell" >&2; exit 2 ;;
esac
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
ln -s "$PWD/scenarios/parts" "$work/parts"
echo "name,command,wall_s,peak_mb,est_cells,est_steps,est_updates,est_s,cell_updates,heat_s,search_wall_s"
for part in "$@"; do
  case "$part" in
    vdome*) printf '[part]\nshape = "hemisphere"\nradius_mm = %s.0\nedge_mm = 2.0\n[thermal]\nmodel = "voxel"\ncoarse_plate = true\n' "${part#vdome}" >"$work/s.toml" ;;
    dome*) printf '[part]\nshape = "hemisphere"\nradius_mm = %s.0\nedge_mm = 2.0\n[thermal]\nmodel = "thin-wall"\n' "${part#dome}" >"$work/s.toml" ;;
    *) [ -f "scenarios/$part" ] || { echo "$part: expected domeR, vdomeR or a scenario of scenarios/" >&2; exit 2; }
       cp "scenarios/$part" "$work/s.toml" ;;
  esac
  printf '[output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\nreport = false\nframes = 0\n' >>"$work/s.toml"
  rm -rf "$work/out"
  /usr/bin/time -f "%e %M" -o "$work/time" "$bin" "$command" "$work/s.toml" "${extra[@]}" \
    -o "$work/out" >"$work/log" 2>&1 || { cat "$work/log" >&2; exit 1; }
  read -r wall kb <"$work/time"
  python3 - "$part" "$command" "$wall" "$kb" "$work" <<'PY'
import json, os, re, sys
part, command, wall, kb, work = sys.argv[1:]
line = next(l for l in open(os.path.join(work, "log")) if l.startswith("estimate:"))
n = re.findall(r"([0-9.]+e[+-]?[0-9]+)", line)
m = re.search(r"about ([0-9.]+) (s|min|h|days)", line)
est = float(m.group(1)) * {"s": 1, "min": 60, "h": 3600, "days": 86400}[m.group(2)]
def read(name):
    try:
        return json.load(open(os.path.join(work, "out", name)))
    except OSError:
        return {}
t, d = read("thermal.json"), read("dwell.json")
print(f"{part},{command},{wall},{int(kb) // 1024},{n[0]},{n[2]},{n[3]},{est:g},"
      f"{t.get('cell_updates', '')},{t.get('wall_s', '')},{d.get('search_wall_s', '')}")
PY
done
