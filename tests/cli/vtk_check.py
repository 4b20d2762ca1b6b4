"""Reads back dembuf's VTK XML files (paraview_test.sh): XML that parses, arrays of the sizes
their counts say, and values that agree with the run's other files. With python3-vtk9
installed, each .vtp is also read by VTK itself.

    vtk_check.py run RUN_DIR ANIMATION_INTERVAL_S
    vtk_check.py bed BED.vtp BED.txt BED.data
"""

import csv
import json
import math
import pathlib
import struct
import sys
import xml.etree.ElementTree as ET
import zlib

try:
    import vtk  # python3-vtk9
except ImportError:
    vtk = None

TYPES = {"Float64": "d", "Float32": "f", "Int32": "i", "Int64": "q", "UInt32": "I"}


def check(condition, what):
    if not condition:
        sys.exit(f"FAIL: {what}")


def read_vtp(path):
    """The piece's counts and arrays: {"points": [...], "PointData": {name: [...]}, ...}.
    dembuf writes its arrays zlib-compressed in an appended raw block; read here by hand,
    block by block, as the VTK file format describes it."""
    data = pathlib.Path(path).read_bytes()
    start = data.find(b"<AppendedData")
    check(start > 0, f"{path}: no appended data")
    underscore = data.index(b"_", data.index(b">", start))
    appended = data[underscore + 1:data.rfind(b"</AppendedData>")]
    root = ET.fromstring(data[:start] + b"</VTKFile>")
    check(root.get("type") == "PolyData" and root.get("header_type") == "UInt32", f"{path}: header")
    check(root.get("compressor") == "vtkZLibDataCompressor", f"{path}: compressor")
    order = "<" if root.get("byte_order") == "LittleEndian" else ">"
    piece = root.find("PolyData/Piece")
    out = {"n_points": int(piece.get("NumberOfPoints")), "bytes": len(data)}

    def decode(array):
        check(array.get("format") == "appended", f"{path}: {array.get('Name')}: format")
        at = int(array.get("offset"))
        blocks, block, last = struct.unpack(order + "3I", appended[at:at + 12])
        sizes = struct.unpack(f"{order}{blocks}I", appended[at + 12:at + 12 + 4 * blocks])
        raw, at = b"", at + 12 + 4 * blocks
        for k, size in enumerate(sizes):
            piece_bytes = zlib.decompress(appended[at:at + size])
            expected = last if k == blocks - 1 and last else block
            check(len(piece_bytes) == expected, f"{path}: {array.get('Name')}: block {k} size")
            raw += piece_bytes
            at += size
        code = TYPES[array.get("type")]
        values = struct.unpack(f"{order}{len(raw) // struct.calcsize(code)}{code}", raw)
        components = int(array.get("NumberOfComponents", "1"))
        check(len(values) % components == 0, f"{path}: {array.get('Name')}: components")
        return [values[i:i + components] for i in range(0, len(values), components)] \
            if components > 1 else list(values)

    out["points"] = decode(piece.find("Points/DataArray"))
    check(len(out["points"]) == out["n_points"], f"{path}: points")
    for group in ("PointData", "CellData"):
        out[group] = {a.get("Name"): decode(a) for a in piece.findall(f"{group}/DataArray")}
    for cells in ("Verts", "Lines", "Polys"):
        node = piece.find(cells)
        if node is not None:
            arrays = {a.get("Name"): decode(a) for a in node.findall("DataArray")}
            out[cells] = arrays
            check(len(arrays["offsets"]) == int(piece.get(f"NumberOf{cells}")),
                  f"{path}: {cells} count")
    if vtk is not None:
        reader = vtk.vtkXMLPolyDataReader()
        reader.SetFileName(str(path))
        reader.Update()
        data = reader.GetOutput()
        check(data.GetNumberOfPoints() == out["n_points"], f"{path}: VTK reads other points")
        for name, values in out["PointData"].items():
            array = data.GetPointData().GetArray(name)
            check(array is not None and array.GetNumberOfTuples() == len(values),
                  f"{path}: VTK reads no {name}")
    return out


def read_pvd(path):
    root = ET.parse(path).getroot()
    check(root.get("type") == "Collection", f"{path}: not a collection")
    return [(float(d.get("timestep")), int(d.get("part")), d.get("file"))
            for d in root.findall("Collection/DataSet")]


def close(a, b, rel=1e-8, abs_=1e-12):
    return abs(a - b) <= max(rel * max(abs(a), abs(b)), abs_)


