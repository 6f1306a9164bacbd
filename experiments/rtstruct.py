"""DICOM RT Structure Set reading for the experiments (pydicom).

An RT-STRUCT holds, per ROI (StructureSetROISequence: number -> name), a
ROIContourSequence item whose ContourSequence lists closed planar polygons
(ContourGeometricType CLOSED_PLANAR) as flat ContourData x0 y0 z0 x1 y1 z1 ...
in DICOM patient coordinates (mm; for an axial head-first-supine set x grows
to the patient's left = image column, y grows posterior = image row, z grows
towards the head). Every polygon lies in one plane z = const.

`read_rtstruct(path)` returns {roi name: {z_mm: [polygon (k, 2) array of x, y mm, ...]}}
with z rounded to 0.01 mm (so contours of one plane group together), ROIs
without contours omitted, explicitly repeated closing points and consecutive
duplicate points removed.
"""
import collections

import numpy as np


def _clean(poly):
    """Drops consecutive duplicate points and a repeated closing point."""
    keep = [0]
    for i in range(1, len(poly)):
        if np.any(poly[i] != poly[keep[-1]]):
            keep.append(i)
    p = poly[keep]
    if len(p) > 1 and np.all(p[-1] == p[0]):
        p = p[:-1]
    return p


def read_rtstruct(path):
    import pydicom  # imported here so that the module loads without pydicom

    ds = pydicom.dcmread(path)
    if getattr(ds, "Modality", "") != "RTSTRUCT":
        raise ValueError("%s: not an RT Structure Set (Modality %r)" % (path, getattr(ds, "Modality", None)))
    names = {int(r.ROINumber): str(r.ROIName) for r in ds.StructureSetROISequence}
    out = {}
    for rc in ds.ROIContourSequence:
        name = names.get(int(rc.ReferencedROINumber), "ROI %d" % int(rc.ReferencedROINumber))
        planes = collections.defaultdict(list)
        for c in getattr(rc, "ContourSequence", []):
            if str(getattr(c, "ContourGeometricType", "CLOSED_PLANAR")) != "CLOSED_PLANAR":
                continue
            p = np.asarray([float(v) for v in c.ContourData], dtype=np.float64).reshape(-1, 3)
            if np.ptp(p[:, 2]) > 1e-3:
                raise ValueError("%s: ROI %r has a non-planar contour" % (path, name))
            xy = _clean(p[:, :2])
            if len(xy) >= 3:
                planes[round(float(p[0, 2]), 2)].append(xy)
        if planes:
            out[name] = dict(sorted(planes.items()))
    return out


def bbox(planes, zs=None):
    """(min x, min y, max x, max y) in mm of the polygons on planes `zs` (all if None)."""
    pts = [p for z, polys in planes.items() if zs is None or z in zs for p in polys]
    a = np.concatenate(pts)
    return a[:, 0].min(), a[:, 1].min(), a[:, 0].max(), a[:, 1].max()
