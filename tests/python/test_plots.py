"""The report plots (tools/plot) checked through their matplotlib objects, not by eye: what each
figure draws, that its title says which data it shows, and that nothing is cut off or hidden.

Run by ctest with POF_BIN = build/bin, POF_GEN_RECORDING = build/tests/gen_recording and
POF_PLOT_DIR = tools/plot. The calibration report comes from a real `pof calibrate --report
--no-plots` run on gen_recording's calibration protocol (~2 s), so a change of the report's
format breaks these tests too.
"""
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.environ["POF_PLOT_DIR"])
import calibration_report  # noqa: E402
import session_report  # noqa: E402

POF = os.path.join(os.environ["POF_BIN"], "pof")
GEN = os.environ["POF_GEN_RECORDING"]


def inside(inner, outer, tol=1.0):
    return (inner.x0 >= outer.x0 - tol and inner.y0 >= outer.y0 - tol and inner.x1 <= outer.x1 + tol
            and inner.y1 <= outer.y1 + tol)


def overlaps(a, b):
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


class FigureChecks(unittest.TestCase):
    def assert_nothing_cut_off(self, fig, name):
        """Every axes with its labels, tick labels, title and legend, and the suptitle, lie inside
        the figure: what savefig crops is what a reader loses."""
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        for ax in fig.axes:
            self.assertTrue(inside(ax.get_tightbbox(r), fig.bbox), f"{name}: an axes' labels or legend leave the figure")
        if fig._suptitle is not None:
            self.assertTrue(inside(fig._suptitle.get_window_extent(r), fig.bbox), f"{name}: suptitle cut off")


class CalibrationReport(FigureChecks):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix="pof-plots-")
        rec = os.path.join(cls.tmp, "cal.csv")
        subprocess.run([GEN, rec, "calibration"], check=True, capture_output=True)
        cls.rep = os.path.join(cls.tmp, "rep")
        subprocess.run([POF, "calibrate", rec, "-o", os.path.join(cls.tmp, "cal.toml"), "--report", cls.rep,
                        "--no-plots"], check=True, capture_output=True)
        # The same report without the dynamic model's per-scan file: no held-out angles.
        cls.rep_in_sample = os.path.join(cls.tmp, "rep_in_sample")
        os.mkdir(cls.rep_in_sample)
        for f in ("calibration.json", "compensated.csv"):
            shutil.copy(os.path.join(cls.rep, f), cls.rep_in_sample)
        cls.figs = calibration_report.figures(cls.rep)
        cls.figs_in_sample = calibration_report.figures(cls.rep_in_sample)
        with open(os.path.join(cls.rep, "calibration.json"), encoding="utf-8") as f:
            cls.report = json.load(f)

    @classmethod
    def tearDownClass(cls):
        plt.close("all")
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def velocities(self):
        return [t["velocity_rad_s"] for t in self.report["velocity_tests"]]

    def test_every_figure_is_whole(self):
        for figs in (self.figs, self.figs_in_sample):
            for name, fig in figs.items():
                self.assert_nothing_cut_off(fig, name)

    def test_loops_are_sensor_against_reference_angle_one_colour_per_velocity(self):
        for figs in (self.figs, self.figs_in_sample):
            fig = figs["loops.png"]
            self.assertIn("loops", fig._suptitle.get_text())
            legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
            self.assertEqual(len(legends), 1, "one legend for the whole figure")
            texts = [t.get_text() for t in legends[0].get_texts()]
            self.assertEqual([t for t in texts if t.endswith("rad/s")],
                             [f"{w:.4f} rad/s" for w in self.velocities()], "a legend entry per velocity test")
            leg = legends[0]
            handles = leg.legend_handles if hasattr(leg, "legend_handles") else leg.legendHandles  # mpl < 3.7
            colours = [matplotlib.colors.to_hex(h.get_color()) for h, t in zip(handles, texts) if t.endswith("rad/s")]
            self.assertEqual(len(set(colours)), len(colours), "velocities share a colour")
            panels = [ax for ax in fig.axes if ax.get_legend() is None]
            loops = [ax for ax in panels if ax.get_ylabel() == "sensor angle [deg]"]
            self.assertGreaterEqual(len(loops), 2, "before and after compensation")
            for ax in panels:
                self.assertEqual(ax.get_xlabel(), "reference angle [deg]")
                drawn = {matplotlib.colors.to_hex(line.get_color()) for line in ax.get_lines()}
                self.assertTrue(set(colours) <= drawn, "every velocity drawn in every panel")
            for ax in loops:  # the loops themselves, not their error: sensor ~ reference over the range
                x = np.concatenate([line.get_xdata() for line in ax.get_lines()])
                y = np.concatenate([line.get_ydata() for line in ax.get_lines()])
                self.assertGreater(np.nanmax(x) - np.nanmin(x), 60)
                self.assertLess(np.nanmedian(np.abs(y - x)), 5)
                self.assertGreater(np.nanmax(y) - np.nanmin(y), 60)

    def test_loop_sweeps_are_the_velocity_tests_sweeps(self):
        tests = calibration_report.test_sweeps(self.report)
        self.assertEqual(len(tests), len(self.report["velocity_tests"]))
        for (w, sweeps), t in zip(tests, self.report["velocity_tests"]):
            kinds = [s["kind"] for s in sweeps]
            self.assertEqual(kinds.count("flexion"), t["n_flexion_sweeps"], w)
            self.assertEqual(kinds.count("extension"), t["n_extension_sweeps"], w)
            for s in sweeps:  # pof calibrate's --min-sweep default: shorter ones are quasi-static steps
                self.assertGreaterEqual(abs(s["angle_end_deg"] - s["angle_begin_deg"]), 20, s)

    def test_titles_say_held_out_or_in_sample(self):
        held = self.report["dynamic"]["held_out"]["folds_used"]
        for name in ("loops.png", "error_vs_angle.png"):
            fig = self.figs[name]
            title = fig._suptitle.get_text() if fig._suptitle is not None else fig.axes[0].get_title()
            self.assertIn("held-out", title, name)
            self.assertIn(f"{held} blocks", title, name)
            fig = self.figs_in_sample[name]
            title = fig._suptitle.get_text() if fig._suptitle is not None else fig.axes[0].get_title()
            self.assertIn("on the calibration recording (in-sample)", title, name)
            self.assertNotIn("held-out", title, name)

    def test_fig6_y_labels_fit_their_panels(self):
        fig = self.figs["fig6_quasi_static.png"]
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        xs = []
        for ax in fig.axes:
            label, box = ax.yaxis.label.get_window_extent(r), ax.get_window_extent(r)
            self.assertLessEqual(label.height, 0.9 * box.height, f"'{ax.get_ylabel()}' overruns its panel")
            xs.append(label.x0)
        self.assertAlmostEqual(min(xs), max(xs), delta=1.0, msg="y labels aligned")


