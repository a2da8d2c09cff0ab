"""The LAMMPS peer's Python half (cdshear_analysis/peers.py): packing -> data file (counts, box,
diameters, masses, wall rows), overlaps of a snapshot, the common second-half estimator, a
LAMMPS run's bulk solid fraction from exact circular segments and its pairing with a campaign's
runs. No LAMMPS needed."""
import contextlib
import io
import json
import math
import os
import subprocess
import stat
import sys
import tempfile
import unittest
import warnings
from unittest import mock

import numpy as np

from cdshear_analysis.__main__ import main as cli_main
from cdshear_analysis.campaign import Campaign, compare_campaigns, paired_differences
from cdshear_analysis.peers import (PeerError, lammps_campaign, lammps_series,
                                    max_overlap, packing_to_lammps, ripple, second_half_estimates,
                                    bulk_stripes, segment_area, stripe_solid_fraction,
                                    wall_lines,
                                    write_lammps_packing)
from cdshear_analysis.rundata import load_run
from cdshear_analysis.synthetic import write_synthetic_run

PYTHON_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

PACKING = {"format": "cdshear-packing", "version": 1, "n": 3, "length_x": 5.0, "height": 4.0,
           "diameter_min": 0.8, "diameter_max": 1.0,
           # the first centre lies just left of x = 0: it must be wrapped into [0, L_x)
           "disks_xyr": [[-0.01, 0.45, 0.45], [2.0, 1.5, 0.5], [4.0, 3.6, 0.4]]}


def parse_data(text):
    """(header counts and box, atoms as rows [id, type, diameter, density, x, y, z])."""
    lines = text.split("\n")
    head = {}
    for line in lines:
        parts = line.split()
        if line.endswith(" atoms"):
            head["atoms"] = int(parts[0])
        elif line.endswith(" atom types"):
            head["types"] = int(parts[0])
        elif line.endswith("xlo xhi"):
            head["x"] = (float(parts[0]), float(parts[1]))
        elif line.endswith("ylo yhi"):
            head["y"] = (float(parts[0]), float(parts[1]))
        elif line.endswith("zlo zhi"):
            head["z"] = (float(parts[0]), float(parts[1]))
    start = lines.index("Atoms # sphere") + 2
    atoms = np.array([l.split() for l in lines[start:] if l.strip()], dtype=float)
    return head, atoms


