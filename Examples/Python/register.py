#!/usr/bin/env python3
"""Registers a planning CT to stereo X-rays with the xpose VTK filters and prints the result
record (the JSON of result.json, without its inputs) on standard output.

    register.py --ct DICOM_FOLDER --geometry FILE --xray A.png --xray B.png [--size 512x384] [--keep-table]

Exit code 0: ok; 3: the registration failed its quality gate; 2: bad input. The pipeline is the
one `xpose register` runs: DICOM reader -> stereo registration filter.
"""
import argparse
import json
import sys

from vtkmodules.vtkIOImage import vtkPNGReader

import xpose


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ct", required=True, help="CT: a DICOM series folder")
    parser.add_argument("--geometry", required=True, help="stereo geometry JSON (Coordinates.md)")
    parser.add_argument("--xray", action="append", required=True, help="12-bit PNG per imager, in order")
    parser.add_argument("--size", default="", help="registration size COLSxROWS, dividing the panels")
    parser.add_argument("--no-entropy-mask", action="store_true", help="register the whole images")
    parser.add_argument("--keep-table", action="store_true",
                        help="render the CT as it is (by default, as xpose register: its table kept or left out as the X-rays show it)")
    args = parser.parse_args()

    ct = xpose.vtkXPDICOMCTReader()
    ct.SetDirectoryName(args.ct)
    ct.Update()
    if ct.GetErrorText():
        fail(ct.GetErrorText())

    registration = xpose.vtkXPStereoRegistrationFilter()
    registration.SetCTConnection(ct.GetOutputPort())
    if not registration.ReadGeometry(args.geometry):
        fail(registration.GetLastError())
    if not registration.SetPatientPosition(ct.GetPatientPosition()):
        fail(registration.GetLastError())
    readers = []
    for path in args.xray:
        reader = vtkPNGReader()
        reader.SetFileName(path)
        reader.Update()
        readers.append(reader)
        registration.AddXRayConnection(reader.GetOutputPort())
    if args.size:
        columns = int(args.size.split("x")[0])
        registration.SetShrinkFactor(readers[0].GetOutput().GetDimensions()[0] // columns)
    registration.SetEntropyMask(not args.no_entropy_mask)
    registration.SetChooseTable(not args.keep_table)
    registration.Update()
    record = registration.GetResultJSON()
    refused = [f["message"] for f in json.loads(record)["failures"] if f["code"] == "invalid_input"]
    if refused:
        fail(refused[0])
    print(record, end="")
    sys.exit(0 if registration.GetResultOk() else 3)


def fail(message):
    print(f"register.py: error: {message}", file=sys.stderr)
    sys.exit(2)


if __name__ == "__main__":
    main()
