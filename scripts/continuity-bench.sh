#!/usr/bin/env bash
# Continuity benchmark: does the system keep (or regain) a pose when frames are withheld?
# Runs `desslam run` RUNS times per sequence for the no-gap case and for every --gaps range
# (frames A..B withheld with --skip-frames A-B), then prints per (sequence, case): median and worst
# ATE RMSE, tracked share (frames with a pose in any map / frames given to the system), main-map
# share, maps and merges, frames until the pose came back after the gap, and whether all maps
# ended merged; finally one summary line per sequence (worst tracked share, worst resume).
# Usage: scripts/continuity-bench.sh [-n RUNS] [-o OUT_DIR] [--gaps "A-B A-B ..."] [--gaps-only]
#                                    [-- extra desslam run args] SEQ_DIR:CONFIG ...
#   e.g. scripts/continuity-bench.sh -n 3 --gaps "200-259 400-429" -- --set dense.enabled=false \
#          /data/fr1_desk:config/tum_fr1.yaml
#   -n RUNS (default 3), -o OUT_DIR (default results/continuity; runs land in OUT/<seq>/<case>/run<i>),
#   --gaps: space-separated 0-based FIRST-LAST ranges of the paired frame list (default: none),
#   --gaps-only: skip the no-gap case. Everything after `--` is passed to every `desslam run`.
# Sequences are not shipped: ../shared/data/README.md says how to get fr1_xyz, fr1_desk, bonn_crowd.
#
# Fields read from report.json (missing ones print '-'): ate.translation_m.rmse (ATE over
# CameraTrajectory.txt), tracked_share_of_associated_frames (main-map share),
# statistics.per_frame[k].{tracked, map, input_index}, statistics.atlas.{maps[].{id, keyframes,
# merged_into}, merges, main_map}; CameraTrajectory_all.txt (rows = frames with a pose in any map)
# is the fallback for the tracked share when per_frame is missing.
#   A frame "has a pose" when per_frame[k].map >= 0 (or, without `map`, per_frame[k].tracked).
#   resume = processed frames after the gap (input_index > B) before the first one with a pose
#            at the time (tracked or predicted; not per_frame[k].backfilled, nor interpolated
#            without a prediction: those got theirs afterwards); 'never' when none did.
#   merged = every map with keyframes, except one, has merged_into set (yes / no / k/N runs).
set -uo pipefail
caller_pwd=$(pwd)
cd "$(dirname "$0")/.." || exit 1
repo_root=$(pwd)

usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; }
abspath() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$caller_pwd/$1" ;; esac; }

runs=3
out=$repo_root/results/continuity
gaps=""
gaps_only=0
extra=()
specs=()
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    -n) [ $# -ge 2 ] || { echo "error: -n needs a number" >&2; exit 2; }; runs=$2; shift 2 ;;
    -o) [ $# -ge 2 ] || { echo "error: -o needs a folder" >&2; exit 2; }; out=$(abspath "$2"); shift 2 ;;
    --gaps) [ $# -ge 2 ] || { echo "error: --gaps needs \"A-B ...\"" >&2; exit 2; }; gaps=$2; shift 2 ;;
    --gaps-only) gaps_only=1; shift ;;
    --) shift; while [ $# -gt 0 ]; do
          # SEQ:CONFIG specs may follow the extra args: a word with ':' naming an existing folder.
          if [[ "$1" == *:* && -d "$(abspath "${1%%:*}")" ]]; then specs+=("$1"); else extra+=("$1"); fi
          shift
        done ;;
    -*) echo "error: unknown option '$1' (desslam run options go after --)" >&2; exit 2 ;;
    *) specs+=("$1"); shift ;;
  esac
done
[ ${#specs[@]} -gt 0 ] || { usage; exit 2; }
[[ "$runs" =~ ^[1-9][0-9]*$ ]] || { echo "error: -n '$runs' is not a positive number" >&2; exit 2; }
for g in $gaps; do
  [[ "$g" =~ ^([0-9]+)-([0-9]+)$ ]] && [ "${BASH_REMATCH[1]}" -le "${BASH_REMATCH[2]}" ] ||
    { echo "error: gap '$g' is not FIRST-LAST with FIRST <= LAST (0-based frame indices), e.g. 200-259" >&2; exit 2; }
done
[ "$gaps_only" = 0 ] || [ -n "$gaps" ] || { echo "error: --gaps-only without --gaps leaves nothing to run" >&2; exit 2; }
# DESSLAM_BIN: another binary (e.g. a copy, so that a rebuild does not change a running benchmark).
desslam=${DESSLAM_BIN:-build/desslam}
[ -x "$desslam" ] || { echo "error: $desslam missing: build it first (scripts/install-and-build.sh)" >&2; exit 1; }
command -v python3 >/dev/null || { echo "error: python3 not found" >&2; exit 1; }

cases=()
[ "$gaps_only" = 1 ] || cases+=(nogap)
for g in $gaps; do cases+=("gap_$g"); done

read -r -d '' PY <<'PY'
import json, math, os, statistics, sys

def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError):
        return None

def get(d, *keys):
    for k in keys:
        if isinstance(d, dict) and k in d:
            d = d[k]
        elif isinstance(d, list) and isinstance(k, int) and -len(d) <= k < len(d):
            d = d[k]
        else:
            return None
    return d

def num(x):
    return x if isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) else None

