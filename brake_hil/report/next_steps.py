"""The diagnosis report's last words: what to do next, and the noise in plain words.

``Next steps``: run the improved model live on the node chain (the exact command, with this
report's recording and ``improved_model.json``), what to check on the rig (the catalogue's
``rig_check`` of each effect named), and how to re-test once the rig is fixed (record again,
``brake-hil diagnose``, ``brake-hil regress``). :func:`noise_words` says how far a model's
error is above the sensor noise, as a ratio of RMS values.
"""

from __future__ import annotations

from collections.abc import Sequence
import html
from pathlib import Path
import shlex

from brake_hil.words import noise_times

__all__ = ["IMPROVED_MODEL", "next_steps", "noise_words"]

IMPROVED_MODEL = "improved_model.json"
"""The improved model ``brake-hil diagnose`` writes beside the report."""


def noise_words(squared_ratio: float, what: str = "the LTI model's error") -> str:
    """``the LTI model's error is 250 times the sensor noise (RMS)``, from a ratio of squares."""
    if not squared_ratio >= 0.0:
        return f"{what} against the sensor noise: not known"
    rms = squared_ratio**0.5
    if rms < 1.05:
        return f"{what} is within the sensor noise (RMS {rms:.2f} times it)"
    return f"{what} is {noise_times(squared_ratio)}"


_REGRESS = ("brake-hil", "regress", "NEW_RECORDING", "--baseline", "baseline.json")


def _command(*words: str | Path) -> str:
    return "<pre>" + html.escape(" ".join(shlex.quote(str(w)) for w in words)) + "</pre>"


def next_steps(
    recording: str,
    out: Path,
    rig_path: Path | None,
    named: bool,
    checks: Sequence[str],
    off_values: Sequence[str] = (),
) -> str:
    """The ``Next steps`` section (HTML).

    Args:
        recording: the recording diagnosed (its path as given).
        out: the folder of the report and of ``improved_model.json``.
        rig_path: the rig file the diagnosis used (``None``: not given).
        named: whether the verdict named physics (else there is no improved model to run).
        checks: what to check on the rig, HTML, one item each.
        off_values: the rig values far outside their tolerance, in words (HTML), one each.
    """
    model = out / IMPROVED_MODEL
    rig: list[str | Path] = ["--rig", rig_path] if rig_path is not None else []
    # the baseline keeps the model file given once; a new recording need not carry its own
    model_option: list[str | Path] = ["--model", rig_path] if rig_path is not None else []
    parts = ["<h2>Next steps</h2><ol class=steps>"]
    if named:
        parts.append(
            "<li><b>Run the improved model live</b> on the node chain (replaying this "
            "recording through it, compared with what was measured; from the brake_hil "
            f"checkout):{_command('bash', 'scripts/run_chain.sh', recording, '--model', model)}"
            "On the rig, give the caliper-model node the same file as its "
            "<code>model_file</code> parameter.</li>"
        )
    elif off_values:
        parts.append(
            "<li><b>Correct the rig file or the rig</b>: no physics was named, but "
            f"{'; '.join(off_values)}. Measure the value on the rig and write it into the rig "
            "file (or fix the part), then re-test; the calibrated LTI model is the one to use "
            "meanwhile.</li>"
        )
    else:
        parts.append(
            "<li><b>The rig file's model stands</b>: no physics was named, so there is no "
            "improved model to run live; the LTI model of the rig file is the one to use.</li>"
        )
    listed = "".join(f"<li>{c}</li>" for c in checks) or "<li>nothing stands out</li>"
    parts.append(f"<li><b>Check on the rig:</b><ul>{listed}</ul></li>")
    again = out.parent / f"{out.name}_retest"
    parts.append(
        "<li><b>Re-test</b> once the rig is fixed: record the same pulsing again "
        "(<code>NEW_RECORDING</code> below) and diagnose it:"
        f"{_command('brake-hil', 'diagnose', 'NEW_RECORDING', *rig, '--out', again)}"
        "then keep it as the regression baseline (once, with <code>--update</code>) and "
        "hold every later recording of the rig against it (without):"
        f"{_command(*_REGRESS, *model_option, '--update')}{_command(*_REGRESS)}"
        "A fixed rig is diagnosed with no missing physics (or a smaller held-out error "
        "cut), and <code>brake-hil trend</code> over the results database shows it over "
        "time.</li>"
    )
    parts.append("</ol>")
    return "".join(parts)
