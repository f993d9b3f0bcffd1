#!/bin/sh
# Usage: parsed-options.sh XPOSE. Each malformed size or point given to register and track is
# refused at the command line: exit 2 and a message naming the option, before any file is read.
xpose=$1
for command in register track; do
  for bad in "--size 600" "--size 0x2" "--iso-ct 1,2" "--target 1,2,x" "--voxel-size 1,-1,1"; do
    option=${bad%% *}
    # shellcheck disable=SC2086 # the option and its value are two words
    message=$("$xpose" $command $bad --ct no-ct --geometry no-geometry.json --out-dir no-out --frames x,y 2>&1 >/dev/null)
    code=$?
    [ $code -eq 2 ] || { echo "$command $bad: exit $code, expected 2 ($message)"; exit 1; }
    case $message in
      *"$option"*) ;;
      *) echo "$command $bad: the message does not name $option: $message"; exit 1 ;;
    esac
    case $message in
      *no-ct* | *no-geometry*) echo "$command $bad: a file was read first: $message"; exit 1 ;;
    esac
  done
done
echo "every malformed size and point refused at the command line"
