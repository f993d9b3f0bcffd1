#!/usr/bin/python3
"""Writes a DICOM CT as a MetaImage (OUT.mhd and OUT.raw, 16-bit HU) for a machine without xpose's
packages: the GPU harness (xpose-gpu-check --ct OUT.mhd) and xpose itself (--ct OUT.mhd) read it.

    PYTHONPATH=build/lib/python3/dist-packages python3 Utilities/GPU/export-ct.py CT_FOLDER OUT.mhd

The voxels are kept as the reader gives them (HU, 16-bit), cropped to the box of the voxels at or
above the air threshold (-950 HU) with one voxel around it, and every voxel below it written as
-1000: the attenuation volume makes both air, so the harness renders the same DRRs, and the file
compresses well (xz). Offset and TransformMatrix place the crop in the CT's (LPS) frame; the
matrix lists the direction's columns, as MetaIO does.
"""
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy

import xpose

AIR = -950


def main(folder, out):
    reader = xpose.vtkXPDICOMCTReader()
    reader.SetDirectoryName(folder)
    reader.Update()
    image = reader.GetOutput()
    nx, ny, nz = image.GetDimensions()
    if nx * ny * nz == 0:
        sys.exit(f"export-ct.py: error: {folder}: no CT read")
    hu = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(nz, ny, nx)
    if hu.dtype != np.int16:
        sys.exit(f"export-ct.py: error: {folder}: HU are {hu.dtype}, not 16-bit integers")
    inside = hu >= AIR
    if not inside.any():
        sys.exit(f"export-ct.py: error: {folder}: no voxel at or above {AIR} HU: nothing but air")
    low, high = [], []
    for axis in range(3):  # the body's extent along each array axis (z, y, x), one voxel around it
        along = np.flatnonzero(inside.any(axis=tuple(a for a in range(3) if a != axis)))
        low.append(max(along[0] - 1, 0))
        high.append(min(along[-1] + 2, hu.shape[axis]))
    crop = hu[low[0]:high[0], low[1]:high[1], low[2]:high[2]].copy()
    crop[crop < AIR] = -1000
    direction = np.array([[image.GetDirectionMatrix().GetElement(r, c) for c in range(3)] for r in range(3)])
    linear = direction @ np.diag(image.GetSpacing())
    origin = np.array(image.GetOrigin()) + linear @ np.array([low[2], low[1], low[0]], dtype=float)
    origin = origin + linear @ np.array(image.GetExtent()[0::2], dtype=float)  # VTK's indices start at the extent
    if not out.endswith(".mhd"):
        sys.exit("export-ct.py: error: the output is a .mhd header (its voxels go to .raw beside it)")
    raw = out[:-4] + ".raw"
    numbers = lambda values: " ".join(f"{v:.17g}" for v in values)  # noqa: E731
    with open(out, "w") as f:
        f.write("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n")
        f.write(f"DimSize = {crop.shape[2]} {crop.shape[1]} {crop.shape[0]}\n")
        f.write(f"ElementSpacing = {numbers(image.GetSpacing())}\n")
        f.write(f"Offset = {numbers(origin)}\n")
        f.write(f"TransformMatrix = {numbers(direction.T.ravel())}\n")
        f.write(f"ElementType = MET_SHORT\nElementDataFile = {raw.split('/')[-1]}\n")
    with open(raw, "wb") as f:
        f.write(crop.astype("<i2").tobytes())
    print(f"{out}: {crop.shape[2]} x {crop.shape[1]} x {crop.shape[0]} voxels of {nx} x {ny} x {nz}")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
