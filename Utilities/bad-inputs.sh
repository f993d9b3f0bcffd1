#!/usr/bin/env bash
# Feeds xpose the bad inputs of Documentation/Reliability.md and prints, per case, the exit code,
# the message the user reads, and whether anything was left in the output folder.
# Usage: bash Utilities/bad-inputs.sh [build/bin/xpose] [work folder]
set -uo pipefail
cd "$(dirname "$0")/.."
xpose=$(realpath "${1:-build/bin/xpose}")
work=${2:-bad-inputs}
geometry=$(realpath Data/geometry/stereo-oblique-90.json)
rm -rf "$work" && mkdir -p "$work" && cd "$work" || exit 1

# Good inputs to damage: the phantom as DICOM and MetaImage, X-rays of it, a ROI.
"$xpose" phantom --out ct --spacing 3 >/dev/null
"$xpose" simulate --ct ct --geometry "$geometry" --pose 3,-2,1,1,0,1 --noise 10 --out-dir xr >/dev/null
"$xpose" mask --xray xr/xray_A.png --out-dir roi >/dev/null
"$xpose" simulate --ct ct --geometry "$geometry" --pose 0,0,0,0,0,0 --size 512x384 --out-dir xr-small >/dev/null
python3 - <<'EOF'
import gzip, os, shutil, struct, zlib

def element(data, group, elem):
    """Offset and length of an implicit-VR little-endian element (the phantom writer's encoding)."""
    i = data.find(struct.pack('<HH', group, elem))
    return i, struct.unpack('<I', data[i + 4:i + 8])[0]

def set_element(data, group, elem, value):
    i, n = element(data, group, elem)
    value += b' ' * (len(value) % 2)
    return data[:i + 4] + struct.pack('<I', len(value)) + value + data[i + 8 + n:]

def series(name, change):
    shutil.copytree('ct', name)
    for f in sorted(os.listdir(name)):
        p = os.path.join(name, f)
        data = open(p, 'rb').read()
        open(p, 'wb').write(change(data, f))

slices = sorted(os.listdir('ct'))
first = slices[0]
series('ct-cut-header', lambda d, f: d[:200] if f == first else d)
series('ct-spacing-inf', lambda d, f: set_element(d, 0x0028, 0x0030, b'inf\\inf'))
series('ct-position-nan', lambda d, f: set_element(d, 0x0020, 0x0032, b'nan\\nan\\nan'))
series('ct-rows-beyond-data', lambda d, f: set_element(d, 0x0028, 0x0010, struct.pack('<H', 60000)) if f == first else d)
series('ct-mixed-series', lambda d, f: set_element(d, 0x0020, 0x000e, b'1.2.3.4.5') if f == first else d)
# A slice moved 0.7 mm: non-uniform spacing.
def moved(d, f):
    if f != slices[5]:
        return d
    i, n = element(d, 0x0020, 0x0032)
    x, y, z = [float(v) for v in d[i + 8:i + 8 + n].decode().strip().split('\\')]
    return set_element(d, 0x0020, 0x0032, ('%g\\%g\\%g' % (x, y, z + 0.7)).encode())
