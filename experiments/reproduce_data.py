#!/usr/bin/env python3
"""Builds the four stand-in datasets for reproducing the paper's Table 1
(Marker, Braude, Museth, Breen 2006: datasets P, J, T0, T1).

usage: /usr/bin/python3 experiments/reproduce_data.py [--out DIR] [--build BUILD_DIR]

Writes DIR/<name>/ (name = P, J, T0, T1) with the inputs and dataset.json
(sizes, z ratio, sources and licenses, the `isoloft reconstruct` runs, the
truth if any, and a CSV of every input contour in mesh coordinates: x =
column, y = row, z = slice z, all in pixel units).

  P   paper: pelvis, 34 slices, polylines rasterized and fitted at 2000x2000,
      field 500x500, z ratio 14:1.
      ours: REAL RT-STRUCT ROI "Lt Lung" (islands, up to 7 contours per
      slice), every 2nd contour plane (6 mm), 34 planes, pixel 6/14 mm, 500x500,
      fitted with --raster-resolution 2000.
  J   paper: jawbone, 48 slices of 500x500, 8:1.
      ours: analytic branching cylinders (`isoloft synth`), 48 non-empty
      contour slices of 500x500 at 8:1, with the analytic truth (shape.json).
  T0  paper: tumour (multi-label images), 9 slices of 489x483, 10:1.
      ours: REAL Whole Frog organ label map, every 7th 1.5 mm slice (10.5 mm,
      10.5:1 at 1 mm pixels), 489x483, organ labels 1..15.
  T1  paper: tumour (multi-label), 4 slices, fitted at 870x616, field 435x308, 63:1.
      ours: REAL RT-STRUCT tumour-bed structures, 4 planes 15 mm apart,
      pixel 15/63 mm, 435x308, fitted with --raster-resolution 870.

Deterministic; numpy, pydicom, matplotlib (contourpy) from Debian's python3.
"""
import argparse
import os
import shutil
import struct
import sys
import tempfile
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import isoloft_common as ic  # noqa: E402
import rtstruct  # noqa: E402

SHARED = os.path.normpath(os.path.join(ic.ROOT, "..", "shared", "data"))
RTSS = os.path.join(SHARED, "rtstruct", "rtss.dcm")
FROG = os.path.join(SHARED, "frog", "frogtissue.mhd")

SRC_RTSS = ("DICOM RT Structure Set rtss.dcm ('boost^breast', real anonymised breast radiotherapy case) "
            "as distributed with dicompyler-core; license BSD-3 (shared/data/rtstruct/LICENSE.txt)")
SRC_FROG = ("LBNL Whole Frog label map frogtissue.mhd (500x470x136, 1 x 1 x 1.5 mm) as distributed with "
            "VTK's data; license VTK BSD-3 (shared/data/frog/VTKData_Copyright.txt)")
SRC_SYNTH = "analytic shape written by `isoloft synth branching-cylinders` (no license needed; truth in shape.json)"

FROG_LABELS = {1: "blood", 2: "brain", 3: "duodenum", 4: "eye_retina", 5: "eye_white", 6: "heart", 7: "ileum",
               8: "kidney", 9: "l_intestine", 10: "liver", 11: "lung", 12: "nerve", 13: "skeleton",
               14: "spleen", 15: "stomach"}


# ---------------------------------------------------------------- helpers

def write_png_gray8(path, img):
    """8-bit grayscale PNG from a (h, w) uint8 array (filter 0, zlib level 9)."""
    img = np.ascontiguousarray(img, dtype=np.uint8)
    h, w = img.shape

    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    raw = np.concatenate([np.zeros((h, 1), np.uint8), img], axis=1).tobytes()
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(png)
    os.replace(tmp, path)


def read_png_gray8(path):
    import matplotlib.image as mpimg
    a = mpimg.imread(path)
    if a.ndim != 2:
        raise ValueError(path + ": expected a grayscale PNG")
    return np.rint(a * 255.0).astype(np.uint8) if a.dtype != np.uint8 else a


