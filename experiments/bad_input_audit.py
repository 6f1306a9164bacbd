#!/usr/bin/env python3
"""The issue-17 audit cases, run against one or two isoloft CLIs (before / after).

Each case runs in a fresh directory under `timeout` and an address-space
limit (the audit's 8 GB); recorded: exit status, wall seconds, peak RSS (MiB),
the last stderr line, and the files left in the directory that were not
there before (a half-run left behind). Writes a markdown table.

usage: bad_input_audit.py OUT.md CLI [CLI_BEFORE] [--timeout S] [--only NAME,...]
"""
import argparse
import math
import os
import shutil
import signal
import struct
import subprocess
import tempfile
import time
import zlib

MEMORY_LIMIT = 8 << 30  # the audit's limit (bytes of address space)


def polylines(size, slices, contours):
    """slices: list of z; contours(z) -> list of point lists."""
    out = ["isoloft-polylines 1", "size %d %d" % (size, size)]
    for z in slices:
        out.append("slice %r" % z)
        for c in contours(z):
            out.append("contour")
            out.extend("%r %r" % p for p in c)
    return "\n".join(out) + "\n"


def circle(cx, cy, r, n=48):
    return [(cx + r * math.cos(2 * math.pi * i / n), cy + r * math.sin(2 * math.pi * i / n)) for i in range(n)]


def circle_file(size=128, r=30, z=(0, 1), n=48):
    return polylines(size, z, lambda _z: [circle(size / 2, size / 2, r, n)])


def png(path, width, height, rows=None):
    """8-bit grey PNG; rows(y) -> bytes of the row (default black), deflated row by row."""
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
    z = zlib.compressobj(9)
    black = b"\0" * (width + 1)
    parts = [z.compress(black if rows is None else b"\0" + rows(y)) for y in range(height)]
    parts.append(z.flush())
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
                + chunk(b"IDAT", b"".join(parts)) + chunk(b"IEND", b""))


def arc_row(y, size=48, r=12):
    """Row y of a half-circle arc of radius r about the image centre (an open contour)."""
    row = bytearray(size)
    c = size // 2
    for i in range(401):
        a = math.pi * i / 400
        if round(c + r * math.sin(a)) == y:
            row[round(c + r * math.cos(a))] = 255
    return bytes(row)