class PackingToLammps(unittest.TestCase):
    def setUp(self):
        self.text, self.vars = packing_to_lammps(PACKING)
        self.head, self.atoms = parse_data(self.text)

    def test_counts_and_box(self):
        n_wall = math.ceil(5.0 / 0.05)
        self.assertEqual(self.vars["n_wall"], n_wall)
        self.assertEqual(self.head["atoms"], 3 + 2 * n_wall)
        self.assertEqual(len(self.atoms), 3 + 2 * n_wall)
        self.assertEqual(self.head["types"], 3)
        self.assertEqual(self.head["x"], (0.0, 5.0))
        self.assertEqual(self.head["z"], (-0.5, 0.5))
        ylo, yhi = self.head["y"]
        self.assertLess(ylo, -1.0)          # below the bottom wall's disks (centres at -0.5)
        self.assertGreater(yhi, 5.0)        # above the top ones (centres at 4.5)
        self.assertEqual(list(self.atoms[:, 0]), list(range(1, len(self.atoms) + 1)))
        self.assertTrue(np.all((self.atoms[:, 4] >= 0.0) & (self.atoms[:, 4] < 5.0)))

    def test_grains_diameters_and_masses(self):
        grains = self.atoms[self.atoms[:, 1] == 1]
        xyr = np.array(PACKING["disks_xyr"])
        self.assertEqual(len(grains), 3)
        np.testing.assert_allclose(grains[:, 2], 2 * xyr[:, 2], rtol=0, atol=0)
        np.testing.assert_allclose(grains[:, 5], xyr[:, 1], rtol=0, atol=0)
        self.assertAlmostEqual(grains[0, 4], 5.0 - 0.01, places=12)
        # LAMMPS: m = density * 4/3 pi r^3; model.md section 1: m = pi r^2 (2D density 1)
        mass = grains[:, 3] * 4.0 / 3.0 * math.pi * (grains[:, 2] / 2) ** 3
        np.testing.assert_allclose(mass, math.pi * xyr[:, 2] ** 2, rtol=1e-12)
        self.assertAlmostEqual(self.vars["grain_area"], float(np.sum(math.pi * xyr[:, 2] ** 2)),
                               places=12)
        self.assertAlmostEqual(self.vars["grain_mass_min"], math.pi * 0.4 ** 2, places=12)

    def test_walls_rows_of_mass_50_with_tops_on_the_wall_lines(self):
        for kind, top_line, sign in ((2, 0.0, +1), (3, 4.0, -1)):
            wall = self.atoms[self.atoms[:, 1] == kind]
            self.assertEqual(len(wall), self.vars["n_wall"])
            radius = wall[:, 2] / 2
            np.testing.assert_allclose(radius, 0.5)
            np.testing.assert_allclose(wall[:, 5] + sign * radius, top_line, atol=1e-12)
            mass = wall[:, 3] * 4.0 / 3.0 * math.pi * radius ** 3
            self.assertAlmostEqual(float(mass.sum()), 50.0, places=9)
            gaps = np.diff(np.sort(wall[:, 4]))
            np.testing.assert_allclose(gaps, 5.0 / len(wall), rtol=1e-9)
            self.assertLessEqual(gaps.max(), 0.05 + 1e-12)

    def test_ripple(self):
        # s^2 / (8 (r + R)) to leading order
        self.assertAlmostEqual(ripple(0.5, 0.05, 0.4), 0.05 ** 2 / (8 * 0.9), delta=1e-7)

    def test_write_files_and_command_line(self):
        with tempfile.TemporaryDirectory() as tmp:
            packing = os.path.join(tmp, "p.json")
            with open(packing, "w") as f:
                json.dump(PACKING, f)
            data = os.path.join(tmp, "p.data")
            variables = write_lammps_packing(packing, data)
            with open(data) as f:
                self.assertEqual(f.read(), self.text)
            with open(data + ".vars") as f:
                lines = [l.split() for l in f if l.startswith("variable")]
            self.assertEqual({l[1] for l in lines}, set(variables))
            self.assertTrue(all(l[2] == "equal" for l in lines))
            out = subprocess.run([sys.executable, "-m", "cdshear_analysis", "lammps-data",
                                  packing, "-o", os.path.join(tmp, "q.data")],
                                 cwd=PYTHON_DIR, capture_output=True, text=True)
            self.assertEqual(out.returncode, 0, out.stderr)
            self.assertIn("3 grains", out.stdout)
            bad = os.path.join(tmp, "bad.json")
            with open(bad, "w") as f:
                json.dump({"format": "something else"}, f)
            with self.assertRaises(PeerError):
                write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            out = subprocess.run([sys.executable, "-m", "cdshear_analysis", "lammps-data",
                                  bad, "-o", os.path.join(tmp, "b.data")],
                                 cwd=PYTHON_DIR, capture_output=True, text=True)
            self.assertEqual(out.returncode, 2)
            self.assertIn("not a cdshear packing", out.stderr)
            # Nested too deeply, or numbers that are not finite: refused, never written out.
            with open(bad, "w") as f:
                f.write("[" * 100000 + "]" * 100000)
            with self.assertRaisesRegex(PeerError, "nested too deeply"):
                write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            for key, value in (("length_x", float("nan")), ("height", float("inf"))):
                with open(bad, "w") as f:
                    json.dump(dict(PACKING, **{key: value}), f)
                with self.assertRaisesRegex(PeerError, "must be finite"):
                    write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            with open(bad, "w") as f:
                json.dump(dict(PACKING, disks_xyr=[[float("nan"), 1.0, 0.5]]), f)
            with self.assertRaisesRegex(PeerError, "must be finite"):
                write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            # Numbers as strings or booleans, a disk of two numbers, a key given twice: refused
            # by name, as `cdshear` refuses them (json would convert or keep the last).
            for changed, problem in ((dict(height="10"), "height must be a number"),
                                     (dict(length_x=True), "length_x must be a number"),
                                     (dict(disks_xyr=[[1.0, 2.0, 0.5], [1.0, "2", 0.5]]),
                                      r"disks_xyr\[1\] must be \[x, y, r\]"),
                                     (dict(disks_xyr=[[1.0, 2.0]]), r"disks_xyr\[0\]"),
                                     (dict(disks_xyr={"x": 1}), "non-empty list"),
                                     # what cdshear's read_packing refuses of the geometry
                                     (dict(length_x=1e308), "the disks fill 0 of"),
                                     (dict(n=-1), "n is -1, but disks_xyr lists 3"),
                                     (dict(diameter_min=0), "diameter_min and diameter_max"),
                                     (dict(diameter_max=0.85), r"disks_xyr\[0\]: diameter 0.9"),
                                     (dict(disks_xyr=[[1.0, 3.9, 0.5]], n=1),
                                      r"disks_xyr\[0\] crosses a wall"),
                                     (dict(disks_xyr=[[1e20, 0.45, 0.45]], n=1),
                                      r"disks_xyr\[0\]: x = 1e\+20 is more than a million "
                                      r"periods"),
                                     (dict(extra=1), "extra: unknown key"),
                                     (dict(length_x=2.9, disks_xyr=[[1.0, 1.5, 0.5]], n=1),
                                      "length_x 2.9 is shorter than 3 largest diameters"),
                                     (dict(version=2), "version is 2; cdshear reads version 1"),
                                     (dict(n=3.0), "n must be a whole number, not 3.0"),
                                     (dict(solid_fraction=0.5), "solid_fraction is 0.5, but the "
                                                                "disks fill 0.0962"),
                                     # disk 3 overlaps disk 0 across the period only
                                     (dict(disks_xyr=PACKING["disks_xyr"] + [[4.6, 0.45, 0.45]],
                                           n=4),
                                      r"disks_xyr\[0\] and disks_xyr\[3\] overlap by 0.51 ")):
                with open(bad, "w") as f:
                    json.dump(dict(PACKING, **changed), f)
                with self.assertRaisesRegex(PeerError, problem):
                    write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            # An integer past 64 bits is a double, as cdshear reads it: 1e400's digits are
            # infinite, not an OverflowError.
            with open(bad, "w") as f:
                f.write(json.dumps(dict(PACKING, length_x=5)).replace('"length_x": 5',
                                                                      '"length_x": 1' + "0" * 400))
            with self.assertRaisesRegex(PeerError, "must be finite"):
                write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            with open(bad, "w") as f:
                f.write(json.dumps(PACKING)[:-1] + ', "height": 99}')
            with self.assertRaisesRegex(PeerError, "'height' is given twice"):
                write_lammps_packing(bad, os.path.join(tmp, "b.data"))
            self.assertFalse(os.path.exists(os.path.join(tmp, "b.data")))
            # An output that would replace the packing read, or a run's own file: refused.
            run = os.path.join(tmp, "run")
            write_synthetic_run(run, kind="A", duration=100.0)
            with open(packing, "rb") as f:
                packing_bytes = f.read()
            fifo = os.path.join(tmp, "fifo")
            os.mkfifo(fifo)   # the rename would replace it (as root, /dev/null)
            for target, problem in ((packing, "is one of the command's inputs"),
                                    (os.path.join(run, "run.h5"), "is a run's own file"),
                                    (tmp, "is a folder"),
                                    (fifo, "is a FIFO, not a file"),
                                    (os.path.join(packing, "x.data"),
                                     f"its folder {os.path.realpath(packing)} is a file, not a "
                                     f"folder")):
                out = subprocess.run([sys.executable, "-m", "cdshear_analysis", "lammps-data",
                                      packing, "-o", target],
                                     cwd=PYTHON_DIR, capture_output=True, text=True)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertTrue(out.stderr.startswith(f"error: {target}: -o: {problem}"),
                                out.stderr)
            with open(packing, "rb") as f:
                self.assertEqual(f.read(), packing_bytes)
            self.assertTrue(stat.S_ISFIFO(os.lstat(fifo).st_mode))
            load_run(run)   # still a sealed run