def mask_boundaries(mask):
    """Closed boundary curves (x = column, y = row, pixel units) of a boolean
    mask: the 0.5 level of the mask, padded by one background pixel so that
    regions touching the border close."""
    import contourpy
    m = np.pad(mask.astype(np.float64), 1)
    gen = contourpy.contour_generator(z=m, line_type=contourpy.LineType.Separate)
    out = []
    for c in gen.lines(0.5):
        c = np.asarray(c, dtype=np.float64) - 1.0
        if len(c) > 1 and np.all(c[0] == c[-1]):
            c = c[:-1]
        if len(c) >= 3:
            out.append(c)
    return out


def polygon_area(c):
    return abs(0.5 * float(np.sum(c[:, 0] * np.roll(c[:, 1], 1) - np.roll(c[:, 0], 1) * c[:, 1])))


def curves3(slices):
    """[(z, [xy polygons])] -> list of (k, 3) curves for write_contours_csv."""
    return [np.column_stack([c, np.full(len(c), z)]) for z, cs in slices for c in cs]


def even_picks(n, count, step):
    """`count` indices spaced `step` apart, centred in range(n)."""
    span = step * (count - 1)
    if span > n - 1:
        raise ValueError("cannot pick %d of %d planes %d apart" % (count, n, step))
    first = (n - 1 - span) // 2
    return [first + step * i for i in range(count)]


def contiguous(zs, dz):
    return bool(np.allclose(np.diff(zs), dz, atol=1e-3))


def place(planes_list, zs, px, w, h):
    """Origin (mm) that centres the union bbox of the given ROIs' polygons on
    planes zs in a w x h grid of px mm pixels, and the smallest margin (px)."""
    boxes = np.array([rtstruct.bbox(p, zs) for p in planes_list])
    x0, y0 = boxes[:, 0].min(), boxes[:, 1].min()
    x1, y1 = boxes[:, 2].max(), boxes[:, 3].max()
    ox = 0.5 * (x0 + x1) - 0.5 * (w - 1) * px
    oy = 0.5 * (y0 + y1) - 0.5 * (h - 1) * px
    margin = min((x0 - ox) / px + 0.5, (y0 - oy) / px + 0.5, w - 0.5 - (x1 - ox) / px, h - 0.5 - (y1 - oy) / px)
    return ox, oy, margin, ((x1 - x0) / px, (y1 - y0) / px)


def polyline_slices(planes, zs, ox, oy, px, z_ratio):
    """[(z_px, [polygons in px])] for planes zs; z_px = k * z_ratio exactly
    (equal to (z_mm - z_first_mm) / px for uniformly spaced planes)."""
    out = []
    for k, z in enumerate(zs):
        polys = [(p - np.array([ox, oy])) / px for p in planes.get(z, [])]
        out.append((round(k * z_ratio, 9), polys))
    return out


def mm_comment(name, source, ox, oy, z0, px):
    return ("%s\nsource: %s\n"
            "pixel units; physical: x_mm = %.6f + %.9g * x, y_mm = %.6f + %.9g * y, z_mm = %.3f + %.9g * z\n"
            "(DICOM patient coordinates; pixel size %.9g mm, kept out of 'pixel_size' so meshes are in pixel units)"
            % (name, source, ox, px, oy, px, z0, px, px))


def fresh_dir(out, name):
    d = os.path.join(out, name)
    if os.path.isdir(d):
        shutil.rmtree(d)
    os.makedirs(d)
    return d


def slug(name):
    return "".join(ch.lower() if ch.isalnum() else "_" for ch in name).strip("_")


# ---------------------------------------------------------------- P

