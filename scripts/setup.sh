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
  echo "brake_hil: installing dependencies into $venv (first run takes about a minute)" >&2
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check --upgrade pip 2>/dev/null || true
  "$venv/bin/python" -m pip install --quiet --disable-pip-version-check -e "$here[ros,dev]" 2>&1 \
    | grep -v "is ignored: it is neither a file nor a directory" >&2 || true
  "$venv/bin/python" -c "import brake_hil, numpy, scipy, mcap, rosbags, can, rclpy" \
    || { echo "brake_hil: install failed" >&2; exit 1; }
  touch "$stamp"
fi
