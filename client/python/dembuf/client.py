"""A connection to a dembufd: the same address, token and TLS settings as the `dembuf` CLI."""

from __future__ import annotations

import math
import os
import pwd
import pathlib
import re
import sys
import time
import uuid
import warnings
from typing import Iterator, Mapping, NamedTuple, Sequence

import grpc
import pandas as pd
from google.protobuf import json_format

from . import frames
from .v1 import dembuf_pb2 as pb
from .v1 import dembuf_pb2_grpc as pb_grpc

_FINAL_STATES = {pb.JOB_STATE_DONE, pb.JOB_STATE_FAILED, pb.JOB_STATE_CANCELLED}

# What a server's answers may be: identity only, and at most as large as the CLI takes. gRPC
# inflates a compressed message whole before it looks at its size, and it refuses a compressed
# answer only by its header: it is also told not to inflate any message at all.
_CHANNEL_OPTIONS = [("grpc.compression_enabled_algorithms_bitset", 1),
                    ("grpc.per_message_decompression", 0),
                    ("grpc.max_receive_message_length", 128 << 20)]
# The longest series series() keeps in memory (a job's is at most the daemon's quota_samples,
# a million by default); `dembuf fetch` streams longer ones to a file.
MAX_SERIES_SAMPLES = 20_000_000


def _read_table(path: str | os.PathLike) -> pd.DataFrame:
    """A table file by `dembuf sweep --table`'s rules: `#` lines and blank lines skipped, the
    header's tabs (else commas) separate the columns, every value text (the daemon checks
    them)."""
    lines = [line for line in pathlib.Path(path).read_text().splitlines()
             if line.strip() and not line.startswith("#")]
    if not lines:
        raise ValueError(f"{path}: needs a header of field names and a row per point")
    sep = "\t" if "\t" in lines[0] else ","
    rows = [[cell.strip(" ") for cell in line.split(sep)] for line in lines]
    return pd.DataFrame(rows[1:], columns=rows[0], dtype=str)


class DembufError(Exception):
    """A refused or failed call: `code` is the gRPC status name ("NOT_FOUND", ...), the
    message the daemon's reason ("id: no job 99")."""

    def __init__(self, code: str, message: str):
        super().__init__(f"{code}: {message}")
        self.code = code
        self.message = message


class Sample(NamedTuple):
    """One written sample of a run, a row of plate_force.csv (SI units)."""

    t_s: float
    plate_force_N: float
    wall_force_z_N: float
    proj_z_m: float
    proj_vz_m_s: float
    proj_force_z_N: float


def _local_user_name() -> str:
    """Who this process runs as, the CLI's rule: $USER, else $LOGNAME, else the name of its
    user id, else "anonymous" (a container's uid may have none)."""
    for name in ("USER", "LOGNAME"):
        if os.environ.get(name):
            return os.environ[name]
    try:
        return pwd.getpwuid(os.getuid()).pw_name or "anonymous"
    except KeyError:
        return "anonymous"


def state_name(state: int) -> str:
    """"done", "preparing_bed", ... as the JSON output and the web API say it."""
    return pb.JobState.Name(state).removeprefix("JOB_STATE_").lower()


_MAX_COMMAND_LINE = 4096  # what the daemon keeps


def _shell_word(word: str) -> str:
    """The word as the CLI writes its own arguments: bare, '...', or $'...' with \\xHH escapes,
    always ASCII."""
    if word and re.fullmatch(r"[A-Za-z0-9%+,\-./:=@_]+", word):
        return word
    if all(" " <= c <= "~" for c in word):
        return "'" + word.replace("'", "'\\''") + "'"
    escaped = "".join(
        "\\" + chr(b) if chr(b) in "\\'" else chr(b) if 0x20 <= b < 0x7f else f"\\x{b:02x}"
        for b in word.encode("utf-8", "surrogateescape"))
    return "$'" + escaped + "'"


def command_line() -> str:
    """This program's command line, sent with jobs as provenance (summary.json keeps it)."""
    words = [sys.executable or "python3", *sys.argv] if sys.argv and sys.argv[0] else ["python3"]
    return " ".join(_shell_word(w) for w in words)[:_MAX_COMMAND_LINE]


