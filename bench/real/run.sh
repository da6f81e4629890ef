#!/usr/bin/env bash
# KITTI seq 00's stereo rig, simhc and PoseLib on identical correspondences (issue 45): one command.
#
#   bench/real/run.sh [bench.py options]        # e.g. --max-pairs 20 --seed 1 --json target/real.json
#
# Sets itself up: a virtual env of its own (target/real-venv, or $REAL_VENV) with gtsam, poselib,
# numpy, matplotlib and pytest from PyPI, the simhc wheel and the example problem's module `gen_relpose`
# built from this checkout (`pip install ./python ./examples/generalized-relative-pose/python`,
# maturin in release: several minutes the first time). An existing venv is reused;
# REBUILD_WHEEL=1 reinstalls both wheels from the checkout. The data is read from the
# installed gtsam package. The reference bundle adjustment is computed once and cached in
# bench/real/cache/ (`python bench/real/kitti.py --force` recomputes it). Plots go to
# target/figures/ unless --plot is given. Options: `bench/real/run.sh --help`.
set -euo pipefail
cd "$(dirname "$0")/../.."
VENV=${REAL_VENV:-target/real-venv}
PY=$VENV/bin/python
if [ ! -x "$PY" ]; then
  echo "run.sh: creating $VENV" >&2
  python3 -m venv "$VENV"
fi
if ! "$PY" -I -c "import gtsam, poselib, numpy, matplotlib, pytest" 2>/dev/null; then
  echo "run.sh: installing gtsam poselib numpy matplotlib pytest into $VENV" >&2
  "$VENV/bin/pip" install --quiet --disable-pip-version-check gtsam poselib numpy matplotlib pytest
fi
# -I: not from the current directory, whose simhc/ (the Rust crate) would import as a namespace.
if [ "${REBUILD_WHEEL:-0}" = 1 ] || ! "$PY" -I -c "import simhc._simhc, gen_relpose" 2>/dev/null; then
  echo "run.sh: building and installing the simhc and gen_relpose wheels from ./python and ./examples/generalized-relative-pose/python (release, several minutes)" >&2
  "$VENV/bin/pip" install --quiet --disable-pip-version-check --force-reinstall ./python ./examples/generalized-relative-pose/python
fi
"$PY" bench/real/kitti.py >&2   # the reference BA (cached); stdout stays for bench.py (--json -)
case " $* " in
  *" --plot "*|*" --help "*|*" -h "*) exec "$PY" bench/real/bench.py "$@" ;;
  *) exec "$PY" bench/real/bench.py --plot target/figures "$@" ;;
esac
