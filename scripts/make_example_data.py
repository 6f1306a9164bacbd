#!/usr/bin/env python3
"""Regenerates data/frog/: the bundled example (a sparse label stack).

Source: ../shared/data/frog/frogtissue.mhd (LBNL Whole Frog, via VTK's data,
BSD-3, license in data/frog/VTKData_Copyright.txt). 500x470x136 labels,
spacing 1 x 1 x 1.5 mm. We keep every 4th slice (6 mm apart, a 6:1 ratio in
pixel units) and the organ labels listed below, as 8-bit gray PNGs whose gray
level is the label. Standard library only (zlib + a minimal PNG writer).
"""
import os, struct, sys, zlib

KEEP = {2: "brain", 4: "eye_retina", 5: "eye_white", 6: "heart", 8: "kidney",
        10: "liver", 11: "lung", 14: "spleen", 15: "stomach"}
EVERY = 4


def write_png(path, w, h, rows):
    def chunk(tag, data):
        c = struct.pack(">I", len(data)) + tag + data
        return c + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(png)


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "..", "shared", "data", "frog")
    out = os.path.join(root, "data", "frog")
    hdr = dict(l.split(" = ", 1) for l in open(os.path.join(src, "frogtissue.mhd")).read().splitlines() if " = " in l)
    nx, ny, nz = map(int, hdr["DimSize"].split())
    vol = zlib.decompress(open(os.path.join(src, hdr["ElementDataFile"]), "rb").read())
    assert len(vol) == nx * ny * nz, "unexpected volume size"
    os.makedirs(out, exist_ok=True)
    for f in os.listdir(out):
        if f.endswith(".png"):
            os.remove(os.path.join(out, f))
    k = 0
    for z in range(0, nz, EVERY):
        plane = vol[z * nx * ny:(z + 1) * nx * ny]
        rows = [[v if v in KEEP else 0 for v in plane[y * nx:(y + 1) * nx]] for y in range(ny)]
        write_png(os.path.join(out, "frog_%03d.png" % k), nx, ny, rows)
        k += 1
    with open(os.path.join(out, "labels.txt"), "w") as f:
        for v, name in sorted(KEEP.items()):
            f.write("%d %s\n" % (v, name))
    print("wrote %d slices to %s" % (k, out))


if __name__ == "__main__":
    main()