def _message_dict(message) -> dict:
    return json_format.MessageToDict(message, preserving_proto_field_name=True)


def _flat_fields(scene: Mapping, prefix: str = "") -> Iterator[tuple[str, str]]:
    """A nested scene ({"bed": {"thickness_m": 0.02}}) as dotted fields and TOML values."""
    for key, value in scene.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping):
            yield from _flat_fields(value, name + ".")
        elif isinstance(value, bool):
            yield name, "true" if value else "false"
        elif isinstance(value, (list, tuple)):
            yield name, "[" + ", ".join(repr(v) if isinstance(v, (int, float)) else
                                        '"' + str(v) + '"' for v in value) + "]"
        else:
            yield name, repr(value) if isinstance(value, float) else str(value)


def _typed(value: str):
    """A swept value as read_sweep's CSV reader types it: an int, a float, else the text
    (bed.seed 2, not 2.0; bed.cut "tops", which float() refused)."""
    for kind in (int, float):
        try:
            return kind(value)
        except ValueError:
            pass
    return value


def _server_json(text: str, what: str,
                 max_bytes: int = frames.MAX_SUMMARY_BYTES) -> dict | None:
    """A JSON object a server sent as text (a summary, a sweep's aggregates); None for none."""
    try:
        return frames.parse_json_object(text, what, max_bytes) or None
    except ValueError as e:
        raise DembufError("DATA_LOSS", f"the server sent {e}") from None


def _job_json(j, details: bool = True) -> dict:
    """A job as `dembuf status --json` writes it, or `dembuf list --json` without `details`
    (proto/json/api_json.cpp, field by field)."""
    p = j.progress
    return {
        "id": j.id, "name": j.name, "owner": j.owner, "state": state_name(j.state),
        "error": j.error or None, "sweep_id": j.sweep_id or None, "sweep_index": j.sweep_index,
        "sweep_values": [_typed(v) for v in j.sweep_values], "attempts": j.attempts,
        "created_at": j.created_at or None, "started_at": j.started_at or None,
        "finished_at": j.finished_at or None, "host": j.host, "code_version": j.code_version,
        "command_line": j.command_line,
        "progress": {"stage": p.stage, "fraction": p.fraction, "sim_time_s": p.sim_time_s,
                     "steps": p.steps, "peak_plate_force_N": p.peak_plate_force_N},
        # (A number that is not finite is null, as in JSON.)
        "peak_plate_force_N": (p.peak_plate_force_N if 0 < p.peak_plate_force_N < math.inf
                               else None),
        "P_N": j.P_N if j.HasField("P_N") and math.isfinite(j.P_N) else None,
        "slurm_job_id": j.slurm_job_id or None,
        "slurm_array_task": j.slurm_array_task if j.HasField("slurm_array_task") else None,
        "reused_from": j.reused_from or None,
    } | ({
        "scene_toml": j.scene_toml, "scene_hash": j.scene_hash, "bed_hash": j.bed_hash,
        "summary": _server_json(j.summary_json, f"job {j.id}'s summary_json"),
        "files": [{"path": f.path, "size": f.size} for f in j.files],
        "beds_prepared": list(j.beds_prepared),
    } if details else {})


def _sample(s: pb.ForceSample) -> Sample:
    return Sample(s.t_s, s.plate_force_N, s.wall_force_z_N, s.proj_z_m, s.proj_vz_m_s,
                  s.proj_force_z_N)