series('ct-nonuniform', moved)
# A DX X-ray: a CT slice relabelled, then with half its pixel data cut off.
d = open(os.path.join('ct', first), 'rb').read()
dx = set_element(d, 0x0008, 0x0060, b'DX')
open('dx-whole.dcm', 'wb').write(dx)
i, n = element(dx, 0x7fe0, 0x0010)
open('dx-half.dcm', 'wb').write(dx[:i + 8 + n // 2])

# MetaImage and NIfTI copies of a small CT, then damaged.
hdr = ('ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n'
       'TransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = -30 -30 -20\nElementSpacing = 2 2 2\n'
       'DimSize = 30 30 20\nElementType = MET_SHORT\nElementDataFile = LOCAL\n')
voxels = b''.join(struct.pack('<h', 300 if (x - 15) ** 2 + (y - 15) ** 2 < 40 else -1000)
                  for z in range(20) for y in range(30) for x in range(30))
open('ct.mha', 'wb').write(hdr.encode() + voxels)
open('ct-cut-third.mha', 'wb').write(hdr.encode() + voxels[:len(voxels) * 2 // 3])
open('ct-dimsize-beyond-data.mha', 'wb').write(hdr.replace('DimSize = 30 30 20', 'DimSize = 40 40 30').encode() + voxels)
open('ct-spacing-zero.mha', 'wb').write(hdr.replace('ElementSpacing = 2 2 2', 'ElementSpacing = 0 2 2').encode() + voxels)
open('ct-huge.mha', 'wb').write(hdr.replace('DimSize = 30 30 20', 'DimSize = 60000 60000 60000').encode() + voxels)
nii = bytearray(352)
struct.pack_into('<i', nii, 0, 348)
struct.pack_into('<8h', nii, 40, 3, 30, 30, 20, 1, 1, 1, 1)
struct.pack_into('<hh', nii, 70, 4, 16)
struct.pack_into('<8f', nii, 76, 1, 2, 2, 2, 0, 0, 0, 0)
struct.pack_into('<f', nii, 108, 352)
nii[344:348] = b'n+1\0'
open('ct.nii', 'wb').write(bytes(nii) + voxels)
whole = gzip.compress(bytes(nii) + voxels)
open('ct-cut.nii.gz', 'wb').write(whole[:len(whole) * 2 // 3])
struct.pack_into('<f', nii, 80, float('nan'))
open('ct-pixdim-nan.nii', 'wb').write(bytes(nii) + voxels)

# PNGs: cut, damaged IDAT, a header larger than its data.
png = open('xr/xray_A.png', 'rb').read()
open('xray-cut.png', 'wb').write(png[:len(png) * 2 // 3])
b = bytearray(png); k = png.index(b'IDAT')
for j in range(k + 40, k + 120): b[j] ^= 0x5a
open('xray-damaged-idat.png', 'wb').write(bytes(b))
b = bytearray(png); w, h = struct.unpack('>II', b[16:24]); b[16:24] = struct.pack('>II', w, h * 2)
b[29:33] = struct.pack('>I', zlib.crc32(bytes(b[12:29])) & 0xffffffff)
open('xray-ihdr-beyond-data.png', 'wb').write(bytes(b))
roi = open('roi/mask.png', 'rb').read()
open('roi-cut.png', 'wb').write(roi[:len(roi) // 2])
EOF
python3 - "$geometry" <<'EOF'
import json, sys
g = json.load(open(sys.argv[1]))
bad = dict(g); bad['name'] = {}
json.dump(bad, open('geometry-name-object.json', 'w'))
bad = json.loads(json.dumps(g)); bad['imagers'][0]['name'] = '../../evil'
json.dump(bad, open('geometry-imager-path.json', 'w'))
bad = json.loads(json.dumps(g)); bad['imagers'][1]['detector']['pixel_spacing'] = [0.4, -0.4]
json.dump(bad, open('geometry-negative-spacing.json', 'w'))
bad = json.loads(json.dumps(g)); bad['imagers'][1]['detector']['size'] = [1024, 700]
json.dump(bad, open('geometry-size-differs.json', 'w'))
EOF
touch a-file

register() { "$xpose" register --geometry "${G:-$geometry}" --size 256x192 --out-dir out "$@"; }
xrays=(--xray xr/xray_A.png --xray xr/xray_B.png)
printf '| # | bad input | exit | what the user reads (first line of stderr) | left in the output folder |\n|---|---|---|---|---|\n'
n=0
case_() {
  local what=$1; shift
  rm -rf out
  local message code
  "$@" >/dev/null 2>stderr.txt
  code=$?
  message=$(head -1 stderr.txt | cut -c1-190 | sed 's/|/\\|/g')
  local left="nothing"
  [ -d out ] && left=$(ls -A out | tr '\n' ' ')
  [ -z "$left" ] && left="an empty folder"
  n=$((n + 1))
  printf '| %d | %s | %s | `%s` | %s |\n' "$n" "$what" "$code" "$message" "$left"
}
case_ "MetaImage CT, data cut by a third" register --ct ct-cut-third.mha "${xrays[@]}"
case_ "MetaImage CT, DimSize larger than its data" register --ct ct-dimsize-beyond-data.mha "${xrays[@]}"
case_ "MetaImage CT, DimSize 60000^3" register --ct ct-huge.mha "${xrays[@]}"
case_ "MetaImage CT, spacing 0" register --ct ct-spacing-zero.mha "${xrays[@]}"
case_ "NIfTI CT (.nii.gz) cut short" register --ct ct-cut.nii.gz "${xrays[@]}"
case_ "NIfTI CT, pixdim NaN" register --ct ct-pixdim-nan.nii "${xrays[@]}"
case_ "DICOM CT, a file cut inside its header" register --ct ct-cut-header "${xrays[@]}"
case_ "DICOM CT, Pixel Spacing inf" register --ct ct-spacing-inf "${xrays[@]}"
case_ "DICOM CT, Image Position NaN" register --ct ct-position-nan "${xrays[@]}"
case_ "DICOM CT, Rows 60000 on one slice" register --ct ct-rows-beyond-data "${xrays[@]}"
case_ "DICOM CT, one slice of another series" register --ct ct-mixed-series "${xrays[@]}"
case_ "DICOM CT, one slice moved 0.7 mm" register --ct ct-nonuniform "${xrays[@]}"
case_ "X-ray PNG cut short" register --ct ct --xray xray-cut.png --xray xr/xray_B.png
case_ "X-ray PNG with a damaged IDAT chunk" register --ct ct --xray xray-damaged-idat.png --xray xr/xray_B.png
case_ "X-ray PNG whose IHDR is larger than its data" register --ct ct --xray xray-ihdr-beyond-data.png --xray xr/xray_B.png
case_ "ROI PNG cut short" register --ct ct "${xrays[@]}" --roi roi-cut.png --roi roi/mask.png
case_ "DX X-ray missing half its pixel data" "$xpose" mask --xray dx-half.dcm --out-dir out
case_ "The same X-ray for both imagers" register --ct ct --xray xr/xray_A.png --xray xr/xray_A.png
case_ "X-ray of another size than the panel" register --ct ct --xray xr-small/xray_A.png --xray xr/xray_B.png
case_ "--max-translation nan --max-rotation nan" register --ct ct "${xrays[@]}" --max-translation nan --max-rotation nan
case_ "--max-translation -5" register --ct ct "${xrays[@]}" --max-translation -5
case_ "An unknown option" register --ct ct "${xrays[@]}" --no-such-option
case_ "--report pointing at a file" register --ct ct "${xrays[@]}" --report a-file
case_ "Geometry with \"name\": {}" env G=geometry-name-object.json bash -c "$(declare -f register); xpose='$xpose'; register --ct ct ${xrays[*]}"
case_ "Geometry with an imager named ../../evil" "$xpose" drr --ct ct --geometry geometry-imager-path.json --out-dir out
case_ "Geometry with a negative pixel spacing" "$xpose" drr --ct ct --geometry geometry-negative-spacing.json --out-dir out
case_ "Geometry whose panel size differs from the X-ray" env G=geometry-size-differs.json bash -c "$(declare -f register); xpose='$xpose'; register --ct ct ${xrays[*]}"
case_ "drr --step 1e-9" "$xpose" drr --ct ct --geometry "$geometry" --step 1e-9 --out-dir out
case_ "mask --window 100" "$xpose" mask --xray xr/xray_A.png --window 100 --out-dir out
cp xr/xray_A.png xr-copy-A.png; cp xr/xray_B.png xr-copy-B.png
"$xpose" register --ct ct --geometry "$geometry" --size 256x192 --xray xr-copy-A.png --xray xr-copy-B.png --out-dir done >/dev/null
cp xr/xray_B.png xr-copy-A.png
case_ "report after an X-ray file was replaced" "$xpose" report --result done/result.json --out-dir out
