# SPDX-License-Identifier: Apache-2.0
# A motion script (docs/python.md, "Motion scripts"): what an operator's hand cannot do evenly.
# The tool tip starts 20 mm above pa10-sim's table.
#
#   examples/force-servo/demo --script examples/force-servo/slide.py
#   rtm script examples/force-servo/slide.py        (on a running force-servo system)
from rtm.motion import arm

arm.approach("-z", speed=0.005, contact=2.0, timeout=15)  # down at 5 mm/s until it touches
arm.press(10, ramp=1.0, hold=2.0)                         # 10 N on the table
arm.slide("x", distance=0.05, speed=0.01, force=10)       # 5 cm along x at 1 cm/s, holding 10 N
arm.press(20, ramp=1.0, hold=2.0)                         # 20 N
arm.release(lift=0.01)                                    # to 0 N, then 1 cm up
