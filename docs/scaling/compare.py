#!/usr/bin/env python3
"""A cut run's preheats against its reference's (docs/PERFORMANCE.md "Parts at full scale").

Usage: compare.py REFERENCE_DIR CUT_DIR [AMBIENT_C]   (the directories KEEP=DIR measure.sh fills)

Prints, over the path's points whose reference preheat rises more than 10 K above ambient, the
largest and the median |cut - reference| as a share of the reference's rise, and the same of
each revolution's hottest preheat (layers.csv preheat_max_c)."""
import csv
import statistics
import sys


def column(path, name):
    with open(path, newline="") as f:
        return [float(r[name]) for r in csv.DictReader(f)]


def shares(ref, cut, ambient):
    if len(ref) != len(cut):
        sys.exit(f"{len(ref)} rows against {len(cut)}: not the same plan")
    return [abs(c - r) / (r - ambient) for r, c in zip(ref, cut) if r - ambient > 10.0]


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    ref, cut = sys.argv[1], sys.argv[2]
    ambient = float(sys.argv[3]) if len(sys.argv) == 4 else 20.0
    for name, file, col in (("points", "path.csv", "preheat_c"),
                            ("revolutions' hottest", "layers.csv", "preheat_max_c")):
        s = shares(column(f"{ref}/{file}", col), column(f"{cut}/{file}", col), ambient)
        print(f"{name}: within {100 * max(s):.2f} % of the rise "
              f"(median {100 * statistics.median(s):.3f} %, {len(s)} compared)")


main()
