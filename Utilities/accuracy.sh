#!/usr/bin/env bash
# Accuracy of approach B on X-rays that xpose's DRR model did not make (the clinical scenario of
# the physics simulator): the acceptance runs and the ablation table of Documentation/results.md;
# and the generalisation matrix (renderer x detector format x CT, wrong patients, near anatomy).
# Usage: bash Utilities/accuracy.sh [acceptance|ablation|all|matrix] [TRIALS_PER_ROW_OR_CELL]
#        bash Utilities/accuracy.sh matrix TRIALS [EVALUATE_OPTIONS...]   (e.g. --registration-off median)
# MATRIX_OUT=eval/NAME writes the matrix's cells to eval/NAME-CELL (default eval/matrix-CELL);
# MATRIX_ONLY=REGEX runs only the cells whose names match it (e.g. '^pelvis3mm-');
# MATRIX_SEED=N draws other trials and noise (default 11), to see a result is not the draw's;
# MATRIX_KEEP=1 keeps each cell's folder: evaluate resumes from its trials.csv (trial k of a seed
# is the same in any run), so a cell copied from a 10-trial run and run with TRIALS 30 gains 20;
# evaluate refuses a folder whose evaluation.json holds other settings (copy trials.csv alone only
# from a run of the same settings);
# MATRIX_GEOMETRY=FILE puts the matrix's imagers elsewhere (default the reference geometry; e.g.
# Data/geometry/stereo-oblique-60.json, beams 60 degrees apart).
# Needs build/bin/xpose, ../shared/data/ct/ (and plastimatch for the matrix); writes under eval/
# (ignored by git).
set -euo pipefail
cd "$(dirname "$0")/.."
what=${1:-all}
rowTrials=${2:-10}
xpose=${XPOSE:-build/bin/xpose} # XPOSE: a copy, for a long run beside a rebuild
pelvis=../shared/data/ct/vhm-pelvis
geometry=Data/geometry/stereo-oblique-90.json
mkdir -p eval

# One evaluate run; prints its summary row: success, median and largest-ok mTRE, bias per axis, time.
run() { # NAME CT SIZE TRIALS MIN MAX SEED ARGS...
  local name=$1 ct=$2 size=$3 trials=$4 min=$5 max=$6 seed=$7
  shift 7
  local dir=eval/accuracy-$name
  rm -rf "$dir" # a fresh run: evaluate would resume from an earlier run's trials
  "$xpose" evaluate --ct "$ct" --geometry "$geometry" --size "$size" --scenario clinical --approaches B \
    --trials "$trials" --min-start-translation "$min" --max-start-translation "$max" --seed "$seed" "$@" --out-dir "$dir" > "$dir.log"
  local summary bias
  summary=$(grep '^| B: entropy masks' "$dir.log" | head -1)
  bias=$(grep '^| B |' "$dir.log" | head -1)
  awk -F'|' -v name="$name" -v s="$summary" -v b="$bias" 'BEGIN {
    split(s, a, "|"); split(b, c, "|");
    gsub(/^ +| +$/, "", a[4]); gsub(/^ +| +$/, "", a[5]);
    printf "| %s | %s | %s | %s | %s | %s | %s | %s |%s |\n", name, a[3], (a[4] == "-" ? a[5] : a[4]), a[6], c[3], c[4], c[6], c[7], a[10] }'
}

header() {
  echo "| run | trials | success | median mTRE (mm) | median signed error tx ty tz (mm) | pitch roll yaw (deg) | ok beyond 2 mm | largest ok mTRE (mm) | median time (s) |"
  echo "|---|---|---|---|---|---|---|---|---|"
}