def has_pose(f):
    m = num(f.get("map")) if isinstance(f, dict) else None
    if m is not None:
        return m >= 0
    t = f.get("tracked") if isinstance(f, dict) else None
    return t if isinstance(t, bool) else None

def posed_at_the_time(f):
    # A pose settled afterwards (tracked or predicted backwards, or interpolated on a frame that had none) does
    # not say that tracking had come back at that frame.
    if not has_pose(f):
        return False
    return not (f.get("backfilled") is True or f.get("predicted_backwards") is True or
                (f.get("interpolated") is True and f.get("predicted") is not True))

def all_rows(run_dir):
    path = os.path.join(run_dir, "CameraTrajectory_all.txt")
    try:
        with open(path) as f:
            stamps = {l.split()[0] for l in f if l.strip() and not l.lstrip().startswith("#")}
        return len(stamps)
    except OSError:
        return None

def analyse(run_dir, gap):
    r = load(os.path.join(run_dir, "report.json"))
    if r is None:
        return None
    res = {"ate": num(get(r, "ate", "translation_m", "rmse")),
           "main": num(r.get("tracked_share_of_associated_frames"))}
    pf = get(r, "statistics", "per_frame")
    pf = pf if isinstance(pf, list) else None
    given = len(pf) if pf else num(get(r, "statistics", "counts", "frames"))
    posed = None
    if pf:
        flags = [has_pose(f) for f in pf]
        if all(x is not None for x in flags):
            posed = sum(flags)
    if posed is None:
        posed = all_rows(run_dir)
    res["tracked"] = posed / given if posed is not None and given else None
    atlas = get(r, "statistics", "atlas")
    maps = atlas.get("maps") if isinstance(atlas, dict) else None
    res["maps"] = len(maps) if isinstance(maps, list) else None
    res["merges"] = num(atlas.get("merges")) if isinstance(atlas, dict) else None
    if isinstance(maps, list):
        alive = [m for m in maps if isinstance(m, dict) and m.get("merged_into") is None
                 and (num(m.get("keyframes")) is None or m.get("keyframes") > 0)]
        res["merged"] = len(alive) <= 1
    else:
        res["merged"] = None
    res["resume"] = None  # int, or "never"
    if gap is not None and pf and all(num(get(f, "input_index")) is not None for f in pf):
        b = gap[1]
        after = [k for k, f in enumerate(pf) if f["input_index"] > b]
        if after:
            k0 = after[0]
            hit = [k for k in after if posed_at_the_time(pf[k])]
            res["resume"] = hit[0] - k0 if hit else "never"
    return res

def vals(rs, key):
    return [x[key] for x in rs if x[key] is not None]

def fmt(x, spec):
    return "-" if x is None else format(x, spec)

def span(xs):
    if not xs:
        return "-"
    lo, hi = min(xs), max(xs)
    return f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"

def resume_key(x):
    return math.inf if x == "never" else x

def resume_text(x):
    return "-" if x is None else ("never" if x == "never" else str(x))

HEAD = (f"{'sequence':24s} {'case':14s} {'runs':>5s} {'ate_med_m':>10s} {'ate_max_m':>10s} "
        f"{'trk_med':>7s} {'trk_min':>7s} {'main_med':>8s} {'maps':>5s} {'merges':>6s} "
        f"{'resume_med':>10s} {'resume_max':>10s} {'merged':>6s}")

mode = sys.argv[1]
if mode == "head":
    print(HEAD)