class SideBySideInput(unittest.TestCase):
    def side_by_side(self, run, lammps, *extra, duration="100"):
        return subprocess.run([sys.executable, "-m", "cdshear_analysis", "side-by-side",
                               "--cdshear-run", run, "--lammps-dir", lammps, "--duration",
                               duration, "--cdshear-seconds", "1", "--lammps-seconds", "2",
                               *extra], cwd=PYTHON_DIR, capture_output=True, text=True,
                              timeout=60)

    def test_bad_options_and_files_are_refused_by_name(self):
        with tempfile.TemporaryDirectory() as tmp:
            run, lammps = os.path.join(tmp, "run"), os.path.join(tmp, "lammps")
            write_synthetic_run(run, kind="A", duration=100.0)
            os.mkdir(lammps)
            series = os.path.join(lammps, "series.txt")
            np.savetxt(series, np.column_stack([np.arange(400), np.arange(400) * 0.25]
                                                + [np.ones(400)] * 7))
            self.assertEqual(self.side_by_side(run, lammps).returncode, 0)
            for duration in ("0", "-2", "nan"):
                out = self.side_by_side(run, lammps, duration=duration)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn("error: --duration: must be a number > 0", out.stderr)
            summary = os.path.join(run, "run.h5")
            for target, problem in ((summary, "is a file of the input folder"),
                                    (os.path.join(tmp, "none", "x.json"), "does not exist")):
                out = self.side_by_side(run, lammps, "--json", target)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn(f"error: {target}: --json: ", out.stderr)
                self.assertIn(problem, out.stderr)
            load_run(run)
            # A LAMMPS series without normal force, with NaN, or with time running back; a
            # duration longer than the runs: each named by its file.
            good = np.loadtxt(series)
            no_load, nan, huge, back = good.copy(), good.copy(), good.copy(), good.copy()
            no_load[:, [3, 5]] = 0.0   # bottom_fy, top_fy
            nan[4, 4] = np.nan
            huge[6, 2] = 1e300   # bottom_fx: would print a 300-digit mu_eff
            back[4, 1] = 0.5
            for table, problem in ((no_load, "no normal force on the walls"),
                                   (nan, "row 5 of the samples holds a value"),
                                   (huge, "row 7 of the samples holds a value that is not "
                                          "finite or beyond 1e+100"),
                                   (back, "time does not increase at row 5")):
                np.savetxt(series, table)
                out = self.side_by_side(run, lammps)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn(f"error: {series}: {problem}", out.stderr)
            np.savetxt(series, good)
            # A duration other than the runs': their second half and seconds per time unit
            # would be of another length (a shorter one averaged to the runs' end).
            for duration, end in (("1e6", "100"), ("50", "100")):
                out = self.side_by_side(run, lammps, duration=duration)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn(f"run.h5: its samples end at t = {end}, not at --duration "
                              f"{float(duration):g}", out.stderr)
            np.savetxt(series, good[:200])
            out = self.side_by_side(run, lammps)
            self.assertEqual(out.returncode, 2, out.stderr)
            self.assertIn(f"{series}: its samples end at t = 49.75, not at --duration 100",
                          out.stderr)
            np.savetxt(series, good)
            with open(os.path.join(lammps, "dump.txt"), "w") as f:
                f.write("ITEM: TIMESTEP\n100\n")
            out = self.side_by_side(run, lammps)
            self.assertEqual(out.returncode, 2, out.stderr)
            self.assertIn("dump.txt: the snapshot from line 1 is cut short", out.stderr)
            # a dump of no atoms, and one of another system than the run's
            attrs = load_run(run)["attrs"]
            for rows, problem in (([], "the snapshot from line 1 holds no atoms"),
                                  ([[1, 1, 1.0, 2.0, 0.5], [2, 1, 3.0, 2.0, 0.5]],
                                   f"holds 2 grains in a box 10 wide where {run}/run.h5 has "
                                   f"{int(attrs['n'])} in {float(attrs['length_x']):.6g}")):
                with open(os.path.join(lammps, "dump.txt"), "w") as f:
                    f.write(f"ITEM: TIMESTEP\n100\nITEM: NUMBER OF ATOMS\n{len(rows)}\n"
                            "ITEM: BOX BOUNDS pp ff pp\n0 10\n-1 30\n-0.5 0.5\n"
                            "ITEM: ATOMS id type x y radius\n" +
                            "".join(" ".join(map(str, r)) + "\n" for r in rows))
                out = self.side_by_side(run, lammps)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn(problem, out.stderr)
            os.unlink(os.path.join(lammps, "dump.txt"))
            # wall times no run takes: refused, not printed with 300 digits
            for seconds in ("1e-320", "1e300"):
                out = subprocess.run([sys.executable, "-m", "cdshear_analysis", "side-by-side",
                                      "--cdshear-run", run, "--lammps-dir", lammps, "--duration",
                                      "100", "--cdshear-seconds", seconds, "--lammps-seconds",
                                      "2"], cwd=PYTHON_DIR, capture_output=True, text=True,
                                     timeout=60)
                self.assertEqual(out.returncode, 2, out.stderr)
                self.assertIn(f"error: --cdshear-seconds: {float(seconds):g} s is no run's wall "
                              "time", out.stderr)
            os.unlink(series)
            os.mkfifo(series)   # refused, not waited on
            out = self.side_by_side(run, lammps)
            self.assertEqual(out.returncode, 2, out.stderr)
            self.assertIn("not a regular file (a FIFO)", out.stderr)