class Client:
    """A dembufd. Arguments left out come from $DEMBUF_SERVER (else 127.0.0.1:50051),
    $DEMBUF_TOKEN and $DEMBUF_TLS_CA; without a token, jobs are filed under `owner`, else
    $USER, $LOGNAME or the user id's name (else "anonymous"), as the CLI does."""

    def __init__(self, address: str | None = None, token: str | None = None,
                 tls_ca: str | os.PathLike | None = None, owner: str | None = None,
                 timeout_s: float = 60.0):
        self.address = address or os.environ.get("DEMBUF_SERVER") or "127.0.0.1:50051"
        self._token = token or os.environ.get("DEMBUF_TOKEN") or ""
        tls_ca = tls_ca or os.environ.get("DEMBUF_TLS_CA")
        self.owner = owner or ("" if self._token else _local_user_name())
        self.timeout_s = timeout_s
        if tls_ca:
            pem = pathlib.Path(tls_ca).read_bytes()
            self._channel = grpc.secure_channel(self.address, grpc.ssl_channel_credentials(pem),
                                                options=_CHANNEL_OPTIONS)
        else:
            self._channel = grpc.insecure_channel(self.address, options=_CHANNEL_OPTIONS)
        self._stub = pb_grpc.DembufStub(self._channel)

    # -- plumbing ------------------------------------------------------------------------------

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _metadata(self):
        return [("authorization", "Bearer " + self._token)] if self._token else None

    def _error(self, e: grpc.RpcError) -> DembufError:
        details = e.details() or ""
        if "ompress" in details or "deserializing response" in details:
            details = (f"the server at {self.address} sent a compressed answer, which this "
                       f"client does not take ({details})")
        return DembufError(e.code().name, details)

    def _call(self, method, request, streaming: bool = False):
        # Streams have no deadline: a watch lasts as long as its job.
        try:
            if streaming:
                return method(request, metadata=self._metadata())
            return method(request, metadata=self._metadata(), timeout=self.timeout_s)
        except grpc.RpcError as e:
            raise self._error(e) from None

    def _submit(self, method, request):
        """Sends a submission with a request id of its own, and sends it again (twice at
        most) while the daemon cannot be reached or does not answer in time: a reply lost on
        the way does not file the work twice, since the daemon files a request id once."""
        request.request_id = uuid.uuid4().hex
        for attempt in range(3):
            if attempt:
                time.sleep(0.5 * attempt)
            try:
                return method(request, metadata=self._metadata(), timeout=self.timeout_s)
            except grpc.RpcError as e:
                retry = e.code() in (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED)
                if not retry or attempt == 2:
                    raise self._error(e) from None

    def _stream(self, method, request):
        try:
            yield from method(request, metadata=self._metadata())
        except grpc.RpcError as e:
            raise self._error(e) from None

    # -- submitting ----------------------------------------------------------------------------

    @staticmethod
    def _scene_spec(preset: str, scene: Mapping | None, toml: str | os.PathLike | None,
                    set: Sequence[str] | Mapping[str, object] | None,
                    accuracy: str) -> pb.SceneSpec:
        spec = pb.SceneSpec(preset=preset, accuracy=accuracy)
        if toml is not None:
            # A path to a scene file, or the text of one.
            text = str(toml)
            path = pathlib.Path(text) if "\n" not in text and len(text) < 4096 else None
            spec.scene_toml = path.read_text() if path and path.is_file() else text
        # The scene's fields as the CLI's --set, by their dotted names: the daemon checks them
        # and names a wrong one as a scene file would ("bed.thicknes_m"), not as the proto.
        if scene:
            spec.set.extend(f"{field}={value}" for field, value in _flat_fields(scene))
        if set:
            items = set.items() if isinstance(set, Mapping) else (s.split("=", 1) for s in set)
            spec.set.extend(f"{field}={value}" for field, value in items)
        return spec

    def send_bed_file(self, path: str | os.PathLike) -> str:
        """Sends a bed file (text, LAMMPS data or dump) to the daemon, which keeps it for
        this user's jobs; returns its SHA-256, which a scene names as its bed file. The
        daemon checks it as an import when a job names it."""
        data = pathlib.Path(path).read_bytes()
        name = re.sub(r"[^A-Za-z0-9._-]", "_", pathlib.Path(path).name)[:100]
        if not name or name.startswith("."):
            name = "bed" + name
        piece = 256 << 10  # as the daemon takes them
        pieces = [pb.BedPiece(kind="file", name=name, size=len(data), owner=self.owner,
                              data=data[:piece])]
        pieces += [pb.BedPiece(data=data[i:i + piece]) for i in range(piece, len(data), piece)]
        try:
            answer = self._stub.PushBed(iter(pieces), metadata=self._metadata(),
                                        timeout=max(self.timeout_s, 600))
        except grpc.RpcError as e:
            raise self._error(e) from None
        return answer.hash

    def submit(self, preset: str = "", scene: Mapping | None = None,
               toml: str | os.PathLike | None = None,
               set: Sequence[str] | Mapping[str, object] | None = None, accuracy: str = "",
               name: str = "", bed_file: str | os.PathLike | None = None,
               notify: bool = False, reuse: bool = True) -> int:
        """Submits one impact; returns its job id. The scene is built as the CLI builds it:
        the preset, the scene file (`toml`: a path or its text), the accuracy, the fields of
        `scene` (nested as a scene file: {"bed": {"thickness_m": 0.02}}), then `set`
        ({"time.end_s": 0.1} or ["time.end_s=0.1"]). `bed_file`: a bed file on this machine
        to import (sent with the job, as bed.import). `notify`: the daemon's chat hook tells
        of the job's end (refused, INVALID_ARGUMENT, by a daemon without one). `reuse`:
        a stored result of the same scene, seed, bed file and engine that you may read answers
        the job at once (job(id)["reused_from"] names it); False runs it anyway. Physically
        odd input comes back as warnings (UserWarning)."""
        request = pb.SubmitJobRequest(scene=self._scene_spec(preset, scene, toml, set, accuracy),
                                      name=name, owner=self.owner, command_line=command_line(),
                                      notify=notify, no_reuse=not reuse)
        if bed_file is not None:
            request.scene.bed_file = self.send_bed_file(bed_file)
        answer = self._submit(self._stub.SubmitJob, request)
        for warning in answer.warnings:
            warnings.warn(f"job {answer.job.id}: {warning}", stacklevel=2)
        return answer.job.id

    def submit_sweep(self, axes: Mapping[str, str | Sequence[object]] | None = None,
                     seeds: int = 1, preset: str = "", scene: Mapping | None = None,
                     toml: str | os.PathLike | None = None,
                     set: Sequence[str] | Mapping[str, object] | None = None,
                     accuracy: str = "", name: str = "",
                     bed_file: str | os.PathLike | None = None,
                     table: "pd.DataFrame | str | os.PathLike | None" = None,
                     notify: bool = False, reuse: bool = True) -> int:
        """Submits a sweep; returns its id. `axes` maps a scene field to its values, a list
        or a "START:STOP:STEP" range (inclusive): {"bed.thickness_m": "0:0.08:0.005"}.
        `table` gives chosen points instead or as well (as `dembuf sweep --table`): a
        DataFrame whose columns are scene fields and whose rows are points, or a file of them
        (tab- or comma-separated, a header of field names); its rows are multiplied by the
        axes. Each point runs on bed seeds 1..seeds (unless bed.seed is a column or an axis),
        its jobs sharing their beds; with `bed_file`, every point imports that file.
        `notify` and `reuse` as submit's, for the sweep's end and for each of its jobs."""
        request = pb.SubmitSweepRequest(
            base=self._scene_spec(preset, scene, toml, set, accuracy), seeds=seeds, name=name,
            owner=self.owner, command_line=command_line(), notify=notify, no_reuse=not reuse)
        if bed_file is not None:
            request.base.bed_file = self.send_bed_file(bed_file)
        if table is not None:
            points = table if isinstance(table, pd.DataFrame) else _read_table(table)
            request.table.fields.extend(str(c) for c in points.columns)
            for row in points.itertuples(index=False):
                request.table.rows.add(values=[str(v) for v in row])
        for field, values in (axes or {}).items():
            if isinstance(values, str):
                request.axes.add(field=field, range=values)
            else:
                request.axes.add(field=field, values=[str(v) for v in values])
        answer = self._submit(self._stub.SubmitSweep, request)
        for warning in answer.warnings:
            warnings.warn(f"sweep {answer.sweep.id}: {warning}", stacklevel=2)
        return answer.sweep.id

    def cancel(self, job: int | None = None, sweep: int | None = None) -> int:
        """Cancels a job or every unfinished job of a sweep; returns how many."""
        request = pb.CancelRequest(job_id=job or 0, sweep_id=sweep or 0)
        return self._call(self._stub.Cancel, request).cancelled

    def delete(self, job: int | None = None, sweep: int | None = None) -> int:
        """Deletes an ended job, or a sweep whose jobs have all ended with its jobs, and what
        the daemon stores of them (their results count against the user's quota_stored_mb);
        returns how many jobs."""
        request = pb.DeleteRequest(job_id=job or 0, sweep_id=sweep or 0)
        return self._call(self._stub.Delete, request).deleted

    # -- following -----------------------------------------------------------------------------

    def job(self, job: int) -> dict:
        """The job as the daemon knows it, in the shape of `dembuf status --json` and
        /api/jobs/ID: id, name, owner, state ("done"), error, sweep_id (None for a single
        job), times (None until they happen), progress, peak_plate_force_N and P_N, the
        scene, the summary (a dict), the files and the beds it prepared."""
        return _job_json(self._call(self._stub.GetJob, pb.GetJobRequest(id=job)))

    def jobs(self, sweep: int = 0, owner: str = "", limit: int = 100) -> pd.DataFrame:
        """Jobs, newest first, one row each, with the columns of `dembuf list --json`'s jobs:
        id, name, owner, state, error, sweep_id (None for a single job), times (None until
        they happen), progress, ..."""
        answer = self._call(self._stub.ListJobs,
                            pb.ListJobsRequest(sweep_id=sweep, owner=owner, limit=limit))
        rows = [_job_json(j, details=False) for j in answer.jobs]
        columns = list(_job_json(pb.Job(), details=False))
        # Object columns, so that None stays None (pandas makes a number column's None NaN).
        return pd.DataFrame(rows, columns=columns, dtype=object)

    def watch(self, job: int, from_index: int = 0) -> Iterator[Sample]:
        """The job's samples: those computed so far, then the live ones as they come, until
        the job ends. Ask wait() or job() how it ended."""
        request = pb.WatchJobRequest(id=job, from_index=from_index)
        for message in self._stream(self._stub.WatchJob, request):
            for s in message.samples:
                yield _sample(s)

    def wait(self, job: int, timeout_s: float | None = None, poll_s: float = 0.5) -> str:
        """Waits for the job to end; returns its final state ("done", "failed",
        "cancelled"). Raises TimeoutError after timeout_s."""
        start = time.monotonic()
        while True:
            message = self._call(self._stub.GetJob, pb.GetJobRequest(id=job))
            if message.state in _FINAL_STATES:
                return state_name(message.state)
            if timeout_s is not None and time.monotonic() - start > timeout_s:
                raise TimeoutError(f"job {job} is still {state_name(message.state)} "
                                   f"after {timeout_s} s")
            time.sleep(poll_s)

    # -- results -------------------------------------------------------------------------------

    def series(self, job: int) -> pd.DataFrame:
        """A finished job's F(t): the columns of plate_force.csv, fetched in pieces (a series
        of any length stays under gRPC's message limit). What the server announces is checked
        before anything is kept: at most MAX_SERIES_SAMPLES samples, each once, in order."""
        import numpy as np
        values = None
        next_index = total = 0
        for chunk in self._stream(self._stub.FetchSeries, pb.FetchSeriesRequest(id=job)):
            if values is None:
                total = chunk.total
                if not 0 <= total <= MAX_SERIES_SAMPLES:
                    raise DembufError("DATA_LOSS", f"the server at {self.address} announced "
                                      f"{total} samples for job {job}; series() keeps at most "
                                      f"{MAX_SERIES_SAMPLES} (dembuf fetch writes longer ones "
                                      f"to a file)")
                values = np.empty((total, len(frames.SERIES_COLUMNS)))
            if chunk.total != total or chunk.first_index != next_index or \
                    len(chunk.samples) > total - next_index:
                raise DembufError("DATA_LOSS", f"the server at {self.address} sent job {job}'s "
                                  f"samples out of order, or more than its {total}")
            for k, s in enumerate(chunk.samples):
                values[next_index + k] = _sample(s)
            next_index += len(chunk.samples)
        if next_index != total:
            raise DembufError("DATA_LOSS", f"job {job}: {next_index} of {total} samples came")
        if values is None:
            values = np.empty((0, len(frames.SERIES_COLUMNS)))
        return frames.series_frame({name: values[:, k]
                                    for k, name in enumerate(frames.SERIES_COLUMNS)})

    def fetch(self, job: int) -> frames.Run:
        """A finished job: its series (DataFrame), its summary.json (dict; empty for a job that
        did not finish well) and the job (dict)."""
        info = self.job(job)
        return frames.Run(series=self.series(job), summary=info["summary"] or {}, job=info)

    def sweep(self, sweep: int) -> pd.DataFrame:
        """A sweep as sweep.csv has it, one row per job: run (its index in the sweep), id (the
        job's), the swept fields, status (the job's state: "done", "failed", ...), the
        summary's metrics, error. sweep_points() gives its points over the bed seeds."""
        info = self._call(self._stub.GetSweep, pb.GetSweepRequest(id=sweep))
        answer = self._call(self._stub.ListJobs,
                            pb.ListJobsRequest(sweep_id=sweep, limit=info.jobs_total or 100))
        axes = [axis.field for axis in info.axes]
        rows = []
        for j in sorted(answer.jobs, key=lambda j: (j.sweep_index, j.id)):
            if len(j.sweep_values) != len(axes):
                raise DembufError("DATA_LOSS", f"job {j.id}: {len(j.sweep_values)} sweep "
                                  f"values for {len(axes)} axes")
            # (A listing carries no summaries: each finished job's comes by itself.)
            summary = {}
            if j.state == pb.JOB_STATE_DONE:
                full = self._call(self._stub.GetJob, pb.GetJobRequest(id=j.id))
                try:
                    summary = frames.parse_json_object(full.summary_json,
                                                   f"job {j.id}'s summary_json")
                except ValueError as e:
                    raise DembufError("DATA_LOSS", f"the server sent {e}") from None
            rows.append({"run": j.sweep_index, "id": j.id,
                         **dict(zip(axes, (_typed(v) for v in j.sweep_values))),
                         "status": state_name(j.state), **frames.metrics_of(summary),
                         "error": j.error})
        return pd.DataFrame(rows, columns=["run", "id", *axes, "status",
                                           *frames.sweep_metric_names(), "error"])

    def sweep_points(self, sweep: int) -> pd.DataFrame:
        """The sweep's points as the daemon computed them from the jobs done so far, the rows
        of a fetched sweep's points.csv (read_points): the swept values but bed.seed, `runs`,
        and per metric M its mean `M`, sample standard deviation `M_sd` (NaN for one run)
        and number `M_n` over the runs that ended well."""
        info = self._call(self._stub.GetSweep, pb.GetSweepRequest(id=sweep, aggregates=True))
        aggregates = _server_json(info.aggregates_json, f"sweep {sweep}'s aggregates_json",
                                  frames.MAX_AGGREGATES_BYTES)
        points = (aggregates or {}).get("points")
        columns = (aggregates or {}).get("point_columns")
        if not isinstance(points, list) or not isinstance(columns, list) or "runs" not in columns:
            raise DembufError("DATA_LOSS", f"the server sent sweep {sweep} without its points")
        try:
            frame = pd.DataFrame(points, columns=columns)
            # The counts and metrics as numbers, a value not known NaN, as read_points has them.
            for column in columns[columns.index("runs"):]:
                frame[column] = pd.to_numeric(frame[column])
        except (ValueError, TypeError) as e:
            raise DembufError("DATA_LOSS", f"the server sent sweep {sweep}'s points "
                              f"that are not a table of numbers: {e}") from None
        return frame

    def server_info(self) -> dict:
        return _message_dict(self._call(self._stub.ServerInfo, pb.ServerInfoRequest()))


def connect(address: str | None = None, token: str | None = None,
            tls_ca: str | os.PathLike | None = None, owner: str | None = None) -> Client:
    """A Client (see there for the defaults from the environment)."""
    return Client(address, token, tls_ca, owner)