class SessionReport(FigureChecks):
    @staticmethod
    def session(n_stats):
        """Five 0-80 deg cycles, the last peak near the end (where an inside legend would sit)."""
        rows, t_us = [], 1_000_000
        for k in range(5):
            for i in range(200):
                a = 80 * (1 - abs(i - 100) / 100)
                rows.append({"utime": str(t_us), "angle_deg": f"{a + 0.05:.3f}", "angle_uncomp_deg": f"{a + 1.5:.3f}",
                             "angle_ref_deg": f"{a:.3f}", "quality": "0"})
                t_us += 5000
        stats = [{"cycle": str(k + 1), "velocity_rad_s": "0.15", "rmse_comp_deg": "0.05", "rmse_uncomp_deg": "1.4",
                  "hysteresis_comp_pct": "0.01", "hysteresis_uncomp_pct": "2.0", "max_error_deg": "0.2"}
                 for k in range(n_stats)]
        return rows, stats

    def tearDown(self):
        plt.close("all")

    def test_title_counts_the_table_rows(self):
        for n in (0, 1, 4, 5):
            rows, stats = self.session(n)
            fig = session_report.figure(rows, stats, "a session")
            m = re.search(r"(\d+) complete cycles?", fig._suptitle.get_text())
            self.assertIsNotNone(m, fig._suptitle.get_text())
            tables = [t for ax in fig.axes for t in ax.tables]
            body_rows = {row for t in tables for (row, _) in t.get_celld() if row > 0}
            self.assertEqual(int(m.group(1)), len(body_rows))
            self.assertEqual(len(body_rows), n)
            self.assert_nothing_cut_off(fig, f"session with {n} cycles")

    def test_legends_are_outside_the_data(self):
        rows, stats = self.session(5)
        fig = session_report.figure(rows, stats, "a session")
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        legends = 0
        for ax in fig.axes:
            leg = ax.get_legend()
            if leg is None:
                continue
            legends += 1
            self.assertFalse(overlaps(leg.get_window_extent(r), ax.get_window_extent(r)),
                             f"the legend of '{ax.get_ylabel()}' lies over its data")
            self.assertTrue(inside(leg.get_window_extent(r), fig.bbox))
        self.assertEqual(legends, 2)


if __name__ == "__main__":
    unittest.main()
