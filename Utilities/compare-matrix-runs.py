#!/usr/bin/env python3
"""Compares two runs of the generalisation matrix trial by trial (the same MATRIX_SEED draws the
same trials): per cell and over all right-anatomy cells, the paired change of mTRE over the
trials `ok` in both runs, and the `ok` counts.

Usage: python3 Utilities/compare-matrix-runs.py BASE_PREFIX NEW_PREFIX
  e.g. eval/s13- eval/vp1--  (each cell's trials.csv lies in PREFIX + cell name)."""
import csv
import os
import statistics
import sys


def cells(prefix):
    folder, stem = os.path.dirname(prefix) or ".", os.path.basename(prefix)
    return sorted(name[len(stem):] for name in os.listdir(folder)
                  if name.startswith(stem) and os.path.isfile(os.path.join(folder, name, "trials.csv")))


def trials(prefix, cell):
    with open(prefix + cell + "/trials.csv", newline="") as f:
        return list(csv.DictReader(f))


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    base, new = sys.argv[1], sys.argv[2]
    every = []
    print("| cell | paired trials | ok base -> new | paired median change (mm) | largest worsening (mm) | largest gain (mm) |")
    print("|---|---|---|---|---|---|")
    for cell in sorted(set(cells(base)) & set(cells(new))):
        before, after = trials(base, cell), trials(new, cell)
        n = min(len(before), len(after))
        changes = [float(a["mtre_mm"]) - float(b["mtre_mm"]) for b, a in zip(before[:n], after[:n])
                   if b["status"] == "ok" and a["status"] == "ok"]
        ok = lambda rows: sum(r["status"] == "ok" for r in rows[:n])
        if not cell.startswith(("wrong-", "near-")):
            every += changes
        if changes:
            print(f"| {cell} | {len(changes)} | {ok(before)} -> {ok(after)} | {statistics.median(changes):+.3f} | "
                  f"{max(changes):+.3f} | {min(changes):+.3f} |")
        else:
            print(f"| {cell} | 0 | {ok(before)} -> {ok(after)} | - | - | - |")
    if every:
        better = sum(c < 0 for c in every) / len(every)
        print(f"\nRight-anatomy trials ok in both: {len(every)}; closer to the truth in {100 * better:.0f} %; "
              f"paired median change {statistics.median(every):+.4f} mm; worst {max(every):+.3f} mm, best {min(every):+.3f} mm")


if __name__ == "__main__":
    main()