class Estimates(unittest.TestCase):
    def test_overlap_of_a_snapshot(self):
        # [id, type, x, y, radius]; grains 1 and 2 overlap by 0.01 across the periodic boundary,
        # grain 3 overlaps a wall disk by 0.002
        rows = np.array([[1, 1, 0.2, 2.0, 0.5], [2, 1, 9.21, 2.0, 0.5],
                         [3, 1, 5.0, 0.498, 0.5], [4, 2, 5.0, -0.5, 0.5],
                         [5, 3, 5.0, 8.5, 0.5]])
        self.assertAlmostEqual(max_overlap(rows, 10.0), 0.01, places=12)
        rows[1, 2] = 8.0
        self.assertAlmostEqual(max_overlap(rows, 10.0), 0.002, places=12)

    def test_overlap_taken_in_chunks_is_the_overlap_of_all_pairs(self):
        # 40 random grains; the largest overlap is between grains 3 and 37, in different chunks
        # of 8, across the periodic boundary; chunks of 1, 8 and all give the same number
        rng = np.random.default_rng(5)
        n = 40
        rows = np.column_stack([np.arange(1, n + 1), np.ones(n), rng.uniform(0, 10, n),
                                rng.uniform(1, 50, n), np.full(n, 0.05)])
        rows[3, 2:4] = [0.01, 25.0]
        rows[37, 2:4] = [9.95, 25.0]  # centres 0.06 apart through x = 0: overlap 0.04
        walls = np.array([[41, 2, 5.0, -0.5, 0.5], [42, 3, 5.0, 52.0, 0.5]])
        rows = np.vstack([rows, walls])
        whole = max_overlap(rows, 10.0, chunk=n)
        self.assertAlmostEqual(whole, 0.04, places=12)
        self.assertEqual(max_overlap(rows, 10.0, chunk=8), whole)
        self.assertEqual(max_overlap(rows, 10.0, chunk=1), whole)

    def test_second_half_estimator(self):
        rng = np.random.default_rng(3)
        t = np.arange(1, 2001) * 0.1
        fy = 5.0 + 0.3 * rng.standard_normal(len(t))
        series = dict(time=t, bottom_fx=0.3 * fy, top_fx=-0.3 * fy, bottom_fy=-fy, top_fy=fy,
                      height=20 + 0.1 * rng.standard_normal(len(t)),
                      solid_fraction=0.8 + 0.01 * rng.standard_normal(len(t)))
        series["bottom_fx"][:1000] = 100.0     # first half: ignored
        est = second_half_estimates(series, 200.0)
        self.assertEqual(est["samples"], 1000)
        self.assertAlmostEqual(est["mu_eff"], 0.3, places=12)
        self.assertLess(est["mu_eff_err"], 1e-12)
        self.assertAlmostEqual(est["solid_fraction"], 0.8, delta=0.002)
        self.assertAlmostEqual(est["solid_fraction_err"], 0.01 / math.sqrt(1000), delta=1e-4)

    def test_lammps_series_file(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "series.txt")
            with open(path, "w") as f:
                f.write("# Time-averaged data\n# TimeStep v_now ...\n"
                        "159 0.05 1 -2 -1 2 20 0.8 0.001\n318 0.15 1 -2 -1 2 20 0.8 0.002\n")
            s = lammps_series(path)
            self.assertEqual(list(s["step"]), [159, 318])
            self.assertEqual(list(s["com_vx"]), [0.001, 0.002])
            with open(path, "a") as f:
                f.write("477 0.25 1\n")
            with self.assertRaises(PeerError):
                lammps_series(path)
            # No sample at all: said so, without numpy's warning on stderr.
            for content in ("", "# Time-averaged data\n"):
                with open(path, "w") as f:
                    f.write(content)
                with warnings.catch_warnings():
                    warnings.simplefilter("error")
                    with self.assertRaisesRegex(PeerError, f"^{path}: holds no sample"):
                        lammps_series(path)


