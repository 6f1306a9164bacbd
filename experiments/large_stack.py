#!/usr/bin/python3
# @file experiments/large_stack.py
# @brief The large label stack of issue 37: a synthetic 2,048 x 2,048 x 400
# label volume with 50 labels, the AAL atlas resampled (nearest neighbour).
#
#   experiments/large_stack.py OUT.nii.gz [--size 2048] [--depth 400] [--labels 50] [--every 4]
#
# AAL (181 x 217 x 181, 1 mm) is scaled by one in-plane factor (its longer
# in-plane side, 217, to SIZE pixels; the shorter one centred, padded with 0)
# and along z to DEPTH slices; its labels 1..LABELS are kept, the others set
# to 0. Every EVERY-th axial slice is the drawn input, the slices between are
# emptied (the sparse annotation the CLI reads, as experiments/batch_cases.py's
# AAL cases). Written as uint8 NIfTI, gzip-compressed, with its voxel size
# (in-plane 217 / SIZE mm, z 181 / DEPTH mm): the file is large (about
# SIZE^2 * DEPTH / EVERY bytes of non-empty slices before compression), never
# commit it; write it to a scratch folder.
import argparse
import pathlib

import nibabel as nib
import numpy as np

AAL = pathlib.Path("/usr/share/mricron/templates/aal.nii.gz")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=2048, help="in-plane size (pixels, both axes)")
    ap.add_argument("--depth", type=int, default=400, help="slices along z")
    ap.add_argument("--labels", type=int, default=50, help="AAL labels 1..N kept")
    ap.add_argument("--every", type=int, default=4, help="every N-th slice drawn, the others emptied")
    a = ap.parse_args()
    aal = nib.load(AAL)
    src = np.asarray(aal.dataobj).astype(np.uint8)
    src[src > a.labels] = 0
    nx, ny, nz = src.shape
    scale = a.size / max(nx, ny)  # one in-plane factor: square pixels
    pad_x = (a.size - round(nx * scale)) // 2
    pad_y = (a.size - round(ny * scale)) // 2
    # Nearest-neighbour source index of each output column/row/slice (-1: padding).
    def index(n_out, n_src, pad, s):
        i = np.floor((np.arange(n_out) - pad + 0.5) / s).astype(np.int64)
        i[(i < 0) | (i >= n_src)] = -1
        return i

    ix = index(a.size, nx, pad_x, scale)
    iy = index(a.size, ny, pad_y, scale)
    iz = index(a.depth, nz, 0, a.depth / nz)
    out = np.zeros((a.size, a.size, a.depth), dtype=np.uint8)
    okx, oky = ix >= 0, iy >= 0
    for k in range(0, a.depth, a.every):  # the drawn slices only
        if iz[k] < 0:
            continue
        plane = src[:, :, iz[k]][np.ix_(ix[okx], iy[oky])]
        out[np.ix_(okx, oky, [k])] = plane[:, :, None]
    zooms = (1.0 / scale, 1.0 / scale, nz / a.depth)
    affine = np.diag([zooms[0], zooms[1], zooms[2], 1.0])
    affine[:3, 3] = aal.affine[:3, 3]
    img = nib.Nifti1Image(out, affine)
    img.header.set_zooms(zooms)
    img.header.set_data_dtype(np.uint8)
    pathlib.Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    nib.save(img, a.out)
    drawn = int(np.count_nonzero(out.reshape(-1, a.depth).any(axis=0)))
    print(f"{a.out}: {out.shape}, {len(np.unique(out)) - 1} labels, {drawn} drawn slices, "
          f"voxel {zooms[0]:.4f} x {zooms[1]:.4f} x {zooms[2]:.4f} mm")


if __name__ == "__main__":
    main()
