"""A hostile dembuf server for the client's tests (hostile_server_test.sh): it speaks the API of
proto/dembuf/v1 but answers with what a compromised daemon could send. Job N's result files
and sweep N's count are chosen by the id asked for (the table below). Prints its port, then
serves until killed. Usage: hostile_server.py PYTHON_PACKAGE_DIR"""
import sys
from concurrent import futures

sys.path.insert(0, sys.argv[1])
import grpc  # noqa: E402
from dembuf.v1 import dembuf_pb2 as pb  # noqa: E402
from dembuf.v1 import dembuf_pb2_grpc as pb_grpc  # noqa: E402

HOOK = b"[core]\n\tfsmonitor = touch PWNED\n"
# Job id -> the files its fetch is answered with, in order.
FILES = {
    1: [(".git/config", HOOK)],                              # runs at the next git status
    2: [(".envrc", b"touch PWNED\n")],                       # runs on entering the folder
    3: [("a", b"x"), ("a/b", b"y")],                         # a file, then a folder of it
    4: [("snapshots/.git/config", HOOK)],                    # hidden inside an allowed folder
    5: [("run.sh", b"touch PWNED\n")],                       # plain, but no result file
    6: [("snapshots.pvd", b"<VTKFile/>\n"),                  # what the API defines, in
        ("snapshots/peak/beads.vtp", b"<VTKFile/>\n")],      # path order
}
# Sweep id -> its jobs_total (sweeps 3 to 8 below).
JOBS_TOTAL = {1: -1, 2: 2_000_000_000}
# Job 7's summary: JSON nested 100,000 deep (the client's JSON library recursed on it).
DEEP_SUMMARY = "{\"a\": " * 100_000 + "1" + "}" * 100_000
# Job 8 is watched: 20 million samples, as fast as they go (a client kept every one).
WATCH_MESSAGES, WATCH_SAMPLES_PER_MESSAGE = 200, 100_000
# Job 9 announces a series of 2^62 samples and streams without end.
ENDLESS = 2**62
# Job 10's text fields, and every refusal of Cancel, carry terminal escape sequences: clear
# the screen, set the window title, and an OSC 52 write to the clipboard.
ESCAPES = "\x1b[2J\x1b]0;owned\x07\x1b]52;c;dG91Y2ggUFdORUQK\x07\u009b31m"
ESCAPES_JSON = "\\u001b[2J\\u001b]0;owned\\u0007"


class Hostile(pb_grpc.DembufServicer):
    def FetchResults(self, request, context):
        # Job 11's summary carries escapes in its provenance and warnings (for log.txt).
        summary = ('{"provenance": {"host": "' + ESCAPES_JSON + '"}, "warnings": ["'
                   + ESCAPES_JSON + '\\nwarning: forged"]}\n') if request.id == 11 else "{}\n"
        job = pb.Job(id=request.id, state=pb.JOB_STATE_DONE, owner="eve", name="job",
                     summary_json=summary)
        for path, data in FILES.get(request.id, []):
            job.files.add(path=path, size=len(data))
        return pb.FetchResultsResponse(job=job, series_length=ENDLESS if request.id == 9 else 0)

    def FetchSeries(self, request, context):
        chunk = pb.SeriesChunk(total=ENDLESS)
        chunk.samples.extend([pb.ForceSample(t_s=1.0)] * 10_000)
        first = 0
        while context.is_active():
            chunk.first_index = first
            yield chunk
            first += 10_000

    def GetJob(self, request, context):
        if request.id == 10:
            return pb.Job(id=10, state=pb.JOB_STATE_RUNNING, owner=ESCAPES, name=ESCAPES,
                          error=ESCAPES, scene_hash=ESCAPES, bed_hash=ESCAPES,
                          created_at=ESCAPES, started_at=ESCAPES, beds_prepared=[ESCAPES],
                          host=ESCAPES, slurm_job_id=1,
                          progress=pb.Progress(stage=ESCAPES))
        return pb.Job(id=request.id, state=pb.JOB_STATE_DONE, owner="eve", name="job",
                      summary_json=DEEP_SUMMARY if request.id == 7 else "{}")

    def Cancel(self, request, context):
        context.abort(grpc.StatusCode.NOT_FOUND, "no job " + ESCAPES)

    def WatchJob(self, request, context):
        message = pb.WatchJobResponse(state=pb.JOB_STATE_RUNNING)
        message.samples.extend([pb.ForceSample(t_s=1e-3, plate_force_N=1.0)] *
                               WATCH_SAMPLES_PER_MESSAGE)
        for k in range(WATCH_MESSAGES):
            message.first_index = k * WATCH_SAMPLES_PER_MESSAGE
            yield message
        yield pb.WatchJobResponse(first_index=WATCH_MESSAGES * WATCH_SAMPLES_PER_MESSAGE,
                                  state=pb.JOB_STATE_DONE)

    def ServerInfo(self, request, context):
        # An answer that inflates to 300 MB (a client blamed it on its own request).
        context.set_compression(grpc.Compression.Gzip)
        return pb.ServerInfoResponse(version="0" * (300 << 20))

    def FetchFiles(self, request, context):
        for path, data in FILES.get(request.id, []):
            yield pb.FileChunk(path=path, size=len(data), offset=0, data=data)

    def GetSweep(self, request, context):
        sweep = pb.Sweep(id=request.id, owner="eve", name="sweep",
                         jobs_total=JOBS_TOTAL.get(request.id, 0))
        if request.id == 3:  # one job, whose value is no value of its axis (an escape in it)
            sweep.jobs_total = 1
            sweep.axes.add(field="bed.thickness_m", values=["0.01"])
        if request.id == 4:  # aggregates nested 100,000 deep
            sweep.aggregates_json = DEEP_SUMMARY
        if request.id == 5:  # an Hc note with escapes
            sweep.aggregates_json = (
                '{"points": [], "critical_thickness": {"reached": false, "Hc_m": null, '
                '"note": "Hc ' + ESCAPES_JSON + ' not reached"}}')
        if request.id == 7:  # an Hc said reached, without its value
            sweep.aggregates_json = '{"points": [], "critical_thickness": {"reached": true}}'
        if request.id == 8:  # "reached" not a boolean
            sweep.aggregates_json = '{"points": [], "critical_thickness": {"reached": 1, "Hc_m": 2}}'
        if request.id == 6:  # points that are no table of numbers
            sweep.aggregates_json = '{"points": [{"runs": "rm -rf"}], "point_columns": ["runs"]}'
        return sweep

    def SubmitJob(self, request, context):
        # Every job answered with a stored result, --no-reuse or not.
        return pb.SubmitJobResponse(job=pb.Job(id=40, state=pb.JOB_STATE_DONE, owner="eve",
                                               name="j", reused_from=1))

    def ListJobs(self, request, context):
        if request.sweep_id == 3:
            return pb.ListJobsResponse(jobs=[pb.Job(
                id=30, state=pb.JOB_STATE_DONE, owner="eve", name="j", sweep_id=3,
                sweep_values=["0.01\x1b]52;c;dG91Y2gK\x07"])])
        return pb.ListJobsResponse()


server = grpc.server(futures.ThreadPoolExecutor(max_workers=4))
pb_grpc.add_DembufServicer_to_server(Hostile(), server)
port = server.add_insecure_port("127.0.0.1:0")
server.start()
print(port, flush=True)
server.wait_for_termination()
