#!/usr/bin/env bash
# One command for the peers benchmark: install (skips what is there), generate trials, run OpenGV
# and PoseLib on them, score.
#
#   bash bench/peers/run.sh [--trials N] [--seed S] [--variant world-box|viewer-box] [--rigid]
#                           [--noise-px X] [--problem upnp|grps|grp] [--repeats N] [--ransac-repeats N]
#                           [--out DIR]
#
# Defaults: 1000 trials, seed 1, world-box, 2 px (upnp) / 0 px (grps, grp), 10 repeats per call
# (5 for PoseLib's RANSAC), output in bench/peers/build/results/. With SIMHC=1 it also runs simhc
# on the same trials file (from the repository root):
#   cargo run --release -p simhc-cli -- bench upnp --trials-file FILE --json   (grps: bench grps)
# and appends simhc's rows to the table. `--problem grp` is generalized relative pose with known
# scale from 7 correspondences (GRPS trials of scale 1, `--points 7`); with SIMHC=1 the example
# crate examples/generalized-relative-pose runs on the same trials (`grp bench grp --trials-file`,
# converted by to_grp.py) and its rows follow the table.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
PYTHON="${PYTHON:-python3}"

trials=1000 seed=1 variant=world-box rigid=0 noise="" problem=upnp repeats=10 ransac_repeats=5
out="$here/build/results"
while [ $# -gt 0 ]; do
  case "$1" in
    --trials) trials="$2"; shift 2 ;;
    --seed) seed="$2"; shift 2 ;;
    --variant) variant="$2"; shift 2 ;;
    --rigid) rigid=1; shift ;;
    --noise-px) noise="$2"; shift 2 ;;
    --problem) problem="$2"; shift 2 ;;
    --repeats) repeats="$2"; shift 2 ;;
    --ransac-repeats) ransac_repeats="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    *) echo "run.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

bash "$here/install.sh"
mkdir -p "$out"

gen_args=(--problem "$problem" --trials "$trials" --seed "$seed")
if [ "$problem" = upnp ]; then
  gen_args+=(--variant "$variant")
  tag="upnp-$variant"
elif [ "$problem" = grp ]; then
  gen_args=(--problem grps --points 7 --trials "$trials" --seed "$seed")
  tag="grp"
else
  tag="grps"
fi
if [ -n "$noise" ]; then
  gen_args+=(--noise-px "$noise")
  tag="$tag-${noise}px"
fi
if [ "$rigid" = 1 ]; then
  gen_args+=(--rigid)
  tag="$tag-rigid"
fi
tag="$tag-n$trials-s$seed"
trials_file="$out/trials-$tag.json"

load_before="$(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
"$PYTHON" "$here/gen_trials.py" "${gen_args[@]}" --out "$trials_file"
"$here/build/run_opengv" --repeats "$repeats" "$trials_file" > "$out/opengv-$tag.jsonl"
"$PYTHON" "$here/run_poselib.py" --repeats "$repeats" --ransac-repeats "$ransac_repeats" "$trials_file" \
  > "$out/poselib-$tag.jsonl"

score_args=("$trials_file" "$out/opengv-$tag.jsonl" "$out/poselib-$tag.jsonl")
if [ "${SIMHC:-0}" = 1 ] && [ "$problem" != grp ]; then
  echo "run.sh: simhc bench $problem --trials-file $trials_file (cargo run --release)" >&2
  if (cd "$root" && cargo run --release -q -p simhc-cli -- bench "$problem" --trials-file "$trials_file" --json) \
      > "$out/simhc-$tag.json"; then
    score_args+=(--simhc "$out/simhc-$tag.json")
  else
    echo "run.sh: simhc run failed; table without it" >&2
  fi
fi

title="$tag ($(date +%F), seed $seed)"
grp_rows=""
if [ "${SIMHC:-0}" = 1 ] && [ "$problem" = grp ]; then
  "$PYTHON" "$here/to_grp.py" "$trials_file" "$out/grp-trials-$tag.json"
  grp_noise="${noise:-0}"
  echo "run.sh: grp bench grp --trials-file $out/grp-trials-$tag.json --noise $grp_noise (cargo run --release)" >&2
  (cd "$root" && cargo run --release -q -p generalized-relative-pose -- bench grp --trials-file "$out/grp-trials-$tag.json" \
      --noise "$grp_noise" --all-roots "$trials" 2>/dev/null) > "$out/grp-$tag.txt"
  grp_rows="$(cat "$out/grp-$tag.txt")"
fi
{
  "$PYTHON" "$here/score.py" "${score_args[@]}" --title "$title"
  if [ -n "$grp_rows" ]; then
    echo
    echo "simhc's generalized-relative-pose example on the same trials (success: validated, E_R < 2 deg and E_t < 5 %):"
    echo
    echo '```'
    echo "$grp_rows"
    echo '```'
  fi
  echo "machine: $(nproc 2>/dev/null || echo '?') cores, load average before the runs: $load_before, after: $(cut -d' ' -f1-3 /proc/loadavg 2>/dev/null || echo '?')"
} | tee "$out/table-$tag.md"
echo "run.sh: trials, per-trial results and table in $out (tag $tag)" >&2
