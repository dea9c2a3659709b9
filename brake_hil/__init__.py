"""brake_hil: hardware-in-the-loop testing of hydraulic disk brakes (ROS 2 node suite).

``physics``, ``analysis``, ``diagnosis``, ``live`` and ``runtime`` are the ROS-free core
(numpy/scipy); ``io`` reads and writes recordings and CAN frames; ``virtual_rig`` simulates
the rig; ``app`` holds the commands, ``cli`` their command line; ``nodes`` are thin rclpy
adapters (README, Layout).
"""

import os

# Every matrix here is tiny (at most about 15 x 15). A multi-threaded BLAS spends far more on
# waking its threads than on the work, and on a busy 2-core machine a 11 x 11 expm measured
# 16 ms with threads against 0.06 ms without. Set before numpy loads; a user may override.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

__version__ = "0.1.0"