def make_p(out, rois):
    d = fresh_dir(out, "P")
    roi = "Lt Lung"
    planes = rois[roi]
    zs = sorted(planes)
    assert contiguous(zs, 3.0), "Lt Lung planes are not 3 mm apart"
    # every 2nd plane; 34 of the 40 such planes. The odd-indexed planes 1..67
    # keep the branching base (up to 7 contours per slice, at z = -20.44 mm)
    # and drop the apex above (single contours) and the lowest plane.
    idx = list(range(1, 68, 2))
    picks = [zs[i] for i in idx]
    spacing = round(picks[1] - picks[0], 6)
    z_ratio = 14.0
    px = spacing / z_ratio
    w = h = 500
    ox, oy, margin, extent = place([planes], picks, px, w, h)
    if margin < 10:
        raise RuntimeError("P: %s does not fit a %dx%d grid at %.4f mm pixels" % (roi, w, h, px))
    sl = polyline_slices(planes, picks, ox, oy, px, z_ratio)
    path = os.path.join(d, slug(roi) + ".txt")
    ic.write_polylines(path, w, h, sl, 1.0, mm_comment("P stand-in: RT-STRUCT ROI '%s', every 2nd plane" % roi,
                                                      SRC_RTSS, ox, oy, picks[0], px))
    csv = os.path.join(d, "contours.csv")
    ic.write_contours_csv(csv, curves3(sl))
    ncont = [len(cs) for _, cs in sl]
    # 4-point diamonds of about one CT voxel (< 3 mm^2) left by the contouring
    # tool; kept (real data), but each becomes its own small closed component
    areas_mm2 = [polygon_area(c) * px * px for _, cs in sl for c in cs]
    scraps = sum(a < 3.0 for a in areas_mm2)
    meta = {
        "name": "P", "paper_name": "P (pelvis)", "kind": "real", "source": SRC_RTSS, "source_short": "RT-STRUCT, breast RT case",
        "structures": [roi], "slices": len(picks), "input_xy": [w, h], "fit_xy": [2000, 2000], "field_xy": [w, h],
        "z_ratio": z_ratio, "pixel_size_mm": px, "slice_spacing_mm": spacing,
        "slice_z_mm": picks, "slice_range_mm": [picks[0], picks[-1]],
        "source_planes": "indices %d..%d step 2 of the ROI's %d contiguous 3 mm planes (z %.2f..%.2f mm)"
                         % (idx[0], idx[-1], len(zs), zs[0], zs[-1]),
        "origin_mm": [ox, oy, picks[0]], "extent_px": [round(extent[0], 2), round(extent[1], 2)],
        "margin_px": round(margin, 2), "contours": int(sum(ncont)), "max_contours_per_slice": int(max(ncont)),
        "contours_per_slice": ncont, "scrap_contours_under_3mm2": int(scraps),
        "notes": ("Paper's P: 34 slices, fitted at 2000x2000, field 500x500, 14:1. Lt Lung has 80 planes 3 mm apart; "
                  "every 2nd plane (6 mm) gives 40, of which 34 are kept (planes above z = %.2f mm, the simple apex, "
                  "and the lowest plane are dropped), so the lung is cut open at its apex and closes with isoloft's "
                  "end cap there. Pixel 6/14 mm makes the z ratio exactly 14. BODY (474 mm wide) would not fit "
                  "500 px at this pixel size. %d of the %d contours are scraps under 3 mm^2 (4-point diamonds of "
                  "about one CT voxel from the contouring tool); they are kept, so most slices' extra 'islands' are "
                  "these and the mesh has several small extra components." % (picks[-1], scraps, sum(ncont))),
        "runs": [{"name": "P_lt_lung", "inputs": [os.path.abspath(path)], "args": ["--raster-resolution", "2000"]}],
        "truth": None, "contours_csv": os.path.abspath(csv),
    }
    ic.write_json(os.path.join(d, "dataset.json"), meta)
    return meta


# ---------------------------------------------------------------- T1

