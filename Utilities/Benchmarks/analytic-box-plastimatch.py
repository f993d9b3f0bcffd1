#!/usr/bin/env python3
"""Accuracy of xpose and plastimatch DRRs against the analytic line integral of a box.

A 64 mm cube of constant mu = 0.02/mm (1 mm voxels, faces on voxel boundaries) sits at the
isocentre. Both renderers project it onto two views 90 degrees apart (xpose: the reference
geometry Data/geometry/stereo-oblique-90.json; plastimatch: gantry 225 and 315 degrees, SAD 1000,
SID 1500, 400 x 300 mm panel, the views of compare-plastimatch.sh). Each pixel is compared with
mu x (chord of its ray through the cube), the ray taken from that renderer's own geometry (the
JSON for xpose, the projection files plastimatch writes for itself). Interior pixels (all eight
neighbours' rays also cross the cube) measure the integration; silhouette pixels are reported
apart, since there every sampling scheme blurs a sharp edge.

Usage: analytic-box-plastimatch.py [COLSxROWS]   (needs plastimatch and a built xpose)
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
XPOSE = os.environ.get("XPOSE", os.path.join(ROOT, "build", "bin", "xpose"))
GEOMETRY = os.path.join(ROOT, "Data", "geometry", "stereo-oblique-90.json")
MU = 0.02
HALF = 32.0   # half edge of the cube, mm
N = 96        # voxels per side of the volume


def write_volume(path, inside, outside):
    """A N^3 MetaImage of 1 mm voxels centred on (0, 0, 0) with the cube set to `inside`."""
    origin = -(N - 1) / 2.0
    header = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
              "TransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = {0} {0} {0}\nElementSpacing = 1 1 1\n"
              "DimSize = {1} {1} {1}\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n").format(origin, N)
    lo, hi = int(N / 2 - HALF), int(N / 2 + HALF)  # voxels lo..hi-1 span [-32, 32] mm
    row_in = struct.pack("<%df" % N, *[inside if lo <= i < hi else outside for i in range(N)])
    row_out = struct.pack("<%df" % N, *([outside] * N))
    with open(path, "wb") as f:
        f.write(header.encode())
        for k in range(N):
            for j in range(N):
                f.write(row_in if lo <= j < hi and lo <= k < hi else row_out)


def chord(source, target):
    """Length of the segment source->target inside the cube [-HALF, HALF]^3 (slab method)."""
    d = [t - s for s, t in zip(source, target)]
    t0, t1 = 0.0, 1.0
    for a in range(3):
        if d[a] == 0.0:
            if abs(source[a]) > HALF:
                return 0.0
            continue
        ta, tb = (-HALF - source[a]) / d[a], (HALF - source[a]) / d[a]
        t0, t1 = max(t0, min(ta, tb)), min(t1, max(ta, tb))
    return max(0.0, t1 - t0) * math.sqrt(sum(x * x for x in d))


def read_mha_floats(path):
    data = open(path, "rb").read()
    start = data.index(b"ElementDataFile = LOCAL\n") + len(b"ElementDataFile = LOCAL\n")
    header = data[:start].decode()
    assert "MET_FLOAT" in header, path + ": expected float pixels"
    count = (len(data) - start) // 4
    return struct.unpack("<%df" % count, data[start:start + 4 * count])


def errors(values, expected, columns, rows):
    """Relative errors of interior pixels, and errors of silhouette pixels relative to mu x 2 HALF."""
    interior, edge = [], []
    for r in range(rows):
        for c in range(columns):
            e = expected[r * columns + c]
            near = [expected[(r + dr) * columns + c + dc] for dr in (-1, 0, 1) for dc in (-1, 0, 1)
                    if 0 <= r + dr < rows and 0 <= c + dc < columns]
            if len(near) == 9 and min(near) > 0.0:
                interior.append(abs(values[r * columns + c] / e - 1.0))
            elif max(near) > 0.0:
                edge.append(abs(values[r * columns + c] - e) / (MU * 2 * HALF))
    return interior, edge


def xpose_views(work, size, method):
    columns, rows = size
    out = os.path.join(work, "xpose-" + method)
    subprocess.run([XPOSE, "drr", "--ct", os.path.join(work, "box_hu.mha"), "--geometry", GEOMETRY, "--size",
                    "%dx%d" % size, "--mu-water", str(MU), "--method", method, "--out-dir", out],
                   check=True, stdout=subprocess.DEVNULL)
    geometry = json.load(open(GEOMETRY))
    iso = geometry["isocenter"]
    for imager in geometry["imagers"]:
        det = imager["detector"]
        pitch = [det["pixel_spacing"][0] * det["size"][0] / columns, det["pixel_spacing"][1] * det["size"][1] / rows]
        # Room coordinates relative to the isocentre, where the cube's centre is placed.
        source = [s - i for s, i in zip(imager["source"], iso)]
        expected = []
        for r in range(rows):
            for c in range(columns):
                pixel = [det["center"][a] - iso[a] + (c - (columns - 1) / 2) * pitch[0] * det["row_direction"][a] +
                         (r - (rows - 1) / 2) * pitch[1] * det["column_direction"][a] for a in range(3)]
                expected.append(MU * chord(source, pixel))
        transmission = read_mha_floats(os.path.join(out, "drr_%s.mha" % imager["name"]))
        # drr_NAME.mha holds detector row 0 first, as `expected` does.
        values = [-math.log(t) if t > 0 else float("inf") for t in transmission]
        yield imager["name"], values, expected


def plastimatch_views(work, size, algorithm):
    columns, rows = size
    prefix = os.path.join(work, "pm-%s_" % algorithm)
    subprocess.run(["plastimatch", "drr", "-I", os.path.join(work, "box_mu.mha"), "-O", prefix, "-i", algorithm,
                    "-r", "%d %d" % (columns, rows), "-z", "400 300", "--sad", "1000", "--sid", "1500", "-o", "0 0 0",
                    "--vup", "0 0 1", "-t", "raw", "-P", "none", "-y", "3.926990817", "-N", "90", "-a", "2"],
                   check=True, stdout=subprocess.DEVNULL)
    for view in range(2):
        lines = [l.split() for l in open("%s%04d.txt" % (prefix, view)).read().splitlines()]
        centre_column, centre_row = float(lines[0][0]), float(lines[0][1])
        at = [l[0] for l in lines].index("Extrinsic")
        rotation = [[float(x) for x in lines[at + 1 + i][:3]] for i in range(3)]
        translation = [float(lines[at + 1 + i][3]) for i in range(3)]
        intrinsic = [[float(x) for x in lines[at + 6 + i]] for i in range(3)]
        sid = 1.0 / intrinsic[2][2]
        # camera = R room + t; a pixel lies at camera ((c - ic_c)/fx, (r - ic_r)/fy, sid).
        to_room = lambda p: [sum(rotation[i][a] * (p[i] - translation[i]) for i in range(3)) for a in range(3)]
        source = to_room([0.0, 0.0, 0.0])
        expected = [MU * chord(source, to_room([(c - centre_column) / intrinsic[0][0], (r - centre_row) / intrinsic[1][1], sid]))
                    for r in range(rows) for c in range(columns)]
        raw = open("%s%04d.raw" % (prefix, view), "rb").read()
        # Columns fastest; plastimatch sums mu (1/mm) x path length in cm, hence the 10.
        values = [10.0 * v for v in struct.unpack("<%df" % (rows * columns), raw)]
        yield "gantry %d" % (225 + 90 * view), values, expected


def median(values):
    s = sorted(values)
    return s[len(s) // 2] if s else float("nan")


def main():
    size = tuple(int(x) for x in (sys.argv[1] if len(sys.argv) > 1 else "256x192").split("x"))
    with tempfile.TemporaryDirectory() as work:
        write_volume(os.path.join(work, "box_hu.mha"), 0.0, -1000.0)
        write_volume(os.path.join(work, "box_mu.mha"), MU, 0.0)
        print("64 mm cube of mu %.3f/mm at the isocentre, 1 mm voxels, %dx%d per view, 2 views" % (MU, size[0], size[1]))
        print("%-34s %10s %16s %16s %14s" % ("renderer", "interior", "median rel. err", "max rel. err", "edge mean err"))
        runs = [("xpose trilinear (per voxel plane)", xpose_views(work, size, "trilinear")),
                ("xpose siddon (exact)", xpose_views(work, size, "siddon")),
                ("plastimatch drr -i exact", plastimatch_views(work, size, "exact")),
                ("plastimatch drr -i uniform", plastimatch_views(work, size, "uniform"))]
        for name, views in runs:
            interior, edge = [], []
            for _, values, expected in views:
                i, e = errors(values, expected, size[0], size[1])
                interior += i
                edge += e
            print("%-34s %10d %15.5f%% %15.5f%% %13.3f%%" % (name, len(interior), 100 * median(interior),
                  100 * max(interior), 100 * sum(edge) / max(1, len(edge))))
        print("interior: pixels whose 8 neighbours' rays also cross the cube, error / (mu x chord);")
        print("edge: silhouette pixels, mean |error| / (mu x 64 mm)")


if __name__ == "__main__":
    main()
