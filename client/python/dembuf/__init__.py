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

from ._version import __version__
from .frames import SERIES_COLUMNS, Run, read_points, read_run, read_sweep, read_sweep_long
from .vtp import read_contacts_vtp, read_pvd, read_vtp

# The client of a dembufd needs grpcio and protobuf; the readers above do not. It is imported
# when first named (PEP 562), so that `import dembuf` works in a Python without gRPC.
_CLIENT_NAMES = ("Client", "DembufError", "Sample", "connect")


def __getattr__(name):
    if name not in _CLIENT_NAMES:
        raise AttributeError(f"module 'dembuf' has no attribute {name!r}")
    try:
        from . import client
    except ImportError as e:
        missing = getattr(e, "name", None) or str(e)
        raise ImportError(
            f"dembuf.{name} talks to a dembufd and needs grpcio and protobuf ({missing} is "
            "missing): install the dembuf wheel with its server extra (pip install "
            "'dembuf-VERSION-py3-none-any.whl[server]'), or on Debian apt install "
            "python3-grpcio python3-protobuf; dembuf.read_run and the other readers work "
            "without them"
        ) from e
    return getattr(client, name)


__all__ = [
    "Client",
    "DembufError",
    "Run",
    "SERIES_COLUMNS",
    "Sample",
    "__version__",
    "connect",
    "read_contacts_vtp",
    "read_points",
    "read_pvd",
    "read_run",
    "read_sweep",
    "read_sweep_long",
    "read_vtp",
]
