#!/usr/bin/python3
"""A cohort of 8 real cases for `isoloft batch` against a one-by-one loop
(issue 26): the bundled frog labels (PNG) and three organs of the frog
MetaImage, the RT-STRUCT's Heart and Breast (or Lt Lung: --lung), and the
116 AAL structures from every 4th axial slice in four cases. Writes DIR/cases.csv (the manifest) and DIR/loop.sh (the same
commands one after the other, --threads 1, as the batch runs them), so that

    farm-bench -n 3 --timeout 1800 --vs 'sh DIR/loop.sh' -- \\
        build/isoloft batch DIR/cases.csv --out DIR/out --workers 2 --force -q

times the two (the mesh bytes of DIR/out and DIR/loop match: loop.sh ends
with that check).

    /usr/bin/python3 experiments/batch_cases.py DIR [--cli build/isoloft] [--shared ../shared/data] [--lung]
"""

import argparse
import csv
import pathlib
import shlex

import nibabel as nib
import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
AAL = pathlib.Path("/usr/share/mricron/templates/aal.nii.gz")
AAL_EVERY = 4  # every 4th axial slice kept, the others emptied (sparse annotation)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--cli", default=str(ROOT / "build" / "isoloft"))
    ap.add_argument("--shared", default=str(ROOT.parent / "shared" / "data"))
    ap.add_argument("--lung", action="store_true", help="the RT-STRUCT's Lt Lung instead of its Breast")
    a = ap.parse_args()
    d = pathlib.Path(a.dir).resolve()
    d.mkdir(parents=True, exist_ok=True)
    shared = pathlib.Path(a.shared).resolve()
    aal = nib.load(AAL)
    labels = np.asarray(aal.dataobj).copy()
    labels[:, :, np.arange(labels.shape[2]) % AAL_EVERY != 0] = 0
    sparse = d / "aal_every4.nii.gz"
    nib.save(nib.Nifti1Image(labels, aal.affine), sparse)
    rtss = ROOT / "data" / "rtstruct" / "rtss.dcm"
    aal_groups = [",".join(map(str, range(lo, lo + 29))) for lo in (1, 30, 59, 88)]  # 116 labels in 4 cases
    # Cases of 1.1-2.5 s of CPU each, as a cohort of similar cases is; the largest first (tasks start in
    # manifest order). With the RT-STRUCT's Lt Lung (5.5 s) in place of its Breast one case would be 30 %
    # of the work: docs/decisions.md (cohorts) has both.
    cases = [
        ("rtss_lt_lung", rtss, "--roi 'Lt Lung'") if a.lung else ("rtss_breast", rtss, "--roi Breast"),
        ("frog_png", ROOT / "data" / "frog", "--input labels --z-spacing 6"),
        ("frog_mha_organs", shared / "frog" / "frogtissue.mhd", "--axis k --labels 2,3,4"),
        ("rtss_heart", rtss, "--roi Heart"),
    ] + [(f"aal_{i + 1}", sparse, f"--labels {g}") for i, g in enumerate(aal_groups)]
    with open(d / "cases.csv", "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["input", "name", "options"])
        for name, src, options in cases:
            w.writerow([str(src), name, options])
    lines = ["set -e", f"rm -rf {d}/loop", f"mkdir -p {d}/loop"]
    for name, src, options in cases:
        lines.append(f"mkdir -p {d}/loop/{name} && cd {d}/loop/{name} && {shlex.quote(str(pathlib.Path(a.cli).absolute()))} reconstruct "
                     f"{shlex.quote(str(src))} {options} -o {name}.ply --report {name}.json --threads 1 -q")
    lines.append(f"cd {d} && for f in $(cd loop && find . -name '*.ply'); do cmp -s loop/$f out/$f || "
                 "{ echo \"differs: $f\" >&2; exit 1; }; done")
    (d / "loop.sh").write_text("\n".join(lines) + "\n")
    print(d / "cases.csv", d / "loop.sh")


if __name__ == "__main__":
    main()