# One cell of the matrix: evaluate, then one row from its trials.csv. A cell whose X-rays show
# another anatomy (--xray-ct, --xray-stretch) counts its `ok`: each is a wrong answer.
cell() { # NAME TRIALS ARGS...
  local name=$1 trials=$2
  shift 2
  [[ -z ${MATRIX_ONLY:-} || $name =~ $MATRIX_ONLY ]] || return 0
  local dir=${MATRIX_OUT:-eval/matrix}-$name
  [ "${MATRIX_KEEP:-0}" = 1 ] || rm -rf "$dir"
  "$xpose" evaluate --geometry "${MATRIX_GEOMETRY:-$geometry}" --approaches B --trials "$trials" --min-start-translation 1 --max-start-translation 20 \
    --max-start-rotation 5 --size 512x384 --seed "${MATRIX_SEED:-11}" "$@" "${matrixOptions[@]}" --out-dir "$dir" > "$dir.log" 2>&1 || { echo "| $name | evaluate failed: see $dir.log |"; return; }
  local wrong=0
  case " $* " in *" --xray-ct "*|*" --xray-stretch "*) wrong=1 ;; esac
  awk -F, -v name="$name" -v wrong="$wrong" '
    function median(a, n,   i, j, t) { for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j-1] > a[j]; j--) { t = a[j]; a[j] = a[j-1]; a[j-1] = t }
      return n == 0 ? "-" : (n % 2 ? a[(n+1)/2] : (a[n/2] + a[n/2+1]) / 2) }
    NR > 1 { n++; time[n] = $24; evals[n] = $26
      if (wrong) { if ($12 == "ok") oks++; next }
      if ($12 == "ok") { m++; mtre[m] = $19; ex[m] = $13; ey[m] = $14; ez[m] = $15; if ($19 >= 2) far++ }
      if ($12 == "ok" && $19 < 2) succ++
      if ($12 != "ok" && $19 < 1) falsefail++ }
    END { if (wrong) { printf "| %s | %d | - | - | - | - | - | %d | %.1f | %s |\n", name, n, oks, median(time, n), median(evals, n); exit }
      printf "| %s | %d | %d/%d | %s | %s %s %s | %d | %d | - | %.1f | %s |\n", name, n, succ, n, (m ? sprintf("%.3f", median(mtre, m)) : "-"),
        (m ? sprintf("%+.2f", median(ex, m)) : "-"), (m ? sprintf("%+.2f", median(ey, m)) : "-"), (m ? sprintf("%+.2f", median(ez, m)) : "-"),
        far, falsefail, median(time, n), median(evals, n) }' "$dir/trials.csv"
}