def tiny_triangles(count=40, size=200):
    tris = []
    for i in range(count):
        x, y = 10 + (i % 8) * 22, 10 + (i // 8) * 22
        tris.append([(x, y), (x + 4, y), (x, y + 4)])
    return polylines(size, [0, 1], lambda _z: tris)


def sphere(d, cli):
    s = os.path.join(d, "sphere")
    subprocess.run([cli, "synth", "sphere", "--size", "64", "--z-spacing", "8", "--out", s], check=True,
                   capture_output=True)
    return s


def text(d, name, content, mode="w"):
    p = os.path.join(d, name)
    with open(p, mode) as f:
        f.write(content)
    return p


# name -> (what it was, setup(d, cli) -> extra args after "reconstruct")
def cases():
    c = {}
    c["40 tiny triangles"] = lambda d, cli: [text(d, "t.txt", tiny_triangles())]
    c["polygon 30k vertices"] = lambda d, cli: [text(d, "p.txt", circle_file(2048, 800, (0, 1), 30000))]

    def big_png(d, cli):
        os.makedirs(os.path.join(d, "big"))
        for n in "ab":
            png(os.path.join(d, "big", n + ".png"), 20000, 20000)
        return [os.path.join(d, "big")]
    c["two 20000^2 PNGs"] = big_png
    c["interp.z_step 1e-6"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"interp": {"z_step": 1e-6}}')]
    c["interp.cap_extent 1e7"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"interp": {"cap_extent": 1e7}}')]
    c["normals.sigma 1e6"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"normals": {"sigma": 1e6}}')]
    c["--z-spacing 1e5 --volume"] = lambda d, cli: [sphere(d, cli), "--z-spacing", "1e5", "--volume", os.path.join(d, "v.nrrd")]

    def white(d, cli):
        os.makedirs(os.path.join(d, "w"))
        for n in "ab":
            png(os.path.join(d, "w", n + ".png"), 1, 1, lambda y: b"\xff")
        return [os.path.join(d, "w")]
    c["1x1 white PNG"] = white
    c["tiny polygon"] = lambda d, cli: [text(d, "t.txt", polylines(64, [0, 1], lambda z: [[(30, 30), (30.4, 30), (30, 30.4)]]))]
    c["slice spacing 1e-9"] = lambda d, cli: [text(d, "t.txt", circle_file(z=(0, 1e-9)))]
    c["--z-spacing 1e-12"] = lambda d, cli: [sphere(d, cli), "--z-spacing", "1e-12"]
    c["mc.iso 1e30"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"mc": {"iso": 1e30}}')]
    c["interp.cap_depth -5"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"interp": {"cap_depth": -5}}')]
    c["mpu.n_min 4294967297"] = lambda d, cli: [sphere(d, cli), "--params", text(d, "p.json", '{"mpu": {"n_min": 4294967297}}')]
    c["--decimate-error nan"] = lambda d, cli: [sphere(d, cli), "--decimate-error", "nan"]
    c["--sign-guard nan"] = lambda d, cli: [sphere(d, cli), "--sign-guard", "nan"]
    c["--labels without labels"] = lambda d, cli: [sphere(d, cli), "--labels", "1"]

    def open_arc(d, cli):
        os.makedirs(os.path.join(d, "o"))
        for n in "abc":
            png(os.path.join(d, "o", n + ".png"), 48, 48, arc_row)
        return [os.path.join(d, "o")]
    c["open contour (arc)"] = open_arc
    c["polyline size 2^20"] = lambda d, cli: [text(d, "t.txt", circle_file(size=1 << 20))]
    c["polyline z 1e9"] = lambda d, cli: [text(d, "t.txt", circle_file(z=(0, 1e9)))]
    c["--raster-resolution 100000"] = lambda d, cli: [text(d, "t.txt", circle_file()), "--raster-resolution", "100000"]
    c["--z-spacing 1e9"] = lambda d, cli: [sphere(d, cli), "--z-spacing", "1e9"]

    def far_slices(d, cli):
        s = sphere(d, cli)
        files = sorted(os.listdir(s))
        files = [os.path.join(s, f) for f in files if f.endswith(".png")][:2]
        return files + ["--slice-z", "0,1e9"]
    c["--slice-z 0,1e9"] = far_slices
    c["zero-area polygon"] = lambda d, cli: [text(d, "t.txt", polylines(64, [0, 1], lambda z: [[(10, 10), (20, 20), (30, 30)]]))]
    c["--z-spacing nan"] = lambda d, cli: [sphere(d, cli), "--z-spacing", "nan"]
    c["CR-only line ends"] = lambda d, cli: [text(d, "t.txt", circle_file(z=(0, 1, 2)).replace("\n", "\r"))]
    c["UTF-8 BOM"] = lambda d, cli: [text(d, "t.txt", "\ufeff" + circle_file(z=(0, 1, 2)), "w")]
    return c


SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


def listing(d):
    """Files and folders (with a trailing '/') under d."""
    out = set()
    for r, ds, fs in os.walk(d):
        out |= {os.path.relpath(os.path.join(r, f), d) for f in fs}
        out |= {os.path.relpath(os.path.join(r, x), d) + "/" for x in ds}
    return out


def run_case(cli, name, setup, timeout, quiet=True, output="m.ply"):
    """setup(d, cli) -> the arguments after "reconstruct"; `output` (relative to d) is -o unless None."""
    d = tempfile.mkdtemp(prefix="audit_")
    try:
        sig = next((s for s in SIGNALS if name.startswith(s)), None)
        args = setup(d, cli)
        before = listing(d)
        out = ["-o", os.path.join(d, output)] if output else []
        cmd = ["/usr/bin/time", "-f", "%e %M", "-o", os.path.join(d, ".time"), "prlimit", "--as=%d" % MEMORY_LIMIT,
               "timeout", str(timeout), cli, "reconstruct"] + args + out + (["-q"] if quiet else [])
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, errors="replace")
        if sig:
            time.sleep(2.0)
            for child in children_named(p.pid, os.path.basename(cli)):
                os.kill(child, getattr(signal, sig))
        _, err = p.communicate()
        secs, rss = open(os.path.join(d, ".time")).read().split()[-2:]
        left = sorted(listing(d) - before - {".time"})
        lines = [l for l in err.strip().splitlines()
                 if l and not l.startswith("Command ") and not l.startswith("Run with --help")]
        msg = next((l for l in lines if "error" in l or "warning" in l), lines[0] if lines else "").replace(d + "/", "")
        code = p.returncode
        if code == 124:
            msg = "(timeout %d s) " % timeout + msg
        return {"code": code, "s": float(secs), "mib": int(rss) / 1024, "msg": msg, "left": left}
    finally:
        shutil.rmtree(d, ignore_errors=True)


