#!/usr/bin/env python3
"""What the halves' limit where the held-out peak is clear would have decided on stored matrix runs.

Reads each cell's trials.csv under the given prefixes (eval/NAME-CELL/trials.csv, as
Utilities/accuracy.sh matrix writes them) and lists the trials that failed on their halves alone
(every message in `reasons` a `halves_disagree` one) with every view's `halves_apart_mm` within
--clear-halves-mm and a `peak_margin` of at least --clear-peak-margin: the trials that
StereoRegistrationSettings::maxHalvesApartClearPeakMM and clearPeakMargin pass. Then, for the
wrong- and near-anatomy cells (named wrong-* or near-*), the trials failed on their halves alone
whatever their limits, with their leads: how far such anatomy stays from the rule.
A trial that several runs share (the same cell, trial and mTRE) is listed once. A halves failure
is told by its message ("its two halves ..."); the tool stops if none of the failed trials' reasons
names the halves although their halves lie beyond every limit.

Usage: python3 Utilities/halves-what-if.py [--clear-halves-mm 1.25] [--clear-peak-margin 0.17] PREFIX...
  e.g. python3 Utilities/halves-what-if.py eval/m20- eval/pl-
"""
import argparse
import csv
import glob
import os


def trials(prefixes):
    """(prefix, cell, row) for every trial under the prefixes."""
    for prefix in prefixes:
        for path in sorted(glob.glob(prefix + "*/trials.csv")):
            cell = os.path.dirname(path)[len(prefix):]
            with open(path, newline="") as f:
                for row in csv.DictReader(f):
                    yield prefix, cell, row


def halves_alone(row):
    """The trial's largest halves distance when its halves alone failed it, else None."""
    if row.get("status") == "ok" or not row.get("reasons") or not row.get("halves_apart_mm"):
        return None
    messages = [m for m in row["reasons"].split("; ") if m.strip()]
    if not all("two halves" in m for m in messages):
        return None
    return max(float(x) for x in row["halves_apart_mm"].split())


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--clear-halves-mm", type=float, default=1.25)
    parser.add_argument("--clear-peak-margin", type=float, default=0.17)
    parser.add_argument("prefixes", nargs="+")
    args = parser.parse_args()
    passed, wrong, seen = [], [], set()
    named = beyond = 0  # trials whose reasons name the halves; failed trials with halves beyond any limit
    for prefix, cell, row in trials(args.prefixes):
        named += "two halves" in row.get("reasons", "")
        beyond += row.get("status") != "ok" and bool(row.get("halves_apart_mm")) and \
            max(float(x) for x in row["halves_apart_mm"].split()) > max(args.clear_halves_mm, 1.0)
        halves = halves_alone(row)
        if halves is None:
            continue
        key = (cell, row["trial"], row["mtre_mm"])
        if key in seen:
            continue
        seen.add(key)
        lead, mtre = float(row["peak_margin"]), float(row["mtre_mm"])
        entry = (prefix, cell, row["trial"], mtre, halves, lead)
        if cell.startswith(("wrong", "near")):
            wrong.append(entry)
        if halves <= args.clear_halves_mm and lead >= args.clear_peak_margin:
            passed.append(entry)
    if beyond and not named:
        raise SystemExit("halves-what-if: failed trials have halves beyond every limit but no reason names "
                         "'two halves': has the gate's halves_disagree message changed?")
    print(f"Failed on their halves alone, halves <= {args.clear_halves_mm} mm and a lead >= {args.clear_peak_margin}:")
    print("| run | cell | trial | mTRE (mm) | halves apart (mm) | held-out lead | anatomy |")
    print("|---|---|---|---|---|---|---|")
    for p, c, t, m, h, l in sorted(passed, key=lambda e: e[3]):
        print(f"| {p} | {c} | {t} | {m:.3f} | {h:.2f} | {l:.3f} | {'WRONG' if c.startswith(('wrong', 'near')) else 'right'} |")
    right = [e for e in passed if not e[1].startswith(("wrong", "near"))]
    print(f"\n{len(passed)} trials would pass: {len(right)} of the right anatomy (largest mTRE "
          f"{max((e[3] for e in right), default=0.0):.3f} mm), {len(passed) - len(right)} of another anatomy.")
    print("\nWrong- and near-anatomy trials failed on their halves alone, largest leads first:")
    print("| run | cell | trial | mTRE (mm) | halves apart (mm) | held-out lead |")
    print("|---|---|---|---|---|---|")
    for p, c, t, m, h, l in sorted(wrong, key=lambda e: -e[5])[:10]:
        print(f"| {p} | {c} | {t} | {m:.3f} | {h:.2f} | {l:.3f} |")


if __name__ == "__main__":
    main()
