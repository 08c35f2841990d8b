#!/usr/bin/env bash
# The voxel model on a real GPU against its CPU (docs/PERFORMANCE.md "The IN718 step on the GPU"):
# the GPU tests, and the GAMMA wall on a box plate of its IN718 (the e2e test's scenario,
# tests/e2e/replay.rs `gamma_on_an_in718_box`) replayed with `device = "gpu"` and on the CPU,
# their IR samples and before-next-pass temperatures compared as shares of the rise.
# On the GPU's machine, from the repository's root, with binaries built here and carried:
#   BIN=waamtwin (cargo build --release -p sim --features gpu --bin waamtwin)
#   TESTS=gpu-… (cargo test --release -p thermal --features gpu --test gpu --no-run)
#   WAAMTWIN_DATA=folder holding gamma_in718_ded_thinwall/   OUT=folder for the results
#   docs/scaling/gpu_check.sh
set -uo pipefail
: "${BIN:?}" "${TESTS:?}" "${WAAMTWIN_DATA:?}" "${OUT:?}"
nvidia-smi --query-gpu=name,driver_version --format=csv,noheader | tee "$OUT/device.txt"
echo "== the GPU tests"
WAAMTWIN_SYSTEM_TESTS=1 "$TESTS" --test-threads 1 --include-ignored 2>&1 | tee "$OUT/tests.txt"
work=$(mktemp -d)
python3 - "$work" <<'PY'
import sys
t = open("scenarios/gamma_in718_wall.toml").read()
t = t.replace('plate_shape = "disc"', "").replace("coarse_plate = true\n", "")
head, rest = t.split("[plate_material]")
t = head + "[thermal]" + rest.split("[thermal]", 1)[1]
open(f"{sys.argv[1]}/box_cpu.toml", "w").write(t)
open(f"{sys.argv[1]}/box_gpu.toml", "w").write(t.replace("[thermal]\n", "[thermal]\ndevice = \"gpu\"\n", 1))
PY
for d in gpu cpu; do
  echo "== replay on the $d"
  /usr/bin/time -f "%e s wall, %M kB" "$BIN" replay "$work/box_$d.toml" -o "$work/$d" >"$OUT/replay_$d.log" 2>&1
  tail -2 "$OUT/replay_$d.log"
done
python3 - "$work" <<'PY' | tee "$OUT/compare.txt"
import csv, json, statistics, sys
w, amb = sys.argv[1], 26.85
def before(d):
    rows = csv.DictReader(open(f"{w}/{d}/passes.csv"))
    return {(r["probe"], r["pass"]): float(r["predicted_before_next_c"]) for r in rows if r["predicted_before_next_c"] not in ("", "nan")}
g, c = before("gpu"), before("cpu")
rel = sorted(abs(g[k] - c[k]) / (c[k] - amb) for k in c if k in g and c[k] - amb > 10)
print(f"before-next-pass: {len(rel)} compared, worst {100*rel[-1]:.3f} % of the rise, median {100*statistics.median(rel):.4f} %")
def samples(d):
    return [(r["probe"], r["t_s"], float(r["predicted_c"])) for r in csv.DictReader(open(f"{w}/{d}/probes.csv"))]
g, c = samples("gpu"), samples("cpu")
assert len(g) == len(c) and all(a[:2] == b[:2] for a, b in zip(g, c)), (len(g), len(c))
rel = sorted(abs(a[2] - b[2]) / (b[2] - amb) for a, b in zip(g, c) if b[2] - amb > 10)
print(f"IR samples: {len(rel)} compared, worst {100*rel[-1]:.3f} % of the rise, 99.9th {100*rel[int(0.999*len(rel))]:.3f} %, median {100*statistics.median(rel):.4f} %")
for d in ("gpu", "cpu"):
    r = json.load(open(f"{w}/{d}/replay.json"))
    print(d, {k: r[k] for k in ("rms_c", "samples", "balance_error", "steps", "voxels", "wall_s")})
PY
rm -rf "$work"