def children_named(pid, name):
    """Descendant pids of pid whose command is `name`."""
    out = subprocess.run(["ps", "-e", "-o", "pid=,ppid=,comm="], capture_output=True, text=True).stdout.split("\n")
    kids, found, frontier = {}, [], [pid]
    for line in out:
        parts = line.split(None, 2)
        if len(parts) == 3:
            kids.setdefault(int(parts[1]), []).append((int(parts[0]), parts[2].strip()))
    while frontier:
        for c, comm in kids.get(frontier.pop(), []):
            frontier.append(c)
            if comm == name[:15]:
                found.append(c)
    return found


def signal_cases():
    def volume_run(d, cli):
        return [sphere(d, cli), "--z-spacing", "3000", "--volume", os.path.join(d, "v.nrrd"), "--max-memory", "0",
                "--max-output", "0"]
    return {s + " during --volume": volume_run for s in SIGNALS}


def cell(r):
    left = ("; left " + ", ".join(r["left"][:3]) + (" ..." if len(r["left"]) > 3 else "")) if r["left"] else ""
    msg = r["msg"].replace("|", "\\|")
    if len(msg) > 150:
        msg = msg[:147] + "..."
    return "%d | %.2f | %.0f | %s%s" % (r["code"], r["s"], r["mib"], msg, left)


def write_atomic(path, text):
    """The table, whole or not at all (an interrupted audit leaves the last one)."""
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def audit_arguments():
    """The audits' shared command line: the table out, the CLI, an older CLI to compare."""
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("cli")
    ap.add_argument("before", nargs="?")
    ap.add_argument("--timeout", type=int, default=60)
    ap.add_argument("--only", default="")
    return ap


def main():
    a = audit_arguments().parse_args()
    all_cases = {**cases(), **signal_cases()}
    names = [n for n in all_cases if not a.only or n in a.only.split(",")]
    rows = []
    for n in names:
        after = run_case(a.cli, n, all_cases[n], a.timeout)
        # Signal cases give the budget flags only the new CLI knows.
        setup = all_cases[n]
        if a.before and n.split()[0] in SIGNALS:
            setup = lambda d, cli, s=setup: [x for x in s(d, cli) if x not in ("--max-memory", "--max-output", "0")]
        before = run_case(a.before, n, setup, a.timeout) if a.before else None
        rows.append((n, before, after))
        print(n, "|", cell(before) if before else "", "|", cell(after), flush=True)
    head = "| case | " + ("before: exit | s | MiB | message | " if a.before else "") + "after: exit | s | MiB | message |\n"
    head += "|---" * (1 + (8 if a.before else 4)) + "|\n"
    body = "".join("| %s | %s%s |\n" % (n, (cell(b) + " | ") if b else "", cell(r)) for n, b, r in rows)
    write_atomic(a.out, head + body)


if __name__ == "__main__":
    main()
