#!/usr/bin/env bash
# Two builds of xpose on the same registration, alternately, on the same machine: each run's wall
# time, and whether the two builds' results agree to the last digit (result.json without its
# timings; fields that only the new build writes are left out of the comparison, at any depth).
# For a speed change that must not change any result.
# Usage: compare-builds.sh OLD_BUILD_DIR NEW_BUILD_DIR RUNS -- REGISTER_OPTIONS...
#   (each BUILD_DIR holds bin/xpose and lib/; REGISTER_OPTIONS without --out-dir)
set -euo pipefail
old=$1 new=$2 runs=$3
shift 3
[ "${1:-}" = "--" ] && shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for ((i = 1; i <= runs; i++)); do
  for build in old new; do
    dir=$old
    [ "$build" = new ] && dir=$new
    start=$(date +%s%N)
    LD_LIBRARY_PATH="$dir/lib" "$dir/bin/xpose" register "$@" --out-dir "$work/$build-$i" > "$work/$build-$i.log" 2>&1 || true
    end=$(date +%s%N)
    printf '%s run %d: %d.%02d s (process), %s\n' "$build" "$i" $(((end - start) / 1000000000)) $(((end - start) / 10000000 % 100)) \
      "$(grep -o '^status: [a-zA-Z]*' "$work/$build-$i.log" || echo 'no status')"
  done
done
python3 - "$work" "$runs" <<'PY'
import json, sys
work, runs = sys.argv[1], int(sys.argv[2])
def load(name):
    r = json.load(open(f"{work}/{name}/result.json"))
    r.pop("timing_s", None); r.pop("inputs", None)
    r.setdefault("device", "cpu")  # records written before the GPU path ran on the CPU
    for stage in r.get("convergence", {}).get("stages", []):
        stage.pop("seconds", None)
    return r
added = set()
def known(new, old, path=""):
    """new without the fields old lacks (what the newer build adds, noted in `added` by their
    path, a list's items as []), at every depth."""
    if isinstance(new, dict) and isinstance(old, dict):
        added.update(path + k for k in new if k not in old)
        return {k: known(v, old[k], path + k + ".") for k, v in new.items() if k in old}
    if isinstance(new, list) and isinstance(old, list) and len(new) == len(old):
        return [known(n, o, path.rstrip(".") + "[].") for n, o in zip(new, old)]
    return new
same = True
for i in range(1, runs + 1):
    old, new = load(f"old-{i}"), load(f"new-{i}")
    same &= known(new, old) == old
print("results identical (result.json without timings" + (", fields only the new build writes: " + ", ".join(sorted(added)) if added else "") + "):",
      "yes" if same else "NO")
PY