def write_lammps_run(folder, name, bulk_rows, mu, top_line=20.0):
    """A finished LAMMPS run of lammps_campaign.sh over 100 t: run.json, the variables, a series
    of 10 samples per time unit (the walls' force ratio mu(t), the height top_line, times
    printed to six digits as LAMMPS' %g does) and a dump every time unit whose snapshot k holds
    `bulk_rows(k)` between wall lines at 0 and top_line."""
    run_dir = os.path.join(folder, name)
    os.makedirs(os.path.join(run_dir, "lammps"))
    with open(os.path.join(run_dir, "run.json"), "w") as f:
        json.dump({"run": name, "velocity": 0.05, "duration": 100.0, "kappa": 2e4}, f)
    with open(os.path.join(run_dir, "packing.data.vars"), "w") as f:
        f.write("# test\nvariable wall_radius equal 0.5\nvariable length_x equal 10.0\n"
                "variable n_grains equal 511\n")
    with open(os.path.join(run_dir, "lammps", "series.txt"), "w") as f:
        f.write("# Time-averaged data\n# TimeStep v_now ...\n")
        for k in range(1, 1001):
            t = 0.1 * k - 0.05
            f.write(f"{225 * k} {t:g} {mu(t) * 5:g} -5 {-mu(t) * 5:g} 5 {top_line:g} 0.8 0\n")
    with open(os.path.join(run_dir, "lammps", "dump.txt"), "w") as f:
        for k in range(101):
            rows = bulk_rows(k)
            walls = [[900, 2, 5.0, -0.5, 0.5], [901, 3, 5.0, top_line + 0.5, 0.5]]
            f.write(f"ITEM: TIMESTEP\n{2250 * k}\nITEM: NUMBER OF ATOMS\n{len(rows) + 2}\n"
                    "ITEM: BOX BOUNDS pp ff pp\n0 10\n-6 26\n-0.5 0.5\n"
                    "ITEM: ATOMS id type x y radius\n")
            for r in list(rows) + walls:
                f.write(" ".join(f"{v:g}" for v in r) + "\n")
    return run_dir


