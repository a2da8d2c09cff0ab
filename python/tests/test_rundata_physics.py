"""run.h5 files that are sealed but are not a shear run (V of 0, NaN or text, a negative height,
time running backwards, no stripes, a window of 0, a V or pressure not its case's, every physical
series NaN, arrays of the wrong rank, a dataset larger than the file, an infinite or 1e200 value,
a NaN wall force) are refused by load_run naming
the attribute or dataset, and `analyze` exits 2 with the message and no traceback: no regime is ever
given to them."""
import contextlib
import io
import os
import shutil
import tempfile
import unittest

import h5py
import numpy as np

from cdshear_analysis import RunDataError, load_run
from cdshear_analysis.__main__ import main
from cdshear_analysis.rundata import seal, truncate_run
from cdshear_analysis.synthetic import write_synthetic_run


def set_attr(name, value, group="/"):
    def damage(f):
        f[group].attrs[name] = value
    return damage


def replace(dataset, make):
    def damage(f):
        old = f[dataset][()]
        del f[dataset]
        f[dataset] = make(old)
    return damage


def delete(dataset):
    def damage(f):
        del f[dataset]
    return damage


def set_group_attr(parent, name, value):
    """The attribute `name` of the first group under `parent` (a region: h5, h10...)."""
    def damage(f):
        f[parent][next(iter(f[parent]))].attrs[name] = value
    return damage


def at(values, row, value):
    """A copy of `values` (float) with row `row` set to `value` (every column of that row)."""
    values = np.array(values, dtype=float)
    values[row] = value
    return values


def replace_in_region(name, make):
    """replace() for the dataset `name` of the first region under /windows/regions."""
    def damage(f):
        region = next(iter(f["windows/regions"]))
        replace(f"windows/regions/{region}/{name}", make)(f)
    return damage


def backwards(t):
    t = np.array(t, dtype=float)
    t[5] = t[3]
    return t


def all_nan_series(f):
    for k in ("com_vx", "height", "solid_fraction", "bottom_fx", "bottom_fy", "top_fx", "top_fy"):
        data = f[f"series/{k}"][()]
        del f[f"series/{k}"]
        f[f"series/{k}"] = np.full_like(np.asarray(data, dtype=float), np.nan)


def snapshot_as_dataset(f):
    del f["snapshot"]
    f["snapshot"] = 1.0


def huge_series(f):
    """A dataset whose dataspace claims 8 TB (nothing written: the file stays small), as damaged
    dimensions in the metadata do."""
    del f["series/com_vx"]
    f.create_dataset("series/com_vx", shape=(10**12,), dtype="f8")


CASES = [
    ("V = 0", set_attr("velocity", 0.0), "attribute velocity is 0.0: it must be > 0"),
    ("V = NaN", set_attr("velocity", np.nan), "attribute velocity is nan, not a finite number"),
    ("n = 'abc'", set_attr("n", "abc"), "attribute n is 'abc', not a finite number"),
    ("n = 2.5", set_attr("n", 2.5), "a number of disks is whole"),
    ("negative height", set_attr("height", -20.0), "attribute height is -20.0: it must be > 0"),
    ("window 0", set_attr("window", 0.0), "attribute window is 0.0: it must be > 0"),
    ("time backwards", replace("series/time", backwards),
     "/series/time does not increase at row 5"),
    ("no stripes", replace("windows/y", lambda y: np.zeros(0)), "/windows/"),
    ("all NaN", all_nan_series, "every physical series"),
    ("3-D vx", replace("windows/vx", lambda v: np.asarray(v)[..., None]),
     "/windows/vx has shape"),
    ("2-D series", replace("series/com_vx", lambda v: np.stack([v, v], axis=1)),
     "/series/com_vx"),
    ("8 TB series", huge_series, "/series/com_vx claims 8000000000000 bytes"),
    # datasets outside the required lists, read by analyze, plot or stress-balance
    ("text height", replace("windows/height", lambda v: np.full(np.shape(v), b"x", "S1")),
     "/windows/height holds values of type |S1, not numbers"),
    ("no carrying Z", delete("windows/force_carrying_coordination"),
     "missing dataset(s) /windows/force_carrying_coordination"),
    ("flat stress", replace("windows/stress", lambda v: np.asarray(v)[..., 0, 0]),
     "/windows/stress has shape"),
    ("flat kinetic stress", replace("windows/kinetic_stress", lambda v: np.asarray(v)[..., 0]),
     "/windows/kinetic_stress has shape"),
    ("layer h -1", set_group_attr("windows/regions", "h", -1.0),
     "a layer's thickness must be > 0"),
    ("layer h text", set_group_attr("windows/regions", "h", "abc"), "('abc') is not a number"),
    ("no radius", delete("snapshot/radius"), "missing dataset(s) /snapshot/radius"),
    ("short x", replace("snapshot/x", lambda v: v[:-1]), "must be lists of one length"),
    ("snapshot no group", snapshot_as_dataset, "/snapshot is not a group"),
    ("snapshot L_x 0", set_attr("length_x", 0.0, "snapshot"),
     "/snapshot length_x is 0.0: it must be a finite number > 0"),
    ("snapshot height text", set_attr("height", "abc", "snapshot"),
     "/snapshot height is 'abc'"),
    ("snapshot time pair", set_attr("time", [1.0, 2.0], "snapshot"),
     "/snapshot time is an array of shape (2,)"),
    ("snapshot time NaN", set_attr("time", np.nan, "snapshot"),
     "/snapshot time is nan"),
    ("snapshot time < 0", set_attr("time", -1.0, "snapshot"),
     "/snapshot time is -1.0: it must be a finite number >= 0"),
    # an attribute changed by hand, not its case: a V of 5e-324 stopped the regime's smoothing
    ("V not the case's", set_attr("velocity", 5e-324),
     "attribute velocity is 5e-324, but its case_toml has shear.velocity = "),
    ("pressure not the case's", set_attr("normal_stress", 2.5),
     "attribute normal_stress is 2.5, but its case_toml has shear.normal_stress = "),
    # values no run measures, which would print a 300-digit mu_eff or overflow a squared sum
    ("1e300 wall force", replace("series/bottom_fx", lambda v: at(v, 7, 1e300)),
     "/series/bottom_fx holds 1e+300 at row 7"),
    ("infinite window force", replace("windows/bottom_force", lambda v: at(v, 2, np.inf)),
     "/windows/bottom_force holds inf at row 2"),
    ("1e200 stripe stress", replace("windows/stress", lambda v: at(v, 3, -1e200)),
     "/windows/stress holds -1e+200 at row 3"),
    ("1e200 layer value", replace_in_region("bulk_mu_eff", lambda v: at(v, 1, 1e200)),
     "bulk_mu_eff holds 1e+200 at row 1"),
    # the walls' forces are never NaN: a NaN there is not an empty stripe to skip
    ("NaN fy sample", replace("series/top_fy", lambda v: at(v, 4, np.nan)),
     "/series/top_fy is NaN at row 4"),
    ("NaN window force", replace("windows/top_force", lambda v: at(v, 4, np.nan)),
     "/windows/top_force is NaN at row 4"),
    # the two clocks: a dt or a step that is not the run's moved every time unseen
    ("dt ten times", lambda f: f.attrs.modify("dt", 10 * float(f.attrs["dt"])),
     "/series/step x attribute dt"),
    ("a step back", replace("series/step", lambda v: at(v, 5, v[4] - 1)),
     "where /series/time holds"),
]


