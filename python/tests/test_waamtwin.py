"""The Python package against the command it wraps. Run from the repository root with the
package installed and WAAMTWIN_BIN naming the `waamtwin` binary of the same build (the e2e
test `python::the_package_passes_its_tests` does both)."""

import json
import os
import signal
import subprocess
import tempfile
import threading
import time
import unittest
from pathlib import Path

import numpy as np

import waamtwin

BIN = os.environ.get("WAAMTWIN_BIN", "waamtwin")
DOME = "scenarios/demo_dome.toml"
# A small closed part on the thin wall: a few seconds a run.
SMALL = {
    "part": {"shape": "cylinder", "radius_mm": 25.0, "height_mm": 30.0},
    "output": {"frames": 0, "rerun": False, "mcap": False, "hdf5": False, "plots": False},
}


def command(*args):
    return subprocess.run([BIN, *args], capture_output=True, text=True)


class SamePlan(unittest.TestCase):
    def test_the_plan_from_python_is_the_commands_to_the_byte(self):
        with tempfile.TemporaryDirectory() as d:
            done = command("plan", DOME, "-o", d)
            self.assertEqual(done.returncode, 0, done.stderr)
            r = waamtwin.plan(DOME)
            self.assertEqual(r.path_of("path.csv").read_bytes(), Path(d, "path.csv").read_bytes())
            self.assertEqual(r.summary, done.stdout.strip())
            # Its tables are the CSV's columns as numbers.
            self.assertEqual(r.path["x"].dtype, np.float64)
            self.assertEqual(len(r.path["x"]), len(Path(d, "path.csv").read_text().splitlines()) - 1)
            # write() gives the command's files, by name and by content (manifest.json carries
            # the run's own times and folder, so it is compared by its keys).
            w = Path(d, "py")
            r.write(w)
            theirs = sorted(p.name for p in Path(d).iterdir() if p.is_file())
            self.assertEqual(sorted(p.name for p in w.iterdir()), theirs)
            for name in theirs:
                if name not in ("manifest.json",):
                    self.assertEqual(Path(w, name).read_bytes(), Path(d, name).read_bytes(), name)
            # The G-code's line, its table's fastest turns in it, is the command's; a robot's
            # format has no table to limit.
            mine = waamtwin.export(r, "gcode", rotary_rpm_max=100.0)
            done = command("export", d, "--format", "gcode", "--rotary-rpm-max", "100")
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertEqual(mine.split(": ", 1)[1], done.stdout.strip().split(": ", 1)[1])
            self.assertIn("rpm on C", mine)
            with self.assertRaises(waamtwin.InputError):
                waamtwin.export(r, "krl", rotary_rpm_max=10)

    def test_a_dict_scenario_with_overrides_runs_as_its_toml(self):
        with tempfile.TemporaryDirectory() as d:
            toml = Path(d, "small.toml")
            toml.write_text(
                '[part]\nshape = "cylinder"\nradius_mm = 25.0\nheight_mm = 30.0\n'
                "[output]\nframes = 0\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n"
                "[thermal]\nmodel = \"thin-wall\"\n"
            )
            done = command("simulate", str(toml), "-o", str(Path(d, "cmd")))
            self.assertEqual(done.returncode, 0, done.stderr)
            r = waamtwin.simulate(SMALL, thermal={"model": "thin-wall"})
            self.assertEqual(
                r.path_of("layers.csv").read_bytes(), Path(d, "cmd", "layers.csv").read_bytes()
            )
            theirs = json.loads(Path(d, "cmd", "thermal.json").read_text())
            self.assertEqual(r.thermal["max_preheat_c"], theirs["max_preheat_c"])
            self.assertTrue(np.all(np.isfinite(r.layers["preheat_max_c"])))


class Errors(unittest.TestCase):
    def test_bad_input_is_an_input_error_naming_the_field(self):
        with self.assertRaises(waamtwin.InputError) as e:
            waamtwin.plan(DOME, dwell={"confidence": 3})
        self.assertIn("dwell.confidence", str(e.exception))
        self.assertIn(DOME, str(e.exception))
        self.assertNotIn(".waamtwin-", str(e.exception))
        self.assertIsInstance(e.exception, ValueError)
        with self.assertRaises(waamtwin.InputError):
            waamtwin.plan("no/such/scenario.toml")
        with self.assertRaises(TypeError):
            waamtwin.plan(DOME, no_such_option=1)
        self.assertTrue(issubclass(waamtwin.SimulationError, RuntimeError))

    def test_a_study_whose_case_fails_keeps_the_others(self):
        # An R 60 cylinder outgrows the 80 mm plate once it is planned; the R 25 one runs.
        with tempfile.TemporaryDirectory() as d:
            base = Path(d, "base.toml")
            base.write_text(
                '[part]\nshape = "cylinder"\nradius_mm = 25.0\nheight_mm = 14.0\n'
                "[thermal]\nplate_mm = [80.0, 80.0, 6.0]\n"
                "[output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n"
            )
            study = {"base": str(base), "sweep": {"part.radius_mm": [25.0, 60.0]}}
            with self.assertRaises(waamtwin.InputError) as e:
                waamtwin.study(study)
        self.assertIn("1 of 2 cases failed", str(e.exception))
        r = e.exception.result
        self.assertEqual(list(r.table("summary")["part.radius_mm"]), [25.0])
        self.assertEqual(list(r.failed["part.radius_mm"]), [60.0])
        self.assertIn("plate_mm", r.failed["message"][0])


