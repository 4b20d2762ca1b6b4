"""dembuf from Python: submit impacts and sweeps to a dembufd, follow them live, and read
results, from the daemon or from a local run's folder, as pandas DataFrames.

    import dembuf
    with dembuf.connect() as daemon:        # $DEMBUF_SERVER, $DEMBUF_TOKEN, $DEMBUF_TLS_CA
        job = daemon.submit(preset="e2", scene={"bed": {"thickness_m": 0.02}})
        for sample in daemon.watch(job):
            print(sample.t_s, sample.plate_force_N)
        run = daemon.fetch(job)               # run.series: DataFrame; run.summary: dict
    local = dembuf.read_run("results/e2")    # the same from `dembuf run`'s folder
    frames = dembuf.read_pvd("results/e2/frames.pvd")  # animation frames: times and files
    beads = dembuf.read_vtp(frames.file.iloc[-1])        # one frame's beads as a DataFrame
"""

from .client import Client, DembufError, Sample, connect
from .frames import SERIES_COLUMNS, Run, read_points, read_run, read_sweep
from .vtp import read_contacts_vtp, read_pvd, read_vtp

__all__ = [
    "Client",
    "DembufError",
    "Run",
    "SERIES_COLUMNS",
    "Sample",
    "connect",
    "read_contacts_vtp",
    "read_points",
    "read_pvd",
    "read_run",
    "read_sweep",
    "read_vtp",
]
