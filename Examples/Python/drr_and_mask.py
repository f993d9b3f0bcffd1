#!/usr/bin/env python3
"""Renders a DRR of one imager with the xpose DRR filter, computes its block-entropy validity
mask, and writes both as PNG (off-screen: no display needed).

    drr_and_mask.py --ct DICOM_FOLDER --geometry FILE [--view 0] [--pose tx,ty,tz,pitch,roll,yaw]
                    --out-dir DIR

Prints the DRR's size, the image entropy H(X) and the mask's valid fraction.
"""
import argparse
import os
import sys

from vtkmodules.vtkImagingCore import vtkImageShiftScale
from vtkmodules.vtkIOImage import vtkPNGWriter

import xpose


def write_png(port, path):
    writer = vtkPNGWriter()
    writer.SetInputConnection(port)
    writer.SetFileName(path)
    writer.Write()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ct", required=True, help="CT: a DICOM series folder")
    parser.add_argument("--geometry", required=True, help="stereo geometry JSON (Coordinates.md)")
    parser.add_argument("--view", type=int, default=0, help="index of the imager in the geometry")
    parser.add_argument("--pose", default="0,0,0,0,0,0", help="misalignment tx,ty,tz (mm),pitch,roll,yaw (degrees)")
    parser.add_argument("--out-dir", required=True)
    args = parser.parse_args()

    ct = xpose.vtkXPDICOMCTReader()
    ct.SetDirectoryName(args.ct)
    ct.Update()
    if ct.GetErrorText():
        sys.exit(f"drr_and_mask.py: error: {ct.GetErrorText()}")

    drr = xpose.vtkXPDRRFilter()
    drr.SetCTConnection(ct.GetOutputPort())
    if not drr.SetViewFromGeometryFile(args.geometry, args.view) or not drr.SetPatientPosition(ct.GetPatientPosition()):
        sys.exit(f"drr_and_mask.py: error: {drr.GetLastError()}")
    drr.SetMisalignmentParameters(*[float(v) for v in args.pose.split(",")])

    mask = xpose.vtkXPEntropyMaskFilter()
    mask.SetInputConnection(drr.GetOutputPort(0))
    mask.Update()

    # The 12-bit DRR stretched to 8 bits for viewing; the mask is 0/255 already.
    display = vtkImageShiftScale()
    display.SetInputConnection(drr.GetOutputPort(0))
    display.SetScale(255.0 / 4095.0)
    display.SetOutputScalarTypeToUnsignedChar()
    os.makedirs(args.out_dir, exist_ok=True)
    write_png(display.GetOutputPort(), os.path.join(args.out_dir, "drr.png"))
    write_png(mask.GetOutputPort(0), os.path.join(args.out_dir, "mask.png"))
    columns, rows, _ = drr.GetOutput(0).GetDimensions()
    print(f"DRR {columns}x{rows}, H(X) {mask.GetImageEntropy():.3f}, valid fraction {mask.GetValidFraction():.3f}")


if __name__ == "__main__":
    main()
