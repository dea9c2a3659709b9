#!/usr/bin/env bash
# The node chain on a bundled recording: pressure_source (replay) -> caliper_model ->
# comparator -> recorder (in one process by default; --layout chooses) on loopback DDS;
# prints the comparison and where the MCAP is. Arguments go to
# `python -m brake_hil.nodes.chain` (see its --help):
#   bash scripts/run_chain.sh [RECORDING] [--model RIG.yaml] [--out DIR] [--rate R]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash scripts/setup.sh
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
exec .venv/bin/python -m brake_hil.nodes.chain "$@"