def make_t1(out, rois):
    d = fresh_dir(out, "T1")
    tb = rois["Tumor Bed"]
    zs = sorted(tb)
    assert contiguous(zs, 3.0), "Tumor Bed planes are not 3 mm apart"
    step = (len(zs) - 1) // 3
    idx = even_picks(len(zs), 4, step)
    picks = [zs[i] for i in idx]
    spacing = round(picks[1] - picks[0], 6)
    z_ratio = 63.0
    px = spacing / z_ratio
    w, h = 435, 308
    # Tumour-bed structures first, then every other ROI with a contour on a
    # picked plane, smallest first, if the union still fits with a margin.
    order = ["Tumor Bed", "Tumor Bed Block"]
    others = [n for n in rois if n not in order and any(z in rois[n] for z in picks)]
    others.sort(key=lambda n: (np.prod(np.subtract(rtstruct.bbox(rois[n], picks)[2:], rtstruct.bbox(rois[n], picks)[:2])), n))
    used, rejected = [], {}
    for n in order + others:
        trial = used + [n]
        _, _, margin, _ = place([rois[m] for m in trial], picks, px, w, h)
        if margin >= 10:
            used = trial
        else:
            x0, y0, x1, y1 = rtstruct.bbox(rois[n], picks)
            rejected[n] = "%.0f x %.0f px on the picked planes: does not fit %dx%d with the others" % (
                (x1 - x0) / px, (y1 - y0) / px, w, h)
    ox, oy, margin, extent = place([rois[m] for m in used], picks, px, w, h)
    runs, all_slices, per = [], [], {}
    for n in used:
        sl = polyline_slices(rois[n], picks, ox, oy, px, z_ratio)
        path = os.path.join(d, slug(n) + ".txt")
        ic.write_polylines(path, w, h, sl, 1.0, mm_comment("T1 stand-in: RT-STRUCT ROI '%s', 4 planes %.0f mm apart" % (n, spacing),
                                                          SRC_RTSS, ox, oy, picks[0], px))
        csv = os.path.join(d, "contours_%s.csv" % slug(n))
        ic.write_contours_csv(csv, curves3(sl))
        all_slices += sl
        per[n] = [len(cs) for _, cs in sl]
        runs.append({"name": "T1_" + slug(n), "inputs": [os.path.abspath(path)], "args": ["--raster-resolution", "870"],
                     "contours_csv": os.path.abspath(csv)})
    csv = os.path.join(d, "contours.csv")
    ic.write_contours_csv(csv, curves3(all_slices))
    meta = {
        "name": "T1", "paper_name": "T1 (tumour, multi-label)", "kind": "real", "source": SRC_RTSS, "source_short": "RT-STRUCT, breast RT case",
        "structures": used, "contours_per_slice": per, "excluded_structures": rejected,
        "slices": len(picks), "input_xy": [w, h], "fit_xy": [2 * w, 2 * h], "field_xy": [w, h],
        "z_ratio": z_ratio, "pixel_size_mm": px, "slice_spacing_mm": spacing,
        "slice_z_mm": picks, "slice_range_mm": [picks[0], picks[-1]],
        "source_planes": "Tumor Bed plane indices %s of its %d contiguous 3 mm planes (z %.2f..%.2f mm)"
                         % (idx, len(zs), zs[0], zs[-1]),
        "origin_mm": [ox, oy, picks[0]], "extent_px": [round(extent[0], 2), round(extent[1], 2)],
        "margin_px": round(margin, 2),
        "notes": ("Paper's T1: 4 slices, fitted at 870x616, field 435x308, 63:1. Four Tumor Bed planes %.0f mm apart "
                  "(every 5th 3 mm plane, centred on its %.0f mm extent); pixel %.0f/63 mm makes the z ratio exactly 63. "
                  "One polyline file per structure on the same grid and planes (a structure absent from a plane has "
                  "an empty slice there). Fitted at 2x (--raster-resolution 870 = 870x616 for the full grid)."
                  % (spacing, zs[-1] - zs[0], spacing)),
        "runs": runs, "truth": None, "contours_csv": os.path.abspath(csv),
    }
    ic.write_json(os.path.join(d, "dataset.json"), meta)
    return meta


# ---------------------------------------------------------------- J

