#!/bin/sh
# Usage: gate-options.sh XPOSE. The held-out check's and the halves' gate limits out of range are
# refused by register and evaluate alike: exit 2 and a message naming the option, before any file
# is read (none of these exists).
xpose=$1
for command in register evaluate; do
  inputs="--ct no-ct --geometry no-geometry.json --out-dir no-out"
  [ $command = register ] && inputs="$inputs --xray a.png --xray b.png"
  for bad in "--clear-peak-margin 5" "--max-halves-apart-clear-peak-mm -1" "--min-peak-margin 2" "--max-halves-apart-mm 0"; do
    option=${bad%% *}
    # shellcheck disable=SC2086 # options and values are separate words
    message=$("$xpose" $command $inputs $bad 2>&1 >/dev/null)
    code=$?
    [ $code -eq 2 ] || { echo "$command $bad: exit $code, expected 2 ($message)"; exit 1; }
    case $message in
      *"$option: must be"*) ;;
      *) echo "$command $bad: the message does not name $option: $message"; exit 1 ;;
    esac
  done
done
echo "every out-of-range held-out and halves limit refused at the command line"