class NotPhysics(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.good = os.path.join(cls.tmp.name, "good")
        write_synthetic_run(cls.good, kind="A", duration=400.0)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_untouched_run_reads(self):
        self.assertGreater(len(load_run(self.good)["series"]["time"]), 10)

    def test_each_damage_is_refused_naming_what(self):
        for name, damage, words in CASES:
            with self.subTest(name):
                d = os.path.join(self.tmp.name, name.replace(" ", "_").replace("'", ""))
                shutil.copytree(self.good, d)
                path = os.path.join(d, "run.h5")
                with h5py.File(path, "r+") as f:
                    damage(f)
                seal(path)
                with self.assertRaises(RunDataError) as e:
                    load_run(d)
                self.assertIn(words, e.exception.problem)
                out, err = io.StringIO(), io.StringIO()
                with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                    rc = main(["analyze", d])
                self.assertEqual(rc, 2, err.getvalue())
                self.assertIn(f"error: {path}", err.getvalue())
                self.assertNotIn("Traceback", err.getvalue())
                self.assertFalse(os.path.exists(os.path.join(d, "summary.json")))

    def test_a_sample_on_a_window_edge_falls_in_its_window(self):
        """A file whose series time is summed step by step (drifting from step x dt, as cdshear
        wrote it before) reads with time = step x dt: each window then holds the same number of
        samples, the one on its end included, as the windows' t_start and t_end count them."""
        d = os.path.join(self.tmp.name, "drifted")
        shutil.copytree(self.good, d)
        path = os.path.join(d, "run.h5")
        with h5py.File(path, "r+") as f:
            dt, step = float(f.attrs["dt"]), f["series/step"][()]
            drifted = np.concatenate(([0.0], np.cumsum(np.full(int(step[-1]), dt))))[step]
            replace("series/time", lambda t: drifted)(f)
        seal(path)
        run = load_run(d)
        t, w = run["series"]["time"], run["windows"]
        np.testing.assert_array_equal(t, run["series"]["step"] * dt)
        counts = {int(((t > a) & (t <= b)).sum()) for a, b in zip(w["t_start"], w["t_end"])}
        self.assertEqual(len(counts), 1, counts)
        # the drift itself would have moved samples between windows: the test sees the edge
        off = {int(((drifted > a) & (drifted <= b)).sum())
               for a, b in zip(w["t_start"], w["t_end"])}
        self.assertGreater(len(off), 1, "no sample sits on a window edge: the test checks nothing")

    def test_truncation_takes_a_positive_time_only(self):
        run = load_run(self.good)
        kept = truncate_run(run, 200.0)
        self.assertLessEqual(kept["series"]["time"][-1], 200.0)
        self.assertLess(len(kept["series"]["time"]), len(run["series"]["time"]))
        for bad in (True, 0, -1.0, float("nan"), "200"):
            with self.subTest(time=bad), self.assertRaisesRegex(ValueError, "a number > 0"):
                truncate_run(run, bad)


if __name__ == "__main__":
    unittest.main()
