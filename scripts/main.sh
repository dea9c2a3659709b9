#!/usr/bin/env bash
# Set up (first run), then the main job on a bundled recording of the virtual rig (the paper's
# one-washer rig, air-driven, seals that stick and slip):
#   1. the node chain replays it: pressure_source -> caliper_model (the rig file's LTI model)
#      -> comparator -> recorder, in one process (the chain's default layout, one-paired) on
#      loopback DDS, its loop under SCHED_FIFO 20 where the user may (else normal priority);
#      prints the comparison and where the MCAP is;
#   2. brake-hil diagnose finds what the LTI model left out, writes out/diagnosis/ (report.html,
#      diagnosis.json, improved_model.json);
#   3. the chain runs again with the improved model live.
# Exit status: 0 when every step holds; 1 when a chain run's verdict failed (the other steps
# still run; its "chain:" lines say why), or the diagnosis failed; 2 on bad input.
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
failed=()
chain() {  # a chain run that fails its verdict (exit 1) is said at the end; bad input stops here
  local step="$1"
  shift
  local code=0
  .venv/bin/python -m brake_hil.nodes.chain "$@" --realtime-priority 20 || code=$?
  [ "$code" -eq 0 ] || [ "$code" -eq 1 ] || exit "$code"
  [ "$code" -eq 0 ] || failed+=("$step")
}
echo "== 1. node chain, LTI model of $rig"
chain "step 1" "$recording" --model "$rig" --out out/chain_lti
echo "== 2. diagnosis"
.venv/bin/brake-hil diagnose "$recording" --rig "$rig" --out out/diagnosis
echo "== 3. node chain, improved model live"
chain "step 3" "$recording" --model out/diagnosis/improved_model.json --out out/chain_improved
if [ "${#failed[@]}" -gt 0 ]; then
  echo "main: the chain's verdict failed in ${failed[*]} (its chain: lines above say why)" >&2
  exit 1
fi