elif mode == "row":
    case_dir, runs, name, case = sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5]
    gap = tuple(int(v) for v in case[4:].split("-")) if case.startswith("gap_") else None
    rs = [analyse(os.path.join(case_dir, f"run{i}"), gap) for i in range(1, runs + 1)]
    ok = [x for x in rs if x is not None]
    runs_text = f"{len(ok)}/{runs}" if len(ok) < runs else str(runs)
    ate, trk, main = vals(ok, "ate"), vals(ok, "tracked"), vals(ok, "main")
    med = lambda xs: statistics.median(xs) if xs else None
    resume_med = resume_max = None
    if gap is not None:
        rv = vals(ok, "resume")
        if rv:
            srt = sorted(rv, key=resume_key)
            m = srt[(len(srt) - 1) // 2] if len(srt) % 2 else None
            if m is None:  # even count: mean of the middle two unless one is 'never'
                a, b = srt[len(srt) // 2 - 1], srt[len(srt) // 2]
                m = "never" if "never" in (a, b) else (a + b) / 2
            resume_med, resume_max = m, srt[-1]
    merged = vals(ok, "merged")
    merged_text = "-" if not merged else ("yes" if all(merged) else ("no" if not any(merged) else f"{sum(merged)}/{len(merged)}"))
    rmed = resume_text(resume_med if not isinstance(resume_med, float) else f"{resume_med:g}")
    print(f"{name:24s} {case:14s} {runs_text:>5s} {fmt(med(ate), '10.4f')} {fmt(max(ate) if ate else None, '10.4f')} "
          f"{fmt(med(trk), '7.3f')} {fmt(min(trk) if trk else None, '7.3f')} {fmt(med(main), '8.3f')} "
          f"{span(vals(ok, 'maps')):>5s} {span(vals(ok, 'merges')):>6s} "
          f"{rmed:>10s} {resume_text(resume_max):>10s} {merged_text:>6s}", flush=True)
    # for the summary
    with open(os.path.join(os.path.dirname(case_dir), ".continuity-summary.jsonl"), "a") as f:
        f.write(json.dumps({"case": case, "runs": runs, "ok": len(ok), "tracked": trk,
                            "resume": vals(ok, "resume") if gap is not None else None}) + "\n")
elif mode == "summary":
    seq_dir, name = sys.argv[2], sys.argv[3]
    trk, resumes, gap_cases, failed = [], [], 0, 0
    try:
        with open(os.path.join(seq_dir, ".continuity-summary.jsonl")) as f:
            lines = [json.loads(l) for l in f if l.strip()]
    except OSError:
        lines = []
    for c in lines:
        trk += c["tracked"]
        failed += c["runs"] - c["ok"]
        if c["resume"] is not None:
            gap_cases += 1
            resumes += c["resume"]
    worst_trk = fmt(min(trk) if trk else None, ".3f")
    worst_res = resume_text(max(resumes, key=resume_key)) if resumes else "-"
    print(f"summary {name}: worst tracked share {worst_trk} over {len(lines)} case(s); "
          f"worst resume {worst_res} frame(s) over {gap_cases} gap case(s)"
          + (f"; {failed} run(s) without report.json" if failed else ""))
PY

python3 -c "$PY" head
names=()
for spec in "${specs[@]}"; do
  [[ "$spec" == *:* ]] || { echo "error: '$spec' is not SEQ_DIR:CONFIG" >&2; exit 2; }
  seq=$(abspath "${spec%%:*}"); cfg=$(abspath "${spec#*:}")
  [ -d "$seq" ] || { echo "error: sequence folder $seq missing" >&2; exit 2; }
  [ -f "$cfg" ] || { echo "error: config $cfg missing" >&2; exit 2; }
  name=$(basename "$seq")
  for n in "${names[@]+"${names[@]}"}"; do [ "$n" != "$name" ] || name="$name+$(basename "$cfg" .yaml)"; done
  names+=("$name")
  mkdir -p "$out/$name"
  rm -f "$out/$name/.continuity-summary.jsonl"
  for c in "${cases[@]}"; do
    skip=()
    [ "$c" = nogap ] || skip=(--skip-frames "${c#gap_}")
    for i in $(seq 1 "$runs"); do
      dir=$out/$name/$c/run$i
      mkdir -p "$dir"
      rm -f "$dir/report.json" "$dir/CameraTrajectory_all.txt" "$dir/stderr.log"
      "$desslam" run "$seq" --config "$cfg" --out "$dir" --overwrite -q "${skip[@]+"${skip[@]}"}" \
        "${extra[@]+"${extra[@]}"}" >"$dir/desslam.log" 2>&1
      rc=$?
      [ "$rc" = 0 ] || echo "warning: $name $c run$i: desslam exited $rc; see $dir/desslam.log" >&2
    done
    python3 -c "$PY" row "$out/$name/$c" "$runs" "$name" "$c"
  done
done
for name in "${names[@]}"; do python3 -c "$PY" summary "$out/$name" "$name"; done
