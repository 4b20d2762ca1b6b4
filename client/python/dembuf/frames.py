"""Results as pandas objects, from the daemon or from the folders `dembuf run` and
`dembuf sweep` write (and `dembuf fetch` fills)."""

from __future__ import annotations

import json
import math
import os
import pathlib
from dataclasses import dataclass, field

import pandas as pd

# The columns of plate_force.csv, in order.
SERIES_COLUMNS = ["t_s", "plate_force_N", "wall_force_z_N", "proj_z_m", "proj_vz_m_s",
                  "proj_force_z_N"]

# The summary fields sweep.csv tabulates, in its column order (the engine's SweepMetricNames;
# the Python tests compare them with a sweep.csv header).
_SWEEP_METRICS = ["P_N", "Pa_N", "Pb_N", "lambda", "crater_depth_m", "measured_thickness_m", "C0",
                  "dS_m", "dt_peaks_s", "load_duration_s", "peak_plate_force_N",
                  "peak_plate_force_time_s", "reference_peak_N", "first_contact_time_s",
                  "max_overlap_ratio", "beads", "steps", "wall_time_s"]

# Bounds on what is read from a folder or an answer: a result is data, not trusted. A summary
# nests four levels; JSON deeper than the C++ side's bound (kMaxJsonDepth) is refused.
MAX_SUMMARY_BYTES = 16 << 20
MAX_AGGREGATES_BYTES = 64 << 20  # a sweep's points (api_json.h's kMaxAggregatesBytes)
MAX_JSON_DEPTH = 64


def sweep_metric_names() -> list[str]:
    return list(_SWEEP_METRICS)


@dataclass
class Run:
    """One impact run: F(t) and the rest of the written samples, the summary.json (P, Pa,
    Pb, lambda, crater depth, ...), and, fetched from a daemon, the job."""

    series: pd.DataFrame
    summary: dict
    job: dict = field(default_factory=dict)
    folder: pathlib.Path | None = None


def series_frame(columns: dict) -> pd.DataFrame:
    """A frame of the series columns; a scene without a projectile has NaN in its columns."""
    return pd.DataFrame({name: pd.Series(columns[name], dtype="float64")
                         for name in SERIES_COLUMNS})


def json_depth(text: str) -> int:
    """How deep JSON text nests, in one pass (json.loads recurses, and a document 100,000
    deep ends in RecursionError or worse): brackets outside strings."""
    depth = deepest = 0
    in_string = escaped = False
    for c in text:
        if in_string:
            if escaped:
                escaped = False
            elif c == "\\":
                escaped = True
            elif c == '"':
                in_string = False
        elif c == '"':
            in_string = True
        elif c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest


def parse_json_object(text: str, what: str, max_bytes: int = MAX_SUMMARY_BYTES) -> dict:
    """A JSON object from outside (a summary, a sweep's aggregates), within the bounds."""
    if not text:
        return {}
    if len(text) > max_bytes:
        raise ValueError(f"{what}: {len(text)} bytes, more than {max_bytes}")
    if json_depth(text) > MAX_JSON_DEPTH:
        raise ValueError(f"{what}: nested deeper than {MAX_JSON_DEPTH} levels")
    summary = json.loads(text)
    if not isinstance(summary, dict):
        raise ValueError(f"{what}: not a JSON object")
    return summary


def metrics_of(summary: dict) -> dict:
    """The sweep metrics of a summary, NaN where absent or not a number."""
    def number(value):
        return float(value) if isinstance(value, (int, float)) and not isinstance(value, bool) \
            else math.nan
    return {m: number(summary.get(m)) for m in _SWEEP_METRICS}


def read_run(folder: str | os.PathLike) -> Run:
    """A run's folder (`dembuf run --out`, a sweep's runs/NAME, a `dembuf fetch`): its
    plate_force.csv and summary.json (empty for a run that did not end well)."""
    folder = pathlib.Path(folder)
    csv = folder / "plate_force.csv"
    if not csv.is_file():
        partial = " (a run still going, or cut short, leaves plate_force.csv.partial)" \
            if (folder / "plate_force.csv.partial").exists() else ""
        raise FileNotFoundError(f"{csv}: no such file{partial}")
    series = pd.read_csv(csv, dtype="float64")
    if list(series.columns) != SERIES_COLUMNS:
        raise ValueError(f"{csv}: columns {list(series.columns)}, expected {SERIES_COLUMNS}")
    summary_path = folder / "summary.json"
    summary = {}
    if summary_path.is_file():
        if summary_path.stat().st_size > MAX_SUMMARY_BYTES:
            raise ValueError(f"{summary_path}: larger than {MAX_SUMMARY_BYTES} bytes")
        summary = parse_json_object(summary_path.read_text(), str(summary_path))
    return Run(series=series, summary=summary, folder=folder)


def read_sweep(folder: str | os.PathLike) -> pd.DataFrame:
    """A sweep's folder (`dembuf sweep --out`, or a fetched sweep): sweep.csv, one row per
    run, as Client.sweep() gives it for a sweep on the daemon (`id`, the job's, is empty for
    a local run)."""
    csv = pathlib.Path(folder) / "sweep.csv"
    frame = pd.read_csv(csv, keep_default_na=False, na_values=[""])
    if "job" in frame.columns and "run" not in frame.columns:
        # A sweep.csv of an older dembuf: `job` counted the runs, `ok` was `done`.
        frame = frame.rename(columns={"job": "run"})
        frame.insert(1, "id", float("nan"))
        frame["status"] = frame["status"].replace({"ok": "done"})
    missing = [c for c in ["run", "id", "status", *_SWEEP_METRICS] if c not in frame.columns]
    if missing:
        raise ValueError(f"{csv}: no column {', '.join(missing)}")
    if "error" in frame:
        frame["error"] = frame["error"].fillna("").astype(str)
    else:
        frame["error"] = ""
    return frame.drop(columns=["run_dir"], errors="ignore")


def read_sweep_long(folder: str | os.PathLike) -> pd.DataFrame:
    """A sweep folder's sweep_long.csv (`dembuf sweep --long`, `dembuf fetch --sweep N
    --long`): every sample of every run that ended well, one row each, tidy: `run` (as in
    sweep.csv), the swept fields, then plate_force.csv's columns (t_s, plate_force_N, ...)."""
    csv = pathlib.Path(folder) / "sweep_long.csv"
    if not csv.exists():
        raise FileNotFoundError(f"{csv}: no long table; write it with `dembuf sweep --long` or "
                                "`dembuf fetch --sweep N --long`")
    return pd.read_csv(csv, keep_default_na=False, na_values=[""])


def sweep_axes(frame: pd.DataFrame) -> list[str]:
    """The swept fields of a sweep frame: its columns between `id` and `status`."""
    columns = list(frame.columns)
    return columns[columns.index("id") + 1:columns.index("status")]


def read_points(folder: str | os.PathLike) -> pd.DataFrame:
    """A sweep folder's points.csv, as dembuf computed it (the same rows as
    Client.sweep_points() for a sweep on the daemon): one row per point, with the swept
    values but bed.seed, `runs` (however they ended), and per metric M, over the runs that
    ended well: the mean `M`, the sample standard deviation `M_sd` (NaN for one run) and
    their number `M_n`. A points.csv of a dembuf before `runs` has the metrics alone."""
    return pd.read_csv(pathlib.Path(folder) / "points.csv", keep_default_na=False,
                       na_values=[""])