if [ "$what" = matrix ]; then
  [ -d eval/phantom-ct-2mm ] || "$xpose" phantom --out eval/phantom-ct-2mm --spacing 2 > /dev/null
  # The phantom at 1 mm too: the same anatomy at another voxel size (its physics X-rays flatten
  # the held-out peak where the 2 mm phantom's do not; Algorithms.md).
  [ -d eval/phantom-ct-1mm ] || "$xpose" phantom --out eval/phantom-ct-1mm --spacing 1 > /dev/null
  # The pelvis with 3 mm slices (0.9 mm pixels), as most planning CTs are taken: coarser than
  # the X-ray's detail along one axis (Algorithms.md, "A verdict...", 9).
  if [ ! -f eval/pelvis-ct-3mm.nii.gz ]; then
    plastimatch convert --input "$pelvis" --output-img eval/pelvis-ct-1mm.nii.gz > /dev/null
    plastimatch resample --input eval/pelvis-ct-1mm.nii.gz --output eval/pelvis-ct-3mm.nii.gz --spacing "0.9 0.9 3" > /dev/null
  fi
  thorax=../shared/data/ct/thorax-crop/ct.nii.gz
  n=${2:-10}
  matrixOptions=("${@:3}")
  echo "| cell | trials | success (ok, mTRE < 2 mm) | median mTRE of ok (mm) | median signed error of ok tx ty tz (mm) | ok beyond 2 mm | false failed (mTRE < 1 mm) | wrong-anatomy ok | median time (s) | median evaluations |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  for ct in pelvis:$pelvis thorax:$thorax phantom:eval/phantom-ct-2mm phantom1mm:eval/phantom-ct-1mm pelvis3mm:eval/pelvis-ct-3mm.nii.gz; do
    for renderer in plastimatch clinical; do
      for format in linear12 linear16 log processed; do
        cell "${ct%%:*}-$renderer-$format" "$n" --ct "${ct#*:}" --scenario "$renderer" --detector "$format" --dose 20000
      done
      cell "${ct%%:*}-$renderer-log-5000" "$n" --ct "${ct#*:}" --scenario "$renderer" --detector log --dose 5000
    done
  done
  # The treatment room's couch: X-rays that show the CT's table (plastimatch), another couch (the
  # physics simulator) and none (the simulator without its couch), each also with read noise of
  # 0.004 of the open field, where the table's edges stand out of a noisy body.
  for ct in pelvis:$pelvis phantom:eval/phantom-ct-2mm pelvis3mm:eval/pelvis-ct-3mm.nii.gz; do
    cell "${ct%%:*}-nocouch-linear16" "$n" --ct "${ct#*:}" --scenario clinical --without couch --detector linear16 --dose 20000
    for renderer in plastimatch clinical; do
      cell "${ct%%:*}-$renderer-linear16-noise" "$n" --ct "${ct#*:}" --scenario "$renderer" --detector linear16 --dose 20000 --electronic-noise 0.004
    done
    cell "${ct%%:*}-nocouch-linear16-noise" "$n" --ct "${ct#*:}" --scenario clinical --without couch --detector linear16 --dose 20000 --electronic-noise 0.004
  done
  # Another patient, and the same patient 10 % narrower, deeper or longer: none may end ok.
  cell wrong-pelvis-ct-thorax-xrays "$n" --ct "$pelvis" --xray-ct "$thorax" --scenario plastimatch --detector linear16
  cell wrong-thorax-ct-pelvis-xrays "$n" --ct "$thorax" --xray-ct "$pelvis" --scenario plastimatch --detector log
  cell wrong-phantom-ct-pelvis-xrays "$n" --ct eval/phantom-ct-2mm --xray-ct "$pelvis" --scenario plastimatch --detector linear12
  cell wrong-thorax-ct-pelvis-xrays-noise "$n" --ct "$thorax" --xray-ct "$pelvis" --scenario plastimatch --detector linear16 --electronic-noise 0.004
  cell wrong-pelvis-ct-thorax-xrays-nocouch "$n" --ct "$pelvis" --xray-ct "$thorax" --scenario clinical --without couch --detector linear16
  # The near anatomy as raw and as processed images: an unsharp mask leaves the halves less to
  # disagree on.
  for axis in 0 1 2; do
    for factor in 0.9 1.1; do
      cell "near-pelvis-axis$axis-x$factor" "$n" --ct "$pelvis" --xray-stretch "$axis,$factor" --scenario plastimatch --detector linear16
      cell "near-pelvis-axis$axis-x$factor-processed" "$n" --ct "$pelvis" --xray-stretch "$axis,$factor" --scenario plastimatch --detector processed
    done
  done
  exit 0
fi

if [ "$what" = acceptance ] || [ "$what" = all ]; then
  [ -d eval/phantom-ct-2mm ] || "$xpose" phantom --out eval/phantom-ct-2mm --spacing 2 > /dev/null
  header
  run pelvis-0-20mm "$pelvis" 512x384 50 1 20 1
  run pelvis-20-30mm "$pelvis" 512x384 30 20 30 2
  run phantom-0-20mm eval/phantom-ct-2mm 256x192 50 1 20 1
  run phantom-20-30mm eval/phantom-ct-2mm 256x192 30 20 30 2
fi

if [ "$what" = ablation ] || [ "$what" = all ]; then
  echo
  header
  run all-effects "$pelvis" 512x384 "$rowTrials" 1 20 3
  for effect in spectrum pixel-area table couch scatter blur quantum-noise electronic-noise heel log truncation; do
    run "without-$effect" "$pelvis" 512x384 "$rowTrials" 1 20 3 --without "$effect"
  done
  # Scatter's fall-off where the body ends at the CT's end slices: the two effects together.
  run "without-truncation,scatter" "$pelvis" 512x384 "$rowTrials" 1 20 3 --without truncation scatter
  run "registration-keep-table" "$pelvis" 512x384 "$rowTrials" 1 20 3 --keep-table
  for step in levels high-pass coverage levels,high-pass,coverage; do
    run "registration-without-$step" "$pelvis" 512x384 "$rowTrials" 1 20 3 --registration-off "$step"
  done
fi
