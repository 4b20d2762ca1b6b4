"""The dembuf Python package against a live dembufd (started by client_test.sh, which sets
DEMBUF_SERVER): submit, live samples, a fetch equal to the CLI's files, a sweep, folders."""

import hashlib
import json
import os
import pathlib
import subprocess
import sys
import unittest

import numpy as np
import pandas as pd

import dembuf

CLI = os.environ["DEMBUF_CLI"]
WORK = pathlib.Path(os.environ["DEMBUF_TEST_WORK"])
SCENE = os.environ["DEMBUF_TEST_SCENE"]  # a 2 cm bed that settles in seconds
EXAMPLE = pathlib.Path(__file__).parents[2] / "docs" / "examples" / "e2_curve.py"
# About 9,200 samples after the free fall: more than one piece of the streamed fetch (8,192
# samples); and animation frames every 20 ms.
LONG_SERIES = {"time.end_s": 0.1, "time.output_interval_s": 1e-5,
               "output.animation_interval_s": 0.02}


def cli(*args):
    return subprocess.run([CLI, *args], check=True, capture_output=True, text=True).stdout


def csv_text(frame: pd.DataFrame) -> str:
    """A series as plate_force.csv writes it (9 significant digits, NaN as empty)."""
    return frame.to_csv(index=False, float_format="%.9g", lineterminator="\n")


class ClientTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.daemon = dembuf.connect()
        cls.job = cls.daemon.submit(toml=SCENE, set=LONG_SERIES, name="python")
        # Watched from the start, while it prepares its bed and runs.
        cls.watched = []
        cls.states_seen = set()
        for sample in cls.daemon.watch(cls.job):
            if len(cls.watched) % 2000 == 0:
                cls.states_seen.add(cls.daemon.job(cls.job)["state"])
            cls.watched.append(sample)
        cls.final_state = cls.daemon.wait(cls.job, timeout_s=300)
        cls.fetched_dir = WORK / "fetched"
        cli("fetch", str(cls.job), "--out", str(cls.fetched_dir), "--no-plots")

    @classmethod
    def tearDownClass(cls):
        cls.daemon.close()

    def test_job_runs_and_samples_arrive_live(self):
        self.assertEqual(self.final_state, "done")
        self.assertIn("running", self.states_seen, "no sample arrived while the job ran")
        self.assertGreater(len(self.watched), 8192)
        times = [s.t_s for s in self.watched]
        self.assertTrue(all(a < b for a, b in zip(times, times[1:])), "times not increasing")

    def test_fetched_series_equals_the_csv(self):
        run = self.daemon.fetch(self.job)
        self.assertEqual(list(run.series.columns), dembuf.SERIES_COLUMNS)
        self.assertEqual(len(run.series), len(self.watched))
        csv_path = self.fetched_dir / "plate_force.csv"
        self.assertEqual(csv_text(run.series), csv_path.read_text())
        from_csv = pd.read_csv(csv_path)
        np.testing.assert_allclose(run.series.to_numpy(), from_csv.to_numpy(), rtol=5e-9,
                                   atol=0, equal_nan=True)
        # The watched samples are the stored ones.
        self.assertEqual(list(run.series["plate_force_N"]),
                         [s.plate_force_N for s in self.watched])

    def test_summary_and_job(self):
        run = self.daemon.fetch(self.job)
        self.assertEqual(run.summary, json.loads((self.fetched_dir / "summary.json").read_text()))
        self.assertGreater(run.summary["P_N"], 0)
        self.assertEqual(run.job["state"], "done")
        self.assertEqual(run.job["name"], "python")

    def test_provenance(self):
        run = self.daemon.fetch(self.job)
        p = run.summary["provenance"]
        # The command that asked for it: this test's, sent by the package.
        self.assertIn("test_client.py", p["command_line"])
        self.assertEqual(run.job["command_line"], p["command_line"])
        # The scene's SHA-256 is that of the scene file the fetch writes.
        scene = (self.fetched_dir / "scene.toml").read_bytes()
        self.assertEqual(p["scene_sha256"], hashlib.sha256(scene).hexdigest())
        self.assertRegex(p["bed_sha256"], "^[0-9a-f]{64}$")
        self.assertEqual(p["bed_hash"], run.job["bed_hash"])
        self.assertRegex(p["build_commit"], "^([0-9a-f]{40}(-dirty-[0-9a-f]{12})?|unknown)$")
        self.assertEqual(p["host"], run.job["host"])
        self.assertGreaterEqual(p["threads"], 1)
        self.assertLessEqual(p["started_at"], p["finished_at"])
        self.assertEqual(p["seed"], 1)

    def test_local_folder_reads_as_fetched(self):
        local = dembuf.read_run(self.fetched_dir)
        fetched = self.daemon.fetch(self.job)
        self.assertEqual(csv_text(local.series), csv_text(fetched.series))
        self.assertEqual(local.summary, fetched.summary)
        with self.assertRaisesRegex(FileNotFoundError, "plate_force.csv"):
            dembuf.read_run(WORK)

    def test_animation_frames_read_as_frames(self):
        frames = dembuf.read_pvd(self.fetched_dir / "frames.pvd")
        # Part 1 is the container, the same file at every time.
        self.assertTrue((frames[frames.part == 1]["file"].map(lambda f: f.name) ==
                         "container.vtp").all())
        frames = frames[frames.part == 0]
        # From the end of the free fall to time.end_s, every 20 ms.
        first = frames["t_s"].iloc[0]
        self.assertEqual(len(frames), int((0.1 - first) / 0.02) + 1)
        spacing = frames["t_s"].diff().dropna()
        self.assertTrue(((spacing > 0.0199) & (spacing < 0.0201)).all(), list(spacing))
        beads = dembuf.read_vtp(frames["file"].iloc[-1])
        summary = json.loads((self.fetched_dir / "summary.json").read_text())
        self.assertEqual(len(beads), summary["beads"] + 1)
        self.assertEqual(sorted(beads["id"]), [-1, *range(summary["beads"])])
        for column in ("x_m", "z_m", "radius_m", "vz_m_s", "fz_N"):
            self.assertIn(column, beads.columns)
        self.assertTrue((beads["radius_m"] > 0).all())

    def test_an_older_sweep_csv_is_read_as_today(self):
        # Columns `job` (the run's number) and status `ok`, as dembuf wrote them before `run`,
        # `id` and the job states.
        folder = WORK / "older-sweep"
        folder.mkdir(exist_ok=True)
        metrics = dembuf.frames.sweep_metric_names()
        (folder / "sweep.csv").write_text(
            "job,bed.thickness_m,status," + ",".join(metrics) + ",run_dir,error\n"
            "0,0.01,ok," + ",".join(["1"] * len(metrics)) + ",runs/000,\n"
            "1,0.02,failed," + "," * (len(metrics) - 1) + ",runs/001,\"unstable\"\n")
        frame = dembuf.read_sweep(folder)
        self.assertEqual(list(frame.columns[:4]), ["run", "id", "bed.thickness_m", "status"])
        self.assertEqual(list(frame["status"]), ["done", "failed"])

    def test_a_local_run_folder(self):
        out = WORK / "local"
        cli("-q", "run", SCENE, "--set", "time.end_s=0.05", "--out", str(out),
            "--no-plots")
        run = dembuf.read_run(out)
        self.assertEqual(len(run.series), len(pd.read_csv(out / "plate_force.csv")))
        self.assertEqual(run.summary["steps"],
                         json.loads((out / "summary.json").read_text())["steps"])

    def test_sweep_as_a_frame(self):
        sweep = self.daemon.submit_sweep({"bed.thickness_m": [0.008, 0.01]}, seeds=2,
                                         toml=SCENE, set={"time.end_s": 0.05}, name="py-sweep")
        for job in self.daemon.jobs(sweep=sweep)["id"]:
            self.assertEqual(self.daemon.wait(int(job), timeout_s=300), "done")
        frame = self.daemon.sweep(sweep)
        self.assertEqual(len(frame), 4)
        self.assertEqual(list(frame["status"]), ["done"] * 4)
        self.assertEqual(sorted(frame["run"]), [0, 1, 2, 3])
        self.assertEqual(sorted(frame["bed.thickness_m"]), [0.008, 0.008, 0.01, 0.01])
        for _, row in frame.iterrows():
            self.assertEqual(row["P_N"], self.daemon.fetch(int(row["id"])).summary["P_N"])
        # The fetched sweep folder gives the same frame: the same runs and job ids.
        folder = WORK / "sweep"
        cli("fetch", "--sweep", str(sweep), "--out", str(folder), "--no-plots")
        local = dembuf.read_sweep(folder)
        self.assertEqual(list(local.columns), list(frame.columns))
        self.assertEqual(sorted(zip(local["run"], local["id"])), sorted(zip(frame["run"], frame["id"])))
        # The swept values with the same types both ways (bed.seed 2, not 2.0).
        for axis in ("bed.thickness_m", "bed.seed"):
            self.assertEqual(list(local[axis]), list(frame[axis]), axis)
            self.assertEqual(local[axis].dtype, frame[axis].dtype, axis)
        metrics = dembuf.frames.sweep_metric_names()
        np.testing.assert_allclose(local[metrics].to_numpy(dtype=float),
                                   frame[metrics].to_numpy(dtype=float), rtol=1e-6,
                                   equal_nan=True)
        # The points as the daemon computed them, row for row the fetched points.csv.
        points = self.daemon.sweep_points(sweep)
        self.assertEqual(list(points["P_N_n"]), [2, 2])
        self.assertEqual(list(points["bed.thickness_m"]), [0.008, 0.01])
        for thickness, point in points.set_index("bed.thickness_m").iterrows():
            values = frame[frame["bed.thickness_m"] == thickness]["P_N"]
            self.assertAlmostEqual(point["P_N"], values.mean())
            self.assertAlmostEqual(point["P_N_sd"], values.std())
        fetched = dembuf.read_points(folder)
        self.assertEqual(list(fetched.columns), list(points.columns))
        pd.testing.assert_frame_equal(fetched, points, check_dtype=False, rtol=1e-9)
        # The worked example of docs/python.md draws the curve, from the daemon and the folder.
        for source in (str(sweep), str(folder)):
            png = WORK / f"curve-{source.replace('/', '_')}.png"
            subprocess.run([sys.executable, str(EXAMPLE), source, str(png)], check=True,
                           capture_output=True)
            self.assertEqual(png.read_bytes()[:8], b"\x89PNG\r\n\x1a\n")

    def test_a_bed_file_sent_with_the_job(self):
        # The job's own bed, exported as LAMMPS data, imported by a job of the package: the
        # same bed hash as the CLI's local import of that file.
        bed = WORK / "python bed.data"
        cli("bed", "export", SCENE, "--format", "lammps", "--out", str(bed), "--force",
            "--bed-cache", str(WORK / "py-beds"))
        local = cli("prepare-bed", SCENE, "--set", f"bed.import={bed}",
                    "--bed-cache", str(WORK / "py-import"))
        job = self.daemon.submit(toml=SCENE, bed_file=bed, set={"time.end_s": 0.001})
        self.assertEqual(self.daemon.wait(job, timeout_s=300), "done")
        record = self.daemon.job(job)
        self.assertIn(f"import bed {record['bed_hash']}:", local)
        self.assertIn('import = "python_bed.data"', record["scene_toml"])
        with self.assertRaisesRegex(dembuf.DembufError, "INVALID_ARGUMENT.*bed.import"):
            bad = WORK / "bad.txt"
            bad.write_text("0 0 0.01 0.5\n")  # a bead wider than the cylinder
            self.daemon.submit(toml=SCENE, bed_file=bad)

    def test_errors_name_the_reason(self):
        with self.assertRaises(dembuf.DembufError) as caught:
            self.daemon.fetch(999999)
        self.assertEqual(caught.exception.code, "NOT_FOUND")
        # The scene's dotted name, as a scene file or the CLI says it (not the proto's
        # "thicknesM").
        with self.assertRaisesRegex(dembuf.DembufError, "INVALID_ARGUMENT.*bed.thicknes_m"):
            self.daemon.submit(scene={"bed": {"thicknes_m": 0.01}})
        with self.assertRaisesRegex(dembuf.DembufError, "bed.cut"):
            self.daemon.submit(scene={"bed": {"cut": "sideways"}})
        with self.assertRaisesRegex(dembuf.DembufError, "INVALID_ARGUMENT.*bed.thickness_m"):
            self.daemon.submit(scene={"bed": {"thickness_m": -1}})


if __name__ == "__main__":
    unittest.main()
