"""The diagnosis of a test procedure on the virtual rig: its verdict and its CPU time.

The one-washer truth of the bundled stick-slip recordings (``bags/truth/one_washer_open.yaml``,
``seal_stick_slip`` at full strength) driven by a procedure: three levels of 5 Hz pulsing
(1.38, 2.07, 2.76 MPa), a 5-25 Hz sweep over 10 s around the last level's mean, a fall to rest,
a 3 s rise to 2.76 MPa, a hold and a 3 s fall (36.5 s). ``diagnose()`` runs in this process
against ``config/rig_default.yaml``; the CPU time is ``time.process_time``.

    .venv/bin/python benchmarks/bench_procedure_diagnosis.py --seed 77
"""

from __future__ import annotations

import argparse
from pathlib import Path
import time

import numpy as np

from brake_hil.diagnosis.diagnose import diagnose
from brake_hil.physics.rig import load_rig
from brake_hil.virtual_rig.effects import make_effect
from brake_hil.virtual_rig.excitation import (
    Excitation,
    frequency_sweep,
    pressure_ramp,
    seed_pulsing,
)
from brake_hil.virtual_rig.simulator import simulate_rig

PROJECT = Path(__file__).resolve().parents[1]


def procedure() -> Excitation:
    """Pulsing at three levels, a 5-25 Hz sweep, a fall to rest, a slow rise and fall."""
    pulsing = seed_pulsing((1.38e6, 2.07e6, 2.76e6), pulsing_s=5.0)
    sweep = frequency_sweep(float(pulsing.pressure[-1]), 0.3e6, sweep_s=10.0)
    step = float(pulsing.time[1] - pulsing.time[0])
    start = int(round(1.0 / step))  # after the sweep's own ramp
    ramp = pressure_ramp(2.76e6, rest_s=0.5)
    rest = np.linspace(sweep.pressure[-1], 0.0, int(0.5 / step))
    pressure = np.concatenate([pulsing.pressure, sweep.pressure[start:], rest, ramp.pressure])
    return Excitation(np.arange(pressure.size) * step, pressure, pulsing.kind, "procedure")


def main() -> None:
    """Simulate, diagnose, print the segments, the verdict and the time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=77)
    args = parser.parse_args()
    truth = load_rig(PROJECT / "bags" / "truth" / "one_washer_open.yaml")
    nominal = load_rig(PROJECT / "config" / "rig_default.yaml")
    run = simulate_rig(truth, [make_effect("seal_stick_slip", 1.0)], procedure(), seed=args.seed)
    recording = run.as_recording(path="procedure")
    cpu, wall = time.process_time(), time.time()
    result = diagnose(recording, nominal)
    cpu, wall = time.process_time() - cpu, time.time() - wall
    print(f"length {recording.time[-1] - recording.time[0]:.1f} s")
    print("windows", [w.kind for w in result.dataset.segments])
    print(f"verdict {result.effects} confidence {result.confidence:.2f}")
    print(f"diagnosis: cpu {cpu:.1f} s, wall {wall:.1f} s")


if __name__ == "__main__":
    main()
