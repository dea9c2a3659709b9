#!/usr/bin/env bash
# Create .venv beside the project (first run) and install brake_hil with its ROS 2 Kilted
# wheels from PyPI; a second run only checks that the install is current (a few seconds).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
venv="$here/.venv"
stamp="$venv/.brake_hil-installed"
if [ ! -x "$venv/bin/python" ]; then
  echo "brake_hil: creating $venv" >&2
  python3 -m venv "$venv"
fi
if [ ! -f "$stamp" ] || [ "$here/setup.py" -nt "$stamp" ]; then
  echo "brake_hil: installing dependencies into $venv (first run: a few minutes, see README)" >&2
  log="$venv/install.log"
  if ! "$venv/bin/python" -m pip install --disable-pip-version-check -e "$here[ros,dev]" \
      >"$log" 2>&1; then
    grep -v "is ignored: it is neither a file nor a directory" "$log" | tail -n 30 >&2
    echo "brake_hil: pip install failed; full log in $log" >&2
    exit 1
  fi
  "$venv/bin/python" -c "import brake_hil, numpy, scipy, mcap, rosbags, can, rclpy" \
    || { echo "brake_hil: install failed" >&2; exit 1; }
  touch "$stamp"
fi