def make_j(out):
    d = fresh_dir(out, "J")
    size, z_spacing, target, w = 396, 8.0, 48, 500
    pad = (w - size) // 2  # 52: the synth image centre (size-1)/2 = 197.5 lands on 249.5
    tmp = tempfile.mkdtemp(prefix="isoloft_repro_J_")
    try:
        ic.isoloft("synth", "branching-cylinders", "--size", size, "--z-spacing", z_spacing, "--out", os.path.join(tmp, "png"))
        ic.isoloft("synth", "branching-cylinders", "--size", size, "--z-spacing", z_spacing, "--kind", "polylines",
                   "--out", os.path.join(tmp, "poly"))
        desc = ic.read_json(os.path.join(tmp, "png", "shape.json"))
        n = int(desc["stack"]["slices"])
        imgs = [read_png_gray8(os.path.join(tmp, "png", "slice_%03d.png" % k)) for k in range(n)]
        nonempty = [k for k in range(n) if imgs[k].any()]
        # synth's first and last cuts miss the shape (its bounds include the
        # blend margin): keep the non-empty run, which must be 48 slices.
        if nonempty != list(range(nonempty[0], nonempty[-1] + 1)) or len(nonempty) != target:
            raise RuntimeError("J: synth gave %d slices, non-empty %s; expected %d non-empty" % (n, nonempty, target))
        k0 = nonempty[0]
        for i, k in enumerate(nonempty):
            write_png_gray8(os.path.join(d, "slice_%03d.png" % i), np.pad(imgs[k], ((pad, w - size - pad), (pad, w - size - pad))))
        _, _, _, poly = ic.read_polylines(os.path.join(tmp, "poly", "stack.txt"))
        shift = np.array([pad, pad], float)
        dz = k0 * z_spacing
        sl = [(z - dz, [c + shift for c in cs]) for z, cs in poly if cs]
        if len(sl) != target or abs(sl[0][0]) > 1e-9:
            raise RuntimeError("J: polyline cuts do not match the images")
        orig = ic.read_json(os.path.join(tmp, "png", "shape.json"))
        orig.pop("reconstruct_hint", None)  # names the temporary directory
        ic.write_json(os.path.join(d, "synth_shape_%d.json" % size), orig)
    finally:
        shutil.rmtree(tmp)
    # The truth, moved like the images: x, y by +pad, z by -k0 * spacing.
    shape = desc["shape"]
    for c in shape["capsules"]:
        c["a"] = [c["a"][0] + pad, c["a"][1] + pad, c["a"][2] - dz]
        c["b"] = [c["b"][0] + pad, c["b"][1] + pad, c["b"][2] - dz]
    desc["stack"].update({"size": w, "slices": target, "z_first": 0.0, "z_last": (target - 1) * z_spacing,
                          "files": "slice_000.png ..."})
    desc["reconstruct_hint"] = "isoloft reconstruct %s --z-spacing %g -o out.ply" % (d, z_spacing)
    desc["derived"] = ("`isoloft synth branching-cylinders --size %d --z-spacing %g` (%d slices; slices 0 and %d "
                       "empty), slices %d..%d kept and renumbered from 0, images zero-padded by %d px on each side "
                       "to %dx%d; shape translated by (%d, %d, %g) to match" %
                       (size, z_spacing, n, n - 1, k0, k0 + target - 1, pad, w, w, pad, pad, -dz))
    truth = os.path.join(d, "shape.json")
    ic.write_json(truth, desc)
    csv = os.path.join(d, "contours.csv")
    ic.write_contours_csv(csv, curves3(sl))
    meta = {
        "name": "J", "paper_name": "J (jawbone)", "kind": "analytic", "source": SRC_SYNTH, "source_short": "isoloft synth branching-cylinders",
        "shape": "branching-cylinders", "slices": target, "input_xy": [w, w], "fit_xy": [w, w], "field_xy": [w, w],
        "z_ratio": z_spacing, "pixel_size_mm": None,
        "synth": {"size": size, "z_spacing": z_spacing, "slices_written": n, "kept": [k0, k0 + target - 1], "pad_px": pad},
        "notes": ("Paper's J: 48 slices of 500x500, 8:1. `isoloft synth --size 500 --z-spacing 8` gives 63 slices "
                  "(the shape is ~1.0 x size tall), so the shape is synthesized at size %d (48 non-empty cuts at 8:1, "
                  "plus an empty cut at each end that is dropped) and zero-padded to 500x500; the branching "
                  "cylinders then span %d of the 500 px across. Inputs are 1-pixel contour PNGs; contours.csv holds "
                  "the exact analytic cuts (synth --kind polylines), shifted the same way." % (size, size)),
        "runs": [{"name": "J_branching", "inputs": [os.path.abspath(d)], "args": ["--z-spacing", "%g" % z_spacing]}],
        "truth": os.path.abspath(truth), "contours_csv": os.path.abspath(csv),
    }
    ic.write_json(os.path.join(d, "dataset.json"), meta)
    return meta


# ---------------------------------------------------------------- T0

def read_frog():
    return ic.read_frog(FROG)


