#!/usr/bin/env python3
"""Writes rotary-b.csv: errmap's own synthetic rotary test (run it again and the file comes
out byte for byte the same). A B axis (a tilting table's rotary axis) against an angle
reference, every 15 degrees from 0 to 360 (0 and 360 both: the closure pair), 5 runs out
and back, one reading per dwell. The planted axis: an eccentricity of 6 arcsec (phase 40
degrees), a worm error 8 times per revolution of 1.5 arcsec, a reversal of 2.5 arcsec, a
ratio error of 12 ppm (5.18 arcsec over the revolution), and 0.4 arcsec of noise per
reading. The error column is the deviation x = reference - indicated, as laser software
writes it."""

import math
import random

rng = random.Random(38)
rows = ["run,direction,target_deg,deviation_arcsec"]
targets = [15.0 * k for k in range(25)]
for run in range(1, 6):
    for d, order in ((1, targets), (-1, targets[::-1])):
        for t in order:
            e = (6.0 * math.sin(math.radians(t + 40.0))
                 + 1.5 * math.sin(math.radians(8.0 * t + 10.0))
                 + d * 2.5 / 2.0 + 12.0 * t * 3.6e-3 + rng.gauss(0.0, 0.4))
            rows.append(f"{run},{'+1' if d > 0 else '-1'},{t:.3f},{-e:.3f}")
with open("rotary-b.csv", "w", newline="\n") as f:
    f.write("\n".join(rows) + "\n")
