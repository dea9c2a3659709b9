"""The seed's physics, ROS-free.

The rig file, eqs. 2-20, the LTI model (eq. 21), sensors, excitation, and the catalogue of
effects the LTI model leaves out.
"""

from __future__ import annotations

__all__ = [
    "catalogue",
    "excitation",
    "lti_model",
    "measurement",
    "parameters",
    "rig",
]
