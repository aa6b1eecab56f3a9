#!/usr/bin/python3
"""make_dicom_series.py - writes a raw uint8 CT volume as a DICOM CT series (one file per
slice, in a shuffled order of names), for picvr-render's DICOM reader and the README.

    tools/make_dicom_series.py IN_XxYxZ_uint8.raw.gz OUT_DIR [--slope S] [--intercept I]

The raw volumes of ../shared/data carry no calibration.  The series stores the raw values
as int16 with RescaleSlope S and RescaleIntercept I (default 8 and -1000: value 0, air,
becomes -1000 HU, and each unit 8 HU), so that the Hounsfield-unit presets apply; that
calibration is made up, and said so in each file's ImageComments.  Geometry: 1 mm voxels;
the raw y axis (up in picvr's default view) becomes the patient's superior (+z) axis, one
axial slice per raw y, raw x the patient's left (+x), raw z the patient's anterior (-y): a
rotation, so the volume is not mirrored.  Uses Debian's python3-pydicom and python3-numpy.
"""
import argparse
import datetime
import gzip
import os
import random
import re
import sys

import numpy as np
import pydicom
from pydicom.dataset import FileDataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("raw")
    ap.add_argument("out_dir")
    ap.add_argument("--slope", type=float, default=8.0)
    ap.add_argument("--intercept", type=float, default=-1000.0)
    a = ap.parse_args()
    m = re.search(r"_(\d+)x(\d+)x(\d+)_uint8\.raw(\.gz)?$", a.raw)
    if not m:
        sys.exit("make_dicom_series: the name must end in _XxYxZ_uint8.raw[.gz]")
    nx, ny, nz = (int(m.group(i)) for i in (1, 2, 3))
    opener = gzip.open if a.raw.endswith(".gz") else open
    with opener(a.raw, "rb") as f:
        data = np.frombuffer(f.read(), dtype=np.uint8)
    if data.size != nx * ny * nz:
        sys.exit("make_dicom_series: %d bytes, the name says %d" % (data.size, nx * ny * nz))
    vol = data.reshape(nz, ny, nx)           # [z][y][x], x fastest
    os.makedirs(a.out_dir, exist_ok=True)
    study, series, frame = generate_uid(), generate_uid(), generate_uid()
    names = list(range(ny))
    random.Random(1).shuffle(names)          # file names in no order: the reader sorts by position
    today = datetime.date.today().strftime("%Y%m%d")
    for k in range(ny):                      # slice k: raw y = k, at z = k mm
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        path = os.path.join(a.out_dir, "IM%04d.dcm" % names[k])
        ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
        ds.SOPClassUID = CTImageStorage
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID, ds.SeriesInstanceUID, ds.FrameOfReferenceUID = study, series, frame
        ds.Modality = "CT"
        ds.PatientName = "picvr^test"
        ds.PatientID = "picvr"
        ds.StudyDate = ds.SeriesDate = today
        ds.SeriesNumber, ds.InstanceNumber = 1, k + 1
        ds.ImageComments = ("%s as DICOM; rescale %g, %g is made up (the data carry no calibration)"
                            % (os.path.basename(a.raw), a.slope, a.intercept))
        # one axial slice: columns along raw x (patient left, +x), rows along raw z (anterior, -y)
        ds.ImageOrientationPatient = [1, 0, 0, 0, -1, 0]
        ds.ImagePositionPatient = [0.0, 0.0, float(k)]
        ds.PixelSpacing = [1.0, 1.0]
        ds.SliceThickness = 1.0
        ds.Rows, ds.Columns = nz, nx
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.RescaleSlope, ds.RescaleIntercept, ds.RescaleType = a.slope, a.intercept, "HU"
        ds.PixelData = np.ascontiguousarray(vol[:, k, :].astype("<i2")).tobytes()   # rows = raw z
        ds.is_little_endian, ds.is_implicit_VR = True, False
        ds.save_as(path, write_like_original=False)
    print("make_dicom_series: %d slices of %dx%d in %s" % (ny, nx, nz, a.out_dir))


if __name__ == "__main__":
    main()
