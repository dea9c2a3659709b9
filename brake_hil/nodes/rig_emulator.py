"""Rig emulator node: a virtual rig run played out in real time, as the real rig presents it.

The run is computed first (:func:`precompute_run`), then played at absolute 1 kHz deadlines
(:class:`~brake_hil.runtime.DeadlineLoop`): sample ``k`` is due at ``t0 + k T``; a late
wake-up sends the samples that fell due back to back (none is skipped, as a DAQ buffers).
Outputs (``output``):

``topics``
    The measured signals on the contract topics (``/brake/master_cylinder/pressure``,
    ``/brake/bore/pressure``, ``/brake/block/force``, ``/brake/caliper/displacement``, and
    ``/brake/air/pressure`` when the run has ``p_a``), ``header.stamp`` = acquisition time
    ``t0 + k T`` on the wall clock.
``can``
    The DAQ's frames of ``config/brake_rig.dbc`` (:class:`~brake_hil.io.can_daq.RigFrameCodec`),
    ``sample_counter = k``. ``can_interface: slcan_pty`` (default) makes a pseudo-terminal
    slcan adapter (:class:`~brake_hil.io.can_daq.SlcanPty`) and links it at
    ``can_link_path``, for a pressure source in another process
    (``can_interface: slcan``, ``can_channel: <can_link_path>``). With ``can_link_path``
    empty (the default) the link is ``rig_can`` in a private folder of its own
    (``tempfile.mkdtemp``, mode 0700, removed at exit), never a fixed name in the shared temp
    folder; its path is logged and on diagnostics (``can``). While the pty's reader lags (its
    buffer, about 20 KB, is full), a frame is held up to ``can_hold_s`` and then dropped, as a
    bus does not lose frames because one reader is slow: the reader gets them late, the
    playback falls behind and catches up as above. After a drop (the reader is gone or stalled
    longer than that) no frame is held until the reader reads again, so the playback keeps its
    pace; frames sent and dropped are on diagnostics (``can_frames_sent``,
    ``can_frames_dropped``). Any other value is a python-can interface with
    ``can_channel``/``can_bitrate`` (e.g. ``socketcan`` on a rig PC).
``both``
    Both at once.

Parameters: :class:`~brake_hil.nodes.settings.RigEmulatorSettings`
(``config/rig_emulator.yaml``): the truth rig, the simulator (``virtual_rig``: the
higher-fidelity simulator with ``effects``, e.g. ``["seal_stick_slip"]``; ``lti``: the seed's
LTI model), the excitation (a :class:`~brake_hil.physics.excitation.PulsingSchedule`), the
outputs, and when to start (once every sample topic has ``wait_for_subscribers`` subscribers,
or after ``wait_timeout_s``; then ``start_delay_s``). With ``loop`` the run is replayed
forever, counter and stamps running on; without, the node exits at its end.
Health and timing go to ``/diagnostics``.
"""

from __future__ import annotations

from collections.abc import Sequence
import sys

from brake_hil.nodes.entry import run_entry

NAME = "rig_emulator"


def main(args: Sequence[str] | None = None) -> int:
    """Entry point ``rig_emulator``: its help, or the node run until SIGINT/SIGTERM."""
    return run_entry(NAME, args)


if __name__ == "__main__":
    sys.exit(main())
