#!/usr/bin/env bash
# Set up (first run) and run every check: ruff (ament_flake8's rules, and its formatter's
# layout), mypy strict on the core and I/O, then the tests. Extra arguments go to pytest
# (e.g. -k characterisation).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash scripts/setup.sh
# Any ROS node a test starts talks over loopback only (no multicast on the network).
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
# One command a line: under set -e a failure inside an && list (but its last) does not stop
# the script.
echo "== ruff"
.venv/bin/ruff check .
.venv/bin/ruff format --check .
echo "== mypy"
.venv/bin/mypy brake_hil/physics brake_hil/analysis brake_hil/diagnosis brake_hil/live brake_hil/runtime \
  brake_hil/io brake_hil/virtual_rig brake_hil/results brake_hil/app brake_hil/cli brake_hil/types.py \
  brake_hil/topics.py brake_hil/errors.py brake_hil/words.py
echo "== pytest"
.venv/bin/python -m pytest -q -p no:cacheprovider test "$@"
