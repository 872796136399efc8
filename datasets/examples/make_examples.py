#!/usr/bin/env python3
"""Writes the README tour's example inputs (datasets/examples/): errmap's own synthetic
files in the layouts of the formats errmap imports. Deterministic: the same files every
run (`python3 datasets/examples/make_examples.py`). See datasets/examples/README.md."""
import math
import os
import random

HERE = os.path.dirname(os.path.abspath(__file__))
IN = 25.4  # mm per inch, exact


def error_um(p_mm, direction, axis_len_mm, rng):
    """The planted machine: a scale error, a pitch error of the screw, a reversal, noise."""
    ppm = 14.0
    pitch = 2.5 * math.sin(2 * math.pi * p_mm / (axis_len_mm / 2.5))
    reversal = 1.6 * direction / 2
    return ppm * 1e-3 * p_mm + pitch + reversal + rng.gauss(0.0, 0.35)


def api_pos(path):
    """An API XD "Linear Data Table" of an inch machine's X axis: 0-20 in every 2 in,
    5 bidirectional runs, LasRead counting negative (as the real X export does)."""
    rng = random.Random(11)
    targets = [2.0 * i for i in range(11)]
    rows = []
    for run in range(5):
        for direction, order in ((1, targets), (-1, targets[::-1])):
            for p in order:
                e = error_um(p * IN, direction, 20 * IN, rng)
                lin_err = -e / 1000.0 / IN  # laser - position, inch
                t_f = 68.2 + 0.1 * run + rng.gauss(0, 0.02)
                rows.append((p, lin_err, t_f))
    out = ["API X-D Laser Measurement Linear Data Table (Company Name: errmap examples)",
           "MachName: VMC-07",
           "TestAxis: \t(X)",
           "Unit:\tinch\t0",
           "IniPos:\t0",
           "EndPos:\t20",
           "Length: 20\tIncrem: 2\tRunNum: 5\tNumofPos: 11",
           "TestType: Bidirection\tDwell: 3",
           "Humidity: 45",
           "",
           "    Position\t      LasRead\t  LinearError\tStatus\tAirTemp\tAirPress\tMatTemp\tMatTemp2\tMatTemp3"]
    for p, le, t_f in rows:
        las = -(p + le)
        out.append(f"{p:12.5f}\t{las:13.6f}\t{le:13.6f}\t     0\t{t_f:.2f}\t29.88\t{t_f + 0.3:.2f}\t-1.00\t-1.00")
    out += ["DecimalPoints:\t4", "", "API Linear Error Compensation Table",
            "Position   \tBidirectional Avg Error"]
    for p in targets:
        vals = [le for q, le, _ in rows if q == p]
        out.append(f"{p:9.6f}\t{sum(vals) / len(vals):9.6f}")
    with open(path, "w", newline="\r\n") as f:
        f.write("\n".join(out) + "\n")


def sheet_de(path):
    """A German-locale spreadsheet (semicolons, decimal commas): Y axis, 0-500 mm every
    50 mm, 5 bidirectional runs, the deviation x = reference - indicated in µm."""
    rng = random.Random(12)
    targets = [50.0 * i for i in range(11)]
    out = ["Lauf;Richtung;Soll_mm;Abweichung_um;Lufttemperatur_C"]
    for run in range(1, 6):
        for sign, order in (("+", targets), ("-", targets[::-1])):
            for p in order:
                e = error_um(p, 1 if sign == "+" else -1, 500.0, rng)
                t = 20.15 + 0.02 * run + rng.gauss(0, 0.01)
                out.append(f"{run};{sign};{p:.1f};{-e:.2f};{t:.2f}".replace(".", ","))
    with open(path, "w", encoding="utf-8-sig", newline="\r\n") as f:
        f.write("\n".join(out) + "\n")


def sheet_en(path):
    """An English spreadsheet in inch and °F: Z axis, 0-12 in every 1 in, 5 bidirectional
    runs, the target and the laser reading."""
    rng = random.Random(13)
    targets = [1.0 * i for i in range(13)]
    out = ["run,direction,target_in,laser_in,air_F"]
    for run in range(1, 6):
        for sign, order in (("up", targets), ("down", targets[::-1])):
            for p in order:
                e = error_um(p * IN, 1 if sign == "up" else -1, 12 * IN, rng)
                laser = p - e / 1000.0 / IN
                out.append(f"{run},{sign},{p:.1f},{laser:.6f},{68.4 + rng.gauss(0, 0.03):.2f}")
    with open(path, "w", newline="\n") as f:
        f.write("\n".join(out) + "\n")


def fagor_alx(path):
    """The Fagor 8055 leadscrew table now in the X axis' controller (inch): an older
    calibration's errors at the same 11 points, one table for both directions."""
    out = []
    for i in range(11):
        p = 2.0 * i
        err = round(-(10.0 * 1e-3 * p * IN + 2.0 * math.sin(2 * math.pi * p / 8.0)) / 1000.0 / IN, 5)
        err = 0.0 if err == 0 else err
        out.append(f"      P{i + 1:03d}          X {p:10.5f}       EX {err:10.5f}        EX    0.00000")
    with open(path, "w", newline="\r\n") as f:
        f.write("\n".join(out) + "\n\n")


if __name__ == "__main__":
    api_pos(os.path.join(HERE, "x-axis.pos"))
    sheet_de(os.path.join(HERE, "y-axis-de.csv"))
    sheet_en(os.path.join(HERE, "z-axis-en.csv"))
    fagor_alx(os.path.join(HERE, "ALX"))