def write_campaign_run(campaign_dir, name, window=True):
    """A campaign's run folder as lammps_campaign reads it: summary.json's averaging start
    (t = 30) and case.toml's stripes of 1 d and, with `window`, windows of 10 t."""
    run = os.path.join(campaign_dir, "runs", name)
    os.makedirs(run)
    with open(os.path.join(run, "summary.json"), "w") as f:
        json.dump({"averaging_start_time": 30.0}, f)
    with open(os.path.join(run, "case.toml"), "w") as f:
        f.write("[measure]\nstripe_thickness = 1.0\n" + ("window = 10.0\n" if window else ""))
    return name


class BesideACampaign(unittest.TestCase):
    def test_segment_areas_are_exact(self):
        r = np.array([0.5, 0.5, 0.5, 0.4])
        whole = segment_area(r, np.full(4, -1.0), np.full(4, 1.0))
        np.testing.assert_allclose(whole, np.pi * r * r, rtol=1e-14)
        half = segment_area(r, np.zeros(4), np.full(4, 2.0))
        np.testing.assert_allclose(half, 0.5 * np.pi * r * r, rtol=1e-14)
        # a cap of height r / 2: r^2 acos(1 / 2) - (r / 2) sqrt(r^2 - r^2 / 4)
        cap = segment_area(np.array([0.5]), np.array([0.25]), np.array([1.0]))[0]
        self.assertAlmostEqual(cap, 0.25 * math.acos(0.5) - 0.25 * math.sqrt(0.25 - 0.0625), 14)

    def test_stripe_solid_fraction_and_wall_lines(self):
        rows = np.array([[1, 1, 2.0, 10.0, 0.5],     # inside: pi / 4
                         [2, 1, 6.0, 15.0, 0.5],     # cut in half by y = 15
                         [3, 1, 8.0, 3.0, 0.5],      # outside
                         [4, 2, 5.0, -0.4, 0.5], [5, 2, 6.0, -0.6, 0.5],
                         [6, 3, 5.0, 20.5, 0.5]])
        self.assertEqual(wall_lines(rows, 0.5), (0.0, 20.0))
        nu = stripe_solid_fraction(rows, 10.0, 5.0, 15.0)
        self.assertAlmostEqual(nu, (0.25 * math.pi + 0.125 * math.pi) / 100.0, places=14)

    def test_the_bulk_is_whole_stripes_with_centres_inside(self):
        # L_y 20.25, h 5: centres 5.5 to 14.5 (15.5 > 15.25); L_y 20.6: 5.5 to 15.5
        self.assertEqual(bulk_stripes(20.25, 5.0, 1.0), (5.0, 15.0))
        self.assertEqual(bulk_stripes(20.6, 5.0, 1.0), (5.0, 16.0))
        self.assertEqual(bulk_stripes(20.0, 5.0, 0.5), (5.0, 15.0))
        self.assertEqual(bulk_stripes(20.0, 4.9, 1.0), (5.0, 15.0))
        self.assertEqual(bulk_stripes(20.0, 5.5, 1.0), (6.0, 14.0))
        self.assertIsNone(bulk_stripes(10.4, 5.0, 1.0))

    def test_runs_are_averaged_as_their_namesakes_and_paired_with_them(self):
        # The campaign's runs average from t = 30 (summary.json; the second half would be 50)
        # in windows of 10 t with stripes of 1 (case.toml). L_y = 20.3 and h = 5: the bulk is the
        # stripes with centres 5.5 to 14.5, [5, 15], so a grain in [15.05, 15.25] is not in it.
        def bulk(k):
            inside, above = [1, 1, 5.0, 10.0, 0.5], [2, 1, 2.0, 15.15, 0.1]
            return [inside, above] + ([[3, 1, 7.0, 12.0, 0.5]] if k <= 30 else [])

        def mu(t):
            return 0.9 if t <= 30 else 0.3 if t <= 50 else 0.5

        with tempfile.TemporaryDirectory() as tmp:
            peers_dir, campaign_dir = os.path.join(tmp, "lammps"), os.path.join(tmp, "campaign")
            cd_rows = []
            for k in (1, 2, 3, 4):   # 3: no LAMMPS run; 4: a case.toml without the window
                name = write_campaign_run(campaign_dir, f"s1_seed{k}_V0.05", window=k < 4)
                cd_rows.append({"run": name, "system": 1, "seed": k, "V": 0.05, "n": 511,
                                "duration": 100.0, "bulk_h": 5.0, "regime": "C",
                                "mu_eff_wall": 0.25, "mu_eff_wall_err": 0.01, "L_y": 20.1,
                                "L_y_err": 0.01, "nu_bulk": 0.007, "nu_bulk_err": 0.001})
                if k != 3:
                    write_lammps_run(peers_dir, name, bulk, mu, top_line=20.3)
            campaign = Campaign(name="fake", folder=campaign_dir, rows=cd_rows)
            peers = lammps_campaign(peers_dir, campaign)
            self.assertEqual([r["run"] for r in peers.rows], ["s1_seed1_V0.05",
                                                              "s1_seed2_V0.05"])
            self.assertEqual(peers.skipped[0], ("s1_seed3_V0.05", "no finished LAMMPS run"))
            self.assertEqual(peers.skipped[1][0], "s1_seed4_V0.05")
            self.assertIn("no measure.stripe_thickness and measure.window", peers.skipped[1][1])
            row = peers.rows[0]
            self.assertAlmostEqual(row["mu_eff_wall"], (0.3 * 200 + 0.5 * 500) / 700, places=6)
            self.assertAlmostEqual(row["L_y"], 20.3, places=12)
            self.assertAlmostEqual(row["nu_bulk"], 0.25 * math.pi / 100.0, places=12)
            self.assertLess(row["nu_bulk_err"], 1e-12)
            paired = paired_differences(compare_campaigns(campaign, peers))[0]
            self.assertEqual(paired["runs"], 2)
            self.assertAlmostEqual(paired["L_y"]["mean"], 0.2, places=10)
            self.assertAlmostEqual(paired["nu_bulk"]["mean"], 0.25 * math.pi / 100 - 0.007,
                                   places=12)
            # The LAMMPS run's grain count is its packing's: another system's is not paired.
            cd_rows[0]["n"] = 5119
            items = compare_campaigns(campaign, lammps_campaign(peers_dir, campaign))
            self.assertIn("n 5119 in a, 511 in b", items[0]["mismatch"])
            cd_rows[0]["n"] = 511
            # A LAMMPS run of another length averages other times: left out, saying so.
            cd_rows[1]["duration"] = 400.0
            peers = lammps_campaign(peers_dir, campaign)
            self.assertEqual([r["run"] for r in peers.rows], ["s1_seed1_V0.05"])
            self.assertIn(("s1_seed2_V0.05", "LAMMPS ran 100 t, the campaign's run 400.0 t: "
                           "their averages would cover other times"), peers.skipped)
            cd_rows[1]["duration"] = 100.0
            # A run.json copied from another run's folder, or without its velocity.
            record = os.path.join(peers_dir, "s1_seed2_V0.05", "run.json")
            for content, problem in (({"run": "s1_seed1_V0.05", "velocity": 0.05,
                                       "duration": 100.0}, "is the record of run 's1_seed1"),
                                     ({"run": ["x"], "velocity": 0.05, "duration": 100.0},
                                      "is the record of run ['x']"),
                                     ({"run": "s1_seed2_V0.05", "duration": 100.0},
                                      "velocity = None: expected a number > 0")):
                with open(record, "w") as f:
                    json.dump(content, f)
                with self.assertRaises(PeerError) as caught:
                    lammps_campaign(peers_dir, campaign)
                self.assertEqual(caught.exception.path, record)
                self.assertIn(problem, caught.exception.problem)
            # No folder of LAMMPS runs: an error, not every run "left out".
            for folder, problem in ((os.path.join(tmp, "none"), "no such folder"),
                                    (record, "is a file, not the folder of the LAMMPS runs")):
                with self.assertRaises(PeerError) as caught:
                    lammps_campaign(folder, campaign)
                self.assertIn(problem, caught.exception.problem)

    def test_cut_short_unfinished_or_mixed_runs_are_not_averaged(self):
        with tempfile.TemporaryDirectory() as tmp:
            peers_dir, campaign_dir = os.path.join(tmp, "lammps"), os.path.join(tmp, "campaign")
            cd_rows = []
            for k in (1, 2):
                name = write_campaign_run(campaign_dir, f"s1_seed{k}_V0.05")
                cd_rows.append({"run": name, "system": 1, "seed": k, "V": 0.05, "n": 511,
                                "duration": 100.0, "bulk_h": 5.0, "finished": True,
                                "time_reached": 100.0})
                write_lammps_run(peers_dir, name, lambda k: [[1, 1, 5.0, 10.0, 0.5]],
                                 lambda t: 0.3)
            campaign = Campaign(name="fake", folder=campaign_dir, rows=cd_rows)
            self.assertEqual(len(lammps_campaign(peers_dir, campaign).rows), 2)
            # The campaign's run stopped at t = 60: the LAMMPS run's 100 t would be averaged
            # over other times.
            cd_rows[1].update(finished=False, time_reached=60.0)
            peers = lammps_campaign(peers_dir, campaign)
            self.assertEqual([r["run"] for r in peers.rows], ["s1_seed1_V0.05"])
            self.assertEqual(peers.skipped, [("s1_seed2_V0.05", "the campaign's run is not "
                                              "finished (t = 60 of 100): the finished LAMMPS "
                                              "run's averages would cover other times")])
            cd_rows[1].update(finished=True, time_reached=100.0)
            # Runs of two contact stiffnesses are not pooled.
            record = os.path.join(peers_dir, "s1_seed2_V0.05", "run.json")
            with open(record) as f:
                meta = json.load(f)
            with open(record, "w") as f:
                json.dump(dict(meta, kappa=1000.0), f)
            with self.assertRaises(PeerError) as caught:
                lammps_campaign(peers_dir, campaign)
            self.assertEqual(caught.exception.path, peers_dir)
            self.assertIn("other contact stiffnesses (run.json's kappa; s1_seed1_V0.05: 20000, "
                          "s1_seed2_V0.05: 1000)", caught.exception.problem)
            with open(record, "w") as f:
                json.dump(meta, f)
            # A kappa that is no number is named, not a traceback.
            with open(record, "w") as f:
                json.dump(dict(meta, kappa=[2e4]), f)
            with self.assertRaises(PeerError) as caught:
                lammps_campaign(peers_dir, campaign)
            self.assertEqual((caught.exception.path, caught.exception.problem),
                             (record, "kappa = [20000.0]: expected a number > 0 (the normal "
                                      "stiffness lammps_campaign.sh ran with)"))
            # A run.json of a shorter run than its files hold: another run's files.
            with open(record, "w") as f:
                json.dump(dict(meta, duration=50.0), f)
            cd_rows[1]["duration"] = 50.0
            with self.assertRaises(PeerError) as caught:
                lammps_campaign(peers_dir, campaign)
            self.assertIn("its samples end at t = 99.95, not at run.json's duration 50: longer "
                          "than the run it records", caught.exception.problem)
            cd_rows[1]["duration"] = 100.0
            with open(record, "w") as f:
                json.dump(meta, f)
            # The command line (its campaign the rows above): the stiffness is printed; nothing
            # compared is an error (exit 2).
            def compare():
                with mock.patch("cdshear_analysis.campaign.load_campaign", lambda _: campaign):
                    return cli_main(["lammps-compare", campaign_dir, peers_dir])

            with contextlib.redirect_stdout(io.StringIO()) as out:
                self.assertEqual(compare(), 0)
            self.assertIn("the LAMMPS runs' normal stiffness: kappa = 20000", out.getvalue())
            for row in cd_rows:
                row["n"] = 1023
            with contextlib.redirect_stdout(io.StringIO()) as out, \
                    contextlib.redirect_stderr(io.StringIO()) as err:
                self.assertEqual(compare(), 2)
            self.assertIn("s1_seed1_V0.05: not compared: n 1023 in a, 511 in b", out.getvalue())
            self.assertIn(f"error: {peers_dir}: no LAMMPS run could be compared", err.getvalue())
            for row in cd_rows:
                row["n"] = 511
            # A series or a dump that stops before run.json's duration (a file cut short).
            series = os.path.join(peers_dir, "s1_seed2_V0.05", "lammps", "series.txt")
            dump = os.path.join(peers_dir, "s1_seed2_V0.05", "lammps", "dump.txt")
            for path, keep, problem in ((series, 602, "its samples end at t = 59.95, not at "
                                         "run.json's duration 100: cut short"),
                                        (dump, 9 * 60 + 3 * 60, "its snapshots end at t = 59, "
                                         "not at run.json's duration 100: cut short")):
                with open(path) as f:
                    whole = f.read()
                with open(path, "w") as f:
                    f.write("".join(whole.splitlines(keepends=True)[:keep]))
                with self.assertRaises(PeerError) as caught:
                    lammps_campaign(peers_dir, campaign)
                self.assertEqual(caught.exception.path, path)
                self.assertIn(problem, caught.exception.problem)
                with open(path, "w") as f:
                    f.write(whole)
            self.assertEqual(len(lammps_campaign(peers_dir, campaign).rows), 2)


if __name__ == "__main__":
    unittest.main()
