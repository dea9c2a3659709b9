#!/usr/bin/env bash
# Set up (first run) and run the main job on the bundled default: the rig file's LTI model on
# a bundled recording, the seed's comparison printed, a plot and JSON written to out/.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$here"
bash scripts/setup.sh
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
recording="${1:-bags/one_washer_lti}"
rig="${2:-config/rig_default.yaml}"
mkdir -p out
.venv/bin/brake-hil compare "$recording" --rig "$rig" --json out/compare.json --plot out/compare.png
.venv/bin/brake-hil characterize "$recording" --rig "$rig" --json out/characterize.json