class LongRuns(unittest.TestCase):
    def test_other_threads_run_while_it_works_and_progress_is_told(self):
        ticks, stop = [0], threading.Event()

        def count():
            while not stop.is_set():
                ticks[0] += 1
                time.sleep(0.005)

        t = threading.Thread(target=count)
        told = []
        t.start()
        start = time.monotonic()
        r = waamtwin.simulate(
            DOME, output={"frames": 0}, progress=lambda s, d, n: told.append((s, d, n))
        )
        wall = time.monotonic() - start
        stop.set()
        t.join()
        # Held GIL: the counter would not move at all while the engine ran.
        self.assertGreater(ticks[0], 0.5 * wall / 0.005 * 0.5, (ticks[0], wall))
        # The dome overheats without dwells: its risk column (text) names the criteria broken,
        # an array of str as long as the numbers beside it.
        risk = r.layers["risk"]
        self.assertEqual(risk.dtype.kind, "U")
        self.assertEqual(len(risk), len(r.layers["preheat_max_c"]))
        self.assertTrue(any(v for v in risk))
        heating = [d for s, d, n in told if s == "heating the build"]
        self.assertGreater(len(heating), 3)
        self.assertEqual(heating, sorted(heating))

    def test_runs_from_two_threads_take_turns_and_agree(self):
        results = [None, None]

        def run(k):
            results[k] = waamtwin.simulate(SMALL)

        threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        a, b = (r.path_of("layers.csv").read_bytes() for r in results)
        self.assertEqual(a, b)

    def test_ctrl_c_stops_the_run(self):
        timer = threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT))
        start = time.monotonic()
        timer.start()
        with self.assertRaises(KeyboardInterrupt):
            waamtwin.simulate(DOME, output={"frames": 0})
        # The run takes ~8 s; stopped within a deposit of the signal.
        self.assertLess(time.monotonic() - start, 3.0)
        # And the next run runs.
        self.assertIn("build", waamtwin.simulate(SMALL).summary)

    def test_ctrl_c_ends_a_follow_with_its_files(self):
        # A small wall whose logger has written its first 40 s and then nothing more: follow
        # waits for the rest until Ctrl-C, which ends it as on the command line, its files
        # written and its result returned.
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            path = "t_s,x_mm,y_mm,z_mm,on\n" + "".join(
                f"{20 * k},-20,0,{1.5 * (k + 1)},0\n{20 * k + 8},20,0,{1.5 * (k + 1)},1\n"
                for k in range(6)
            )
            (d / "path.csv").write_text(path)
            log = ["t_s,a_c"] + [
                f"{0.5 * j},{25 + 60 * (1 - np.exp(-0.5 * j / 80)):.2f}" for j in range(81)
            ]
            (d / "log.csv").write_text("\n".join(log) + "\n")
            scenario = {
                "toolpath": {"file": str(d / "path.csv"), "deposit_mm": 2.0},
                "process": {
                    "power_w": 2000.0,
                    "efficiency": 0.8,
                    "bead_width_mm": 4.0,
                    "layer_height_mm": 1.5,
                },
                "material": {"preset": "G3Si"},
                "thermal": {"model": "voxel", "voxel_mm": 2.0, "plate_mm": [80.0, 40.0, 6.0]},
                "probes": {
                    "file": str(d / "log.csv"),
                    "unit": "C",
                    "points": [{"name": "a", "column": 1, "x_mm": 0.0, "y_mm": 8.0, "z_mm": 0.0}],
                },
                "calibrate": {"parameters": [{"name": "efficiency", "low": 0.5, "high": 0.95}]},
                "live": {"ensemble": 4, "forecast_every_s": 10.0, "forecast_horizons_s": [10.0]},
            }
            timer = threading.Timer(8.0, lambda: os.kill(os.getpid(), signal.SIGINT))
            start = time.monotonic()
            timer.start()
            r = waamtwin.follow(scenario)
            self.assertLess(time.monotonic() - start, 30.0)
            self.assertEqual(r.follow["state"], "interrupted (Ctrl-C)")
            self.assertEqual(r.follow["rows"], 81)
            self.assertGreater(len(r.forecasts["made_at_s"]), 0)
            self.assertTrue(np.all(r.forecasts["made_at_s"] <= 40.0))


if __name__ == "__main__":
    unittest.main()