def check_run(run, interval):
    run = pathlib.Path(run)
    summary = json.loads((run / "summary.json").read_text())
    beads = summary["beads"]
    # The container: the plate (one polygon at z = 0) and the wall (quads up to the rim).
    scene = summary["scene"]["cylinder"]
    box = read_vtp(run / "container.vtp")
    check(box["CellData"]["part"].count(0) == 1 and box["CellData"]["part"].count(1) > 8,
          "container: a plate and a wall")
    check(all(close(math.hypot(p[0], p[1]), scene["radius_m"], 1e-9) for p in box["points"]),
          "container: its points on the cylinder")
    check(sorted({p[2] for p in box["points"]}) == [0.0, scene["height_m"]], "container: height")
    # Snapshots: each listed three times (beads, contacts, the container) at its time.
    entries = read_pvd(run / "snapshots.pvd")
    snapshots = sorted(p for p in (run / "snapshots").iterdir())
    check(len(entries) == 3 * len(snapshots) and len(snapshots) == 2, "snapshots.pvd entries")
    check(sum(e[2] == "container.vtp" and e[1] == 2 for e in entries) == len(snapshots),
          "snapshots.pvd: the container as part 2")
    for folder in snapshots:
        meta = json.loads((folder / "snapshot.json").read_text())
        mine = [e for e in entries if e[2].startswith(f"snapshots/{folder.name}/")]
        check(sorted(e[1] for e in mine) == [0, 1], f"{folder.name}: parts")
        check(all(close(e[0], meta["t_s"], 1e-15) for e in mine), f"{folder.name}: time")
        b = read_vtp(folder / "beads.vtp")
        check(b["n_points"] == beads + 1 == meta["beads"] + 1, f"{folder.name}: point count")
        ids = b["PointData"]["id"]
        check(sorted(ids) == [-1, *range(beads)], f"{folder.name}: ids")
        for name, size in (("radius_m", 1), ("velocity_m_s", 3), ("force_N", 3)):
            values = b["PointData"][name]
            check(len(values) == b["n_points"], f"{folder.name}: {name} count")
        check(b["Verts"]["connectivity"] == list(range(b["n_points"])), "vertices")
        projectile = b["points"][ids.index(-1)]
        check(close(projectile[2], meta["projectile"]["z_m"], 1e-8), "projectile position")
        check(max(abs(v[2]) for v in b["PointData"]["velocity_m_s"]) > 0.01, "nothing moves")
        c = read_vtp(folder / "contacts.vtp")
        check(c["points"] == b["points"], f"{folder.name}: contacts' points")
        rows = list(csv.DictReader(open(folder / "contacts.csv")))
        pairs = [r for r in rows if r["b"].isdigit()]
        forces = c["CellData"]["normal_force_N"]
        check(len(forces) == len(pairs) == meta["bead_bead_contacts"] + sum(
            r["a"] == "projectile" for r in pairs), f"{folder.name}: {len(forces)} lines")
        for line, row in enumerate(pairs):
            check(close(forces[line], float(row["normal_N"]), 1e-8), "normal force")
            if row["a"].isdigit():
                a = b["points"][int(row["a"])]
                check(all(close(a[k], float(row["a" + "xyz"[k] + "_m"]), 1e-8) for k in range(3)),
                      f"{folder.name}: bead {row['a']}: position")
    # Frames: every interval from the start of the impact, each with every body.
    frames = read_pvd(run / "frames.pvd")
    check(sum(f[2] == "container.vtp" for f in frames) * 2 == len(frames), "frames: the container")
    frames = [f for f in frames if f[2] != "container.vtp"]
    times = [t for t, _, _ in frames]
    dt = summary["dt_s"]
    check(len(frames) >= 5, f"{len(frames)} frames")
    for k, t in enumerate(times):
        check(0 <= t - (times[0] + k * interval) < dt + 1e-12, f"frame {k} at {t}")
    first = read_vtp(run / frames[0][2])
    last = read_vtp(run / frames[-1][2])
    for f in (first, last):
        check(f["n_points"] == beads + 1 and sorted(f["PointData"]["id"]) == [-1, *range(beads)],
              "frame bodies")
    speed = first["PointData"]["velocity_m_s"][first["PointData"]["id"].index(-1)]
    check(close(math.dist(speed, (0, 0, 0)), summary["impact_speed_m_s"], 0.01),
          "the first frame's projectile speed is the impact speed")
    print(f"{len(snapshots)} snapshots and {len(frames)} frames read back"
          + (" (and by VTK)" if vtk else ""))


def check_bed(vtp, text, data):
    beads = [tuple(map(float, line.split())) for line in open(text) if not line.startswith("#")]
    b = read_vtp(vtp)
    check(b["n_points"] == len(beads), "vtp beads")
    for p, r, bead in zip(b["points"], b["PointData"]["radius_m"], beads):
        check(tuple(p) == bead[:3] and r == bead[3], "vtp against text")
    lines = open(data).read().split("\n")
    atoms = lines[lines.index("Atoms # sphere") + 2:]
    atoms = [a.split() for a in atoms[:len(beads)]]
    check(f"{len(beads)} atoms" in lines, "lammps atom count")
    for a, bead in zip(atoms, beads):
        check(float(a[2]) == 2 * bead[3] and tuple(map(float, a[4:7])) == bead[:3], "lammps atom")
    print(f"bed of {len(beads)} beads: .vtp, text and LAMMPS data agree")


if __name__ == "__main__":
    if sys.argv[1] == "run":
        check_run(sys.argv[2], float(sys.argv[3]))
    else:
        check_bed(*sys.argv[2:5])
