#!/usr/bin/env python3
"""Renders a DRR of one imager with the xpose DRR filter, computes its block-entropy validity
mask, compares it with the DRR at the planned pose as a registration compares an X-ray with a
DRR (mutual information over the mask's pixels), and writes the DRR, the mask and a colour
overlay of the two DRRs as PNG (off-screen: no display needed).

    drr_and_mask.py --ct DICOM_FOLDER --geometry FILE [--view 0] [--pose tx,ty,tz,pitch,roll,yaw]
                    --out-dir DIR

Prints the DRR's size, the image entropy H(X), the mask's valid fraction, and the mutual
information and correlation with the planned pose's DRR over the valid pixels.
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

    def drr_at(pose):
        drr = xpose.vtkXPDRRFilter()
        drr.SetCTConnection(ct.GetOutputPort())
        if not drr.SetViewFromGeometryFile(args.geometry, args.view) or not drr.SetPatientPosition(ct.GetPatientPosition()):
            sys.exit(f"drr_and_mask.py: error: {drr.GetLastError()}")
        drr.SetMisalignmentParameters(*pose)
        return drr

    drr = drr_at([float(v) for v in args.pose.split(",")])
    planned = drr_at([0.0] * 6)

    mask = xpose.vtkXPEntropyMaskFilter()
    mask.SetInputConnection(drr.GetOutputPort(0))
    mask.Update()

    # The DRR at --pose in the X-ray's place, the planned pose's DRR as the one a registration
    # would move: their mutual information over the pixels the mask keeps, and an overlay (X-ray
    # magenta, DRR green; aligned structures turn grey).
    metric = xpose.vtkXPMutualInformationMetric()
    metric.SetFixedConnection(drr.GetOutputPort(0))
    metric.SetMovingConnection(planned.GetOutputPort(0))
    metric.SetFixedMaskConnection(mask.GetOutputPort(0))
    metric.Update()
    overlay = xpose.vtkXPOverlayFilter()
    overlay.SetXRayConnection(drr.GetOutputPort(0))
    overlay.SetDRRConnection(planned.GetOutputPort(0))
    overlay.SetModeToColourBlend()

    # The 12-bit DRR stretched to 8 bits for viewing; the mask is 0/255 already.
    display = vtkImageShiftScale()
    display.SetInputConnection(drr.GetOutputPort(0))
    display.SetScale(255.0 / 4095.0)
    display.SetOutputScalarTypeToUnsignedChar()
    os.makedirs(args.out_dir, exist_ok=True)
    write_png(display.GetOutputPort(), os.path.join(args.out_dir, "drr.png"))
    write_png(mask.GetOutputPort(0), os.path.join(args.out_dir, "mask.png"))
    write_png(overlay.GetOutputPort(), os.path.join(args.out_dir, "overlay.png"))
    columns, rows, _ = drr.GetOutput(0).GetDimensions()
    print(f"DRR {columns}x{rows}, H(X) {mask.GetImageEntropy():.3f}, valid fraction {mask.GetValidFraction():.3f}, "
          f"MI with the planned pose's DRR {metric.GetMutualInformation():.3f} "
          f"(NCC {metric.GetNormalizedCrossCorrelation():.3f}) over {metric.GetNumberOfValidPixels()} pixels")


if __name__ == "__main__":
    main()
