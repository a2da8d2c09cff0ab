"""Exact comparison of two run.h5 files: every group, dataset and attribute, NaN equal to NaN.

Used by the resume test (a resumed run's data must equal the uninterrupted run's, bit for bit):
    /usr/bin/python3 -m cdshear_analysis.compare A/run.h5 B/run.h5
prints the first differences and exits 1 when the files differ, 0 when they are the same.
"""
import sys

import h5py
import numpy as np


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or a.dtype.kind != b.dtype.kind:
        return False
    if a.dtype.kind == "f":
        return bool(np.array_equal(a, b, equal_nan=True))
    return bool(np.array_equal(a, b))


def differences(path_a, path_b, ignore_attrs=()):
    """Names of the objects or attributes that differ between the two files."""
    out = []
    with h5py.File(path_a, "r") as fa, h5py.File(path_b, "r") as fb:
        names_a, names_b = [], []
        fa.visit(names_a.append)
        fb.visit(names_b.append)
        for name in sorted(set(names_a) ^ set(names_b)):
            out.append(f"{name}: only in one file")
        for name in [""] + sorted(set(names_a) & set(names_b)):
            oa, ob = (fa[name], fb[name]) if name else (fa, fb)
            for key in sorted(set(oa.attrs) | set(ob.attrs)):
                if key in ignore_attrs:
                    continue
                if key not in oa.attrs or key not in ob.attrs or not _same(oa.attrs[key],
                                                                           ob.attrs[key]):
                    out.append(f"{name or '/'}@{key}")
            if isinstance(oa, h5py.Dataset) and not _same(oa[()], ob[()]):
                out.append(name)
    return out


def main(argv):
    if len(argv) != 2:
        print("usage: python3 -m cdshear_analysis.compare A.h5 B.h5", file=sys.stderr)
        return 2
    diff = differences(argv[0], argv[1], ignore_attrs=("case_toml",))
    for d in diff[:20]:
        print(f"differs: {d}")
    return 1 if diff else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
