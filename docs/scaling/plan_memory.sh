#!/usr/bin/env bash
# The planner's memory against the part's mesh (docs/PERFORMANCE.md "Cost estimates", the plan's
# memory): for each part, `waamtwin mesh` writes its welded mesh (the vertices counted) and
# `waamtwin plan` runs under /usr/bin/time; one CSV row a part:
#   name,vertices,plan_wall_s,plan_peak_mb
# (MB of 10^6 bytes). `pipeline::cost::plan_bytes` is held against such rows in the test
# `cost::tests::the_plans_memory_meets_the_peaks_measured`.
# A part is a scenario file (a path, or a name in scenarios/) or domeR, the closed hemisphere of
# radius R mm at 2 mm edges that measure.sh runs.
# Usage: [BIN=PATH] docs/scaling/plan_memory.sh PART...
#   e.g. docs/scaling/plan_memory.sh dome50 dome100 bottle.toml /tmp/big_cylinder.toml
set -euo pipefail
cd "$(dirname "$0")/../.."
bin="${BIN:-${CARGO_TARGET_DIR:-target}/release/waamtwin}"
[ -x "$bin" ] || { echo "$bin: expected the waamtwin binary (cargo build --release -p sim --bin waamtwin, or BIN=PATH)" >&2; exit 2; }
[ $# -gt 0 ] || { echo "expected parts: domeR or scenario files" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "name,vertices,plan_wall_s,plan_peak_mb"
for part in "$@"; do
  case "$part" in
    dome*) printf '[part]\nshape = "hemisphere"\nradius_mm = %s.0\nedge_mm = 2.0\n' "${part#dome}" >"$work/s.toml" ;;
    *) f="$part"; [ -f "$f" ] || f="scenarios/$part"
       [ -f "$f" ] || { echo "$part: expected domeR or a scenario file" >&2; exit 2; }
       # A mesh path is read relative to the scenario's folder: its parts/ linked beside the copy.
       cp "$f" "$work/s.toml"
       ln -sfn "$(cd "$(dirname "$f")" && pwd)/parts" "$work/parts" ;;
  esac
  "$bin" mesh "$work/s.toml" -o "$work/m.obj" >/dev/null 2>&1 || { echo "$part: waamtwin mesh failed" >&2; exit 1; }
  vertices=$(grep -c '^v ' "$work/m.obj")
  rm -rf "$work/out"
  /usr/bin/time -f "%e %M" -o "$work/time" "$bin" plan "$work/s.toml" -o "$work/out" >"$work/log" 2>&1 \
    || { cat "$work/log" >&2; exit 1; }
  read -r wall kb <"$work/time"
  echo "$(basename "$part"),$vertices,$wall,$(python3 -c "print(round($kb * 1024 / 1e6, 1))")"
done
