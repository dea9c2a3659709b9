#!/usr/bin/env bash
# Set up (first run), then the main job on a bundled recording of the virtual rig (the paper's
# one-washer rig, air-driven, seals that stick and slip):
#   1. the node chain replays it: pressure_source -> caliper_model (the rig file's LTI model)
#      -> comparator -> recorder, each its own process on loopback DDS; prints the comparison
#      and where the MCAP is;
#   2. brake-hil diagnose finds what the LTI model left out, writes out/diagnosis/ (report.html,
#      diagnosis.json, improved_model.json);
#   3. the chain runs again with the improved model live.
# Usage: bash scripts/main.sh [RECORDING [RIG.yaml]]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash scripts/setup.sh
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
recording="${1:-bags/one_washer_open}"
rig="${2:-${recording%/}.rig.yaml}"
[ -f "$rig" ] || rig=config/rig_default.yaml
mkdir -p out
echo "== 1. node chain, LTI model of $rig"
.venv/bin/python -m brake_hil.nodes.chain "$recording" --model "$rig" --out out/chain_lti
echo "== 2. diagnosis"
.venv/bin/brake-hil diagnose "$recording" --rig "$rig" --out out/diagnosis
echo "== 3. node chain, improved model live"
.venv/bin/python -m brake_hil.nodes.chain "$recording" --model out/diagnosis/improved_model.json \
  --out out/chain_improved
