#!/usr/bin/env bash
# Accuracy and speed benchmark: runs `desslam run` several times per sequence and prints the
# median ATE RMSE, tracked share, median tracking time per frame, end-to-end frames/s and, with
# --realtime, the 95th percentile of how late frames started against the sensor clock.
# Usage: scripts/benchmark.sh [-n RUNS] [-o OUT_DIR] [-- extra desslam run args] SEQ_DIR:CONFIG ...
#   e.g. scripts/benchmark.sh -n 3 /data/rgbd_dataset_freiburg1_xyz:config/tum_fr1.yaml
# Sequences are not shipped: ../shared/data/README.md says how to get fr1_xyz, fr1_desk, bonn_crowd.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=3
out=results/benchmark
extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    -n) runs=$2; shift 2 ;;
    -o) out=$2; shift 2 ;;
    --set|--dynamic) extra+=("$1" "$2"); shift 2 ;;
    --deterministic|--realtime) extra+=("$1"); shift ;;
    *) break ;;
  esac
done
[ $# -gt 0 ] || { sed -n '2,6p' "$0"; exit 2; }
[ -x build/desslam ] || { echo "build/desslam missing: run scripts/install-and-build.sh first" >&2; exit 1; }
printf '%-32s %5s %10s %8s %12s %9s %14s\n' sequence runs ate_rmse_m tracked tracking_ms frames/s rt_lag_p95_ms
for spec in "$@"; do
  seq=${spec%%:*}; cfg=${spec#*:}
  name=$(basename "$seq")
  for i in $(seq 1 "$runs"); do
    build/desslam run "$seq" --config "$cfg" --out "$out/$name/run$i" --overwrite -q "${extra[@]}" 2>/dev/null
  done
  python3 - "$out/$name" "$runs" "$name" <<'PY'
import json, statistics, sys
folder, runs, name = sys.argv[1], int(sys.argv[2]), sys.argv[3]
reports = [json.load(open(f"{folder}/run{i}/report.json")) for i in range(1, runs + 1)]
med = lambda xs: statistics.median(xs)
ate = med([r["ate"]["translation_m"]["rmse"] for r in reports]) if all("ate" in r for r in reports) else float("nan")
tracked = med([r.get("tracked_share_of_associated_frames", float("nan")) for r in reports])
tracking = med([r["statistics"]["timings_ms"]["tracking"]["median"] for r in reports])
fps = med([r["frames_per_second"] for r in reports])
# Real-time runs: how late frames started against the sensor clock (95th percentile); "-" offline.
lag = med([r["realtime_lag_ms"]["p95"] for r in reports]) if all("realtime_lag_ms" in r for r in reports) else None
lag_text = f"{lag:14.1f}" if lag is not None else f"{'-':>14s}"
print(f"{name:32s} {runs:5d} {ate:10.4f} {tracked:8.3f} {tracking:12.1f} {fps:9.1f} {lag_text}")
PY
done
