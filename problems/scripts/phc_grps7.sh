#!/bin/sh
# Independent check of the GRPS7 solution count with PHCpack's blackbox solver (not part of the
# test suite; takes about a minute). Installs the Debian package `phcpack` if `phc` is missing,
# writes the noise-free GRPS7 instance of scene seed $1 (default 0) with the phc_input example,
# solves it with `phc -b` (polyhedral homotopy, 560 paths) and prints PHCpack's summary.
# Expected: 280 finite solutions (140 rotations, each as +-q), 0 at infinity.
set -eu
seed="${1:-0}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
work="$(mktemp -d)"
if ! command -v phc >/dev/null 2>&1; then
    apt-get update && apt-get install -y phcpack
fi
cd "$root"
cargo run --quiet --release -p simhc-problems --example phc_input -- "$seed" > "$work/in.phc"
start=$(date +%s)
phc -b "$work/in.phc" "$work/out.phc" > /dev/null
end=$(date +%s)
echo "PHCpack ($(phc --version 2>&1 | head -1)) on GRPS7 scene seed $seed, $((end - start)) s:"
grep -E "^(total degree|mixed volume)" "$work/out.phc" | head -2
sed -n '/^A list of .* solutions has been refined/,/^Number of failures/p' "$work/out.phc" | tail -8
echo "files in $work"