def make_t0(out):
    d = fresh_dir(out, "T0")
    vol, spacing = read_frog()
    nz, ny, nx = vol.shape
    vol = np.where(vol <= 15, vol, 0).astype(np.uint8)  # drop the stray labels 16-29
    every, count, w, h = 7, 9, 489, 483
    # the window of 9 slices 7 apart with all organs present and the most
    # (label, slice) pairs; ties -> lowest start
    best = None
    for s in range(0, nz - every * (count - 1)):
        labs = [set(np.unique(vol[s + every * i]).tolist()) - {0} for i in range(count)]
        key = (len(set().union(*labs)), sum(len(l) for l in labs), -s)
        if best is None or key > best[0]:
            best = (key, s)
    start = best[1]
    zidx = [start + every * i for i in range(count)]
    # crop x 500 -> 489 (the frog spans columns 27..475) and pad y 470 -> 483 at the bottom
    # (the frog reaches the last row 469)
    xs = np.nonzero(vol.any(axis=(0, 1)))[0]
    x_off = (nx - w) // 2
    if xs[0] < x_off or xs[-1] >= x_off + w:
        raise RuntimeError("T0: cropping to %d columns would cut labels" % w)
    z_ratio = every * spacing[2] / spacing[0]
    sl_all, present = [], {}
    for k, z in enumerate(zidx):
        img = np.zeros((h, w), np.uint8)
        img[:ny, :] = vol[z, :, x_off:x_off + w]
        write_png_gray8(os.path.join(d, "frog_%02d.png" % k), img)
        polys = []
        for lab in sorted(set(np.unique(img).tolist()) - {0}):
            present.setdefault(lab, []).append(k)
            polys += mask_boundaries(img == lab)
        sl_all.append((k * z_ratio, polys))
    csv = os.path.join(d, "contours.csv")
    ic.write_contours_csv(csv, curves3(sl_all))
    with open(os.path.join(d, "labels.txt"), "w") as f:
        for lab in sorted(present):
            f.write("%d %s\n" % (lab, FROG_LABELS[lab]))
    meta = {
        "name": "T0", "paper_name": "T0 (tumour, multi-label images)", "kind": "real", "source": SRC_FROG, "source_short": "Whole Frog organ labels",
        "labels": {str(l): FROG_LABELS[l] for l in sorted(present)},
        "label_slices": {str(l): v for l, v in sorted(present.items())},
        "slices": count, "input_xy": [w, h], "fit_xy": [w, h], "field_xy": [w, h],
        "z_ratio": z_ratio, "pixel_size_mm": spacing[0], "slice_spacing_mm": every * spacing[2],
        "source_slices": zidx, "source_slice_range": [zidx[0], zidx[-1]],
        "crop": {"x_offset": int(x_off), "y_pad_bottom": h - ny},
        "notes": ("Paper's T0: 9 slices of 489x483, 10:1. Every 7th 1.5 mm frog slice = 10.5 mm at 1 mm pixels, "
                  "so the z ratio is 10.5:1, not 10:1. Columns %d..%d kept (489 of 500), 13 zero rows added at the "
                  "bottom (483 of 470); labels 16-29 (a few stray voxels) set to 0. Slice window: all 15 organs "
                  "present, most (label, slice) pairs. PNG gray level = label." % (x_off, x_off + w - 1)),
        "runs": [{"name": "T0_frog", "inputs": [os.path.abspath(d)],
                  "args": ["--input", "labels", "--z-spacing", "%g" % z_ratio]}],
        "truth": None, "contours_csv": os.path.abspath(csv),
    }
    ic.write_json(os.path.join(d, "dataset.json"), meta)
    return meta


# ---------------------------------------------------------------- main

def summary(m):
    what = m.get("structures") or list(m.get("labels", {}).values()) or [m.get("shape")]
    px = "%.6f mm" % m["pixel_size_mm"] if m["pixel_size_mm"] else "n/a"
    return ("%-2s %-8s %2d slices, input %dx%d, fit %dx%d, field %dx%d, z %g:1, pixel %s, %d run(s): %s"
            % (m["name"], m["kind"], m["slices"], *m["input_xy"], *m["fit_xy"], *m["field_xy"], m["z_ratio"], px,
               len(m["runs"]), ", ".join(what)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(ic.ROOT, "experiments", "out", "reproduce", "data"))
    ap.add_argument("--build", help="build directory holding isoloft (default: $ISOLOFT_BUILD or build/)")
    a = ap.parse_args()
    if a.build:
        os.environ["ISOLOFT_BUILD"] = os.path.abspath(a.build)
    out = os.path.abspath(a.out)
    os.makedirs(out, exist_ok=True)
    rois = rtstruct.read_rtstruct(RTSS)
    for make in (lambda: make_p(out, rois), lambda: make_j(out), lambda: make_t0(out), lambda: make_t1(out, rois)):
        print(summary(make()), flush=True)


if __name__ == "__main__":
    main()
