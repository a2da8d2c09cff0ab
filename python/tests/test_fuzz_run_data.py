"""A structure-aware generator of damaged run.h5 files for the analysis side (which libFuzzer does
not reach): from a sealed synthetic run, each case deletes, retypes, reshapes or fills with
non-numbers one to three of its attributes and datasets, reseals the file so that the seal lets it
through, and runs `analyze` on it. Whatever the damage, `analyze` either analyses the run (exit 0,
a summary.json that is JSON) or refuses it with "error: FILE..." and exit 2: never a traceback,
another exit status or an exception out of main. The cases are drawn from a fixed seed, so a
failure names a case that reproduces."""
import contextlib
import io
import json
import os
import shutil
import tempfile
import unittest

import h5py
import numpy as np

from cdshear_analysis.__main__ import main
from cdshear_analysis.rundata import seal
from cdshear_analysis.synthetic import write_synthetic_run

CASES = 100  # damaged files per run of the suite (about 0.3 s each)


def _objects(f):
    """Every attribute (as (object name, attribute name)) and dataset of the file."""
    attributes = [("/", name) for name in f.attrs]
    datasets = []

    def visit(name, obj):
        for a in obj.attrs:
            attributes.append((name, a))
        if isinstance(obj, h5py.Dataset):
            datasets.append(name)
    f.visititems(visit)
    return sorted(attributes), sorted(datasets)


def _damaged_value(rng, value):
    """Something that `value` must not be: text, NaN, infinity, a negative, zero, an empty array,
    an extra axis, half its length, booleans, an enormous number."""
    a = np.asarray(value)
    kind = rng.integers(11)
    if kind == 0:
        return "text"
    if kind == 1:
        return np.full(a.shape, np.nan)
    if kind == 2:
        return np.full(a.shape, np.inf)
    if kind == 3:
        return -np.abs(a.astype(float)) - 1.0 if a.dtype.kind in "biuf" else -1.0
    if kind == 4:
        return np.zeros(a.shape)
    if kind == 5:
        return np.zeros(0)
    if kind == 6:
        return a[..., None] if a.ndim else np.array([[1.0]])
    if kind == 7:
        return a[: max(1, len(a) // 2)] if a.ndim else np.array([1.0, 2.0])
    if kind == 8:
        return np.ones(a.shape, dtype=bool)
    if kind == 9:
        return np.full(a.shape, 1e308)
    return np.array([b"x", b"y"])


def damage(path, rng):
    """Applies one to three damages to the run.h5 at `path`; returns what was done."""
    done = []
    with h5py.File(path, "r+") as f:
        attributes, datasets = _objects(f)
        for _ in range(rng.integers(1, 4)):
            if rng.random() < 0.4 and attributes:
                owner, name = attributes[rng.integers(len(attributes))]
                obj = f[owner]
                if name not in obj.attrs:
                    continue
                if rng.random() < 0.2:
                    del obj.attrs[name]
                    done.append(f"deleted attribute {owner}:{name}")
                else:
                    obj.attrs[name] = _damaged_value(rng, obj.attrs[name])
                    done.append(f"attribute {owner}:{name} damaged")
            elif datasets:
                name = datasets[rng.integers(len(datasets))]
                if name not in f:
                    continue
                old = f[name][()]
                del f[name]
                if rng.random() < 0.2:
                    done.append(f"deleted dataset {name}")
                else:
                    f[name] = _damaged_value(rng, old)
                    done.append(f"dataset {name} damaged")
    seal(path)
    return done


class DamagedRunData(unittest.TestCase):
    def test_analyze_exits_0_or_2_with_a_message_on_every_damaged_file(self):
        rng = np.random.default_rng(20261128)
        with tempfile.TemporaryDirectory() as tmp:
            good = os.path.join(tmp, "good")
            write_synthetic_run(good, kind="A", duration=400.0)
            outcomes = {0: 0, 2: 0}
            for case in range(CASES):
                d = os.path.join(tmp, f"case{case}")
                shutil.copytree(good, d)
                path = os.path.join(d, "run.h5")
                done = damage(path, rng)
                out, err = io.StringIO(), io.StringIO()
                with self.subTest(case=case, damages=done):
                    try:
                        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                            rc = main(["analyze", d])
                    except BaseException as e:  # noqa: B902 - anything that escapes is the bug
                        self.fail(f"{type(e).__name__} escaped main: {e}")
                    self.assertIn(rc, (0, 2), err.getvalue())
                    self.assertNotIn("Traceback", err.getvalue())
                    outcomes[rc] += 1
                    if rc == 2:
                        self.assertIn("error: ", err.getvalue())
                        self.assertFalse(os.path.exists(os.path.join(d, "summary.json")))
                    else:
                        with open(os.path.join(d, "summary.json"), encoding="utf-8") as f:
                            json.load(f)
                shutil.rmtree(d)
            # The generator must reach both outcomes, or it tests nothing of interest.
            self.assertGreater(outcomes[2], 0)
            self.assertGreater(outcomes[0], 0)


if __name__ == "__main__":
    unittest.main()
