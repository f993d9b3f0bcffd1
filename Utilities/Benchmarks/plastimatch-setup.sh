# Sourced by the plastimatch benchmarks: checks the tools, converts the CT to .mha in a temporary
# folder ($work, removed on exit) and defines pm_drr, which renders the reference geometry's two
# views with plastimatch. Expects $ct, $size, $xpose set; $ct_type (short|float) is optional.
command -v plastimatch >/dev/null || { echo "plastimatch not found: apt-get install plastimatch" >&2; exit 2; }
[ -x "$xpose" ] || { echo "xpose not built at $xpose" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cols=${size%x*}; rows=${size#*x}

plastimatch convert --input "$ct" --output-img "$work/ct.mha" ${ct_type:+--output-type "$ct_type"} >/dev/null
# Isocentre = CT centre (xpose's default): origin + (size - 1) / 2 * spacing, LPS, axial CT.
read -r iso < <(plastimatch header "$work/ct.mha" | awk '
  /^Origin/ {o1=$3; o2=$4; o3=$5} /^Size/ {s1=$3; s2=$4; s3=$5} /^Spacing/ {p1=$3; p2=$4; p3=$5}
  END {printf "%.3f %.3f %.3f\n", o1+(s1-1)/2*p1, o2+(s2-1)/2*p2, o3+(s3-1)/2*p3}')

# The reference geometry's two views: panel 400 x 300 mm, SAD 1000, SID 1500, gantry 225 and 315
# degrees. $1 = exact|uniform, $2 = "cols rows".
pm_drr() {
  plastimatch drr -I "$work/ct.mha" -O "$work/pm_" -i "$1" -r "$2" -z "400 300" --sad 1000 --sid 1500 \
    -o "$iso" --vup "0 0 1" -t pfm -y 3.926990817 -N 90 -a 2 >/dev/null
}
seconds() { local s e; s=$(date +%s.%N); "$@"; e=$(date +%s.%N); echo "$e - $s" | bc -l; }
