#!/usr/bin/env python3
"""Compares two runs of the generalisation matrix trial by trial (the same MATRIX_SEED draws the
same trials): per cell and over all right-anatomy cells, the paired change of mTRE over the
trials `ok` in both runs, and the `ok` counts.

Usage: python3 Utilities/compare-matrix-runs.py [--goals] BASE_PREFIX NEW_PREFIX
       python3 Utilities/compare-matrix-runs.py --goals PREFIX   (one run against the goals)
  e.g. eval/s13- eval/vp1--  (each cell's trials.csv lies in PREFIX + cell name).
--goals prints instead, per cell, both runs against the product's goals (success = ok with mTRE
< 2 mm; a right-anatomy cell meets them with >= 9/10 success, a median mTRE of its ok trials
<= 0.35 mm and signed medians tx ty tz within +-0.2 mm; a wrong-anatomy cell with no ok), the
median evaluations, and the totals: ok beyond 2 mm, false failed (not ok, mTRE < 1 mm),
wrong-anatomy ok, median evaluations over every trial and over the right-anatomy ones.  Wrong-anatomy cells are those named wrong-* or near-*.
Beside a cell's success stands the chance that a cell succeeding in 90 % of its trials (the goal)
gives this few successes or fewer (binomial): a cell under 9/10 with a chance over 5 % may be at
the goal and unlucky in its draw; under 5 %, it is short of it. The totals add how many cells
would miss 9/10 by chance alone if every right-anatomy cell succeeded in 95 % or 98 % of its trials."""
import csv
import math
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


def median(values):
    return statistics.median(values) if values else float("nan")


def at_most(k, n, p):
    """P(X <= k) for X binomial(n, p): the chance of k successes or fewer in n trials."""
    return sum(math.comb(n, i) * p ** i * (1 - p) ** (n - i) for i in range(k + 1))


def least_success(n):
    """The fewest successes of n trials that meet the goal of 9 in 10 (integer ceil of 0.9 n)."""
    return (9 * n + 9) // 10


def short_by_chance(n, p):
    """The chance that a cell of n trials succeeding with probability p misses 9 of 10."""
    return at_most(least_success(n) - 1, n, p)


def goals(rows, wrong):
    """One run's figures for one cell against the product's goals."""
    ok = [r for r in rows if r["status"] == "ok"]
    mtre = [float(r["mtre_mm"]) for r in ok]
    figures = {
        "trials": len(rows),
        "success": sum(m < 2 for m in mtre),
        "ok": len(ok),
        "median": median(mtre),
        "signed": [median([float(r[axis]) for r in ok]) for axis in ("error_tx", "error_ty", "error_tz")],
        "beyond": sum(m >= 2 for m in mtre),
        "false_failed": sum(r["status"] != "ok" and float(r["mtre_mm"]) < 1 for r in rows),
        "evaluations": median([float(r["evaluations"]) for r in rows]),
    }
    # Under 9/10: the chance of this few successes or fewer from a cell that meets the 90 % goal.
    short = figures["success"] < least_success(len(rows))
    figures["chance"] = at_most(figures["success"], len(rows), 0.9) if short and not wrong else None
    if wrong:
        figures["meets"] = figures["ok"] == 0
    else:
        figures["meets"] = (not short and figures["median"] <= 0.35
                            and all(abs(s) <= 0.2 for s in figures["signed"]))
    return figures


def print_goals(base, new):
    print("| cell | success (or wrong ok) base -> new (chance at 90 %) | median mTRE of ok (mm) base -> new | "
          "signed medians tx ty tz (mm) new | median evaluations base -> new | goals base / new |")
    print("|---|---|---|---|---|---|")
    totals = {side: {"trials": 0, "beyond": 0, "false_failed": 0, "wrong_ok": 0, "missed": [], "evaluations": [],
                     "right_evaluations": [], "cells": [], "unlucky": []}
              for side in ("base", "new")}
    for cell in sorted(set(cells(base)) & set(cells(new))):
        wrong = cell.startswith(("wrong-", "near-"))
        before, after = trials(base, cell), trials(new, cell)
        n = min(len(before), len(after))
        if n == 0:
            continue  # a cell still running
        figures = {"base": goals(before[:n], wrong), "new": goals(after[:n], wrong)}
        for side, f in figures.items():
            t = totals[side]
            counts = [float(r["evaluations"]) for r in (before if side == "base" else after)[:n]]
            t["evaluations"] += counts
            if not wrong:
                t["right_evaluations"] += counts
            if wrong:
                t["wrong_ok"] += f["ok"]
            else:
                t["trials"] += n
                t["beyond"] += f["beyond"]
                t["false_failed"] += f["false_failed"]
                t["cells"].append(n)
                if f["chance"] is not None and f["chance"] > 0.05:
                    t["unlucky"].append(cell)
            if not f["meets"]:
                t["missed"].append(cell)
        b, a = figures["base"], figures["new"]
        mark = lambda f: "meets" if f["meets"] else "**misses**"
        if wrong:
            print(f"| {cell} | {b['ok']} -> {a['ok']} ok | - | - | {b['evaluations']:.0f} -> {a['evaluations']:.0f} | "
                  f"{mark(b)} / {mark(a)} |")
        else:
            signed = " ".join(f"{s:+.2f}" for s in a["signed"])
            chance = lambda f: "" if f["chance"] is None else f" ({100 * f['chance']:.1f} %)"
            print(f"| {cell} | {b['success']}/{n}{chance(b)} -> {a['success']}/{n}{chance(a)} | "
                  f"{b['median']:.3f} -> {a['median']:.3f} | "
                  f"{signed} | {b['evaluations']:.0f} -> {a['evaluations']:.0f} | {mark(b)} / {mark(a)} |")
    for side in ("base", "new"):
        t = totals[side]
        print(f"\n{side}: right-anatomy trials {t['trials']}; ok beyond 2 mm {t['beyond']}; false failed "
              f"{t['false_failed']} ({100 * t['false_failed'] / max(t['trials'], 1):.1f} %); wrong-anatomy ok "
              f"{t['wrong_ok']}; median evaluations over every trial {median(t['evaluations']):.0f}, over the "
              f"right-anatomy ones {median(t['right_evaluations']):.0f}; "
              f"cells missing the goals {len(t['missed'])}: {' '.join(t['missed'])}; under 9/10 but within chance "
              f"of 90 % ({len(t['unlucky'])}): {' '.join(t['unlucky']) or '-'}")
    expected = {p: sum(short_by_chance(n, p) for n in totals["new"]["cells"]) for p in (0.95, 0.98)}
    print(f"\nBy chance alone, with every one of the new run's {len(totals['new']['cells'])} right-anatomy cells "
          f"succeeding in 95 % of its trials, {expected[0.95]:.1f} of them would be expected under 9/10; at 98 %, "
          f"{expected[0.98]:.1f}.")


def main():
    arguments = sys.argv[1:]
    goals_table = "--goals" in arguments
    arguments = [a for a in arguments if a != "--goals"]
    if goals_table and len(arguments) == 1:
        arguments *= 2  # one run: both sides the same
    if len(arguments) != 2:
        sys.exit(__doc__)
    base, new = arguments
    if goals_table:
        print_goals(base, new)
        return
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
