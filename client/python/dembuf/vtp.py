"""dembuf's VTK XML files as pandas objects: a snapshot's or frame's beads (.vtp) as a
DataFrame, a .pvd collection as a list of times and files. For analysis in Python without
VTK; ParaView opens the same files directly."""

from __future__ import annotations

import base64
import os
import pathlib
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pandas as pd

_TYPES = {"Float64": "f8", "Float32": "f4", "Int32": "i4", "Int64": "i8", "UInt32": "u4"}
_MAX_FILE_BYTES = 1 << 30  # a frame of a million beads is about 125 MB


class _File:
    """A VTK XML file's tree and the bytes of its arrays: inline base64, or appended raw
    (what dembuf writes), zlib-compressed or not."""

    def __init__(self, path: pathlib.Path):
        if path.stat().st_size > _MAX_FILE_BYTES:
            raise ValueError(f"{path}: larger than {_MAX_FILE_BYTES} bytes")
        data = path.read_bytes()
        self.path = path
        self.appended = b""
        start = data.find(b"<AppendedData")
        if start >= 0:
            # The block after '_' is raw bytes, not XML: the tree is read without it.
            underscore = data.index(b"_", data.index(b">", start))
            end = data.rfind(b"</AppendedData>")
            if end < underscore:
                raise ValueError(f"{path}: its appended data does not end")
            self.appended = data[underscore + 1:end]  # arrays lie at their offsets in it
            data = data[:start] + b"</VTKFile>"
        self.root = ET.fromstring(data)
        self.order = "<" if self.root.get("byte_order") == "LittleEndian" else ">"
        self.header = self.order + ("u8" if self.root.get("header_type") == "UInt64" else "u4")
        self.compressed = self.root.get("compressor") == "vtkZLibDataCompressor"
        if self.root.get("compressor") not in (None, "vtkZLibDataCompressor"):
            raise ValueError(f"{path}: compressor {self.root.get('compressor')} is not zlib")

    def _take(self, raw: bytes, name: str) -> bytes:
        """An array's bytes from its header onwards (raw may run past its end)."""
        width = np.dtype(self.header).itemsize
        if not self.compressed:
            size = int(np.frombuffer(raw[:width], dtype=self.header)[0])
            if size > len(raw) - width:
                raise ValueError(f"{self.path}: array {name}: {len(raw) - width} bytes, "
                                 f"its header says {size}")
            return raw[width:width + size]
        blocks, block, last = (int(v) for v in np.frombuffer(raw[:3 * width], dtype=self.header))
        sizes = np.frombuffer(raw[3 * width:(3 + blocks) * width], dtype=self.header)
        out, at = [], (3 + blocks) * width
        for k, size in enumerate(sizes):
            piece = zlib.decompress(raw[at:at + int(size)])
            expected = last if k == blocks - 1 and last else block
            if len(piece) != expected:
                raise ValueError(f"{self.path}: array {name}: block {k} holds {len(piece)} "
                                 f"bytes, its header says {expected}")
            out.append(piece)
            at += int(size)
        return b"".join(out)

    def array(self, array: ET.Element) -> np.ndarray:
        name = array.get("Name")
        if array.get("format") == "appended":
            raw = self._take(self.appended[int(array.get("offset")):], name)
        else:
            raw = self._take(base64.b64decode(array.text or ""), name)
        values = np.frombuffer(raw, dtype=self.order + _TYPES[array.get("type")])
        components = int(array.get("NumberOfComponents", "1"))
        return values.reshape(-1, components) if components > 1 else values


def _piece(path: pathlib.Path) -> tuple[ET.Element, _File]:
    """The PolyData piece of a .vtp file (bounded in size) and the file, which decodes its
    arrays."""
    file = _File(path)
    if file.root.get("type") != "PolyData":
        raise ValueError(f"{path}: not VTK PolyData")
    return file.root.find("PolyData/Piece"), file


def read_vtp(path: str | os.PathLike) -> pd.DataFrame:
    """The points of a dembuf .vtp (beads.vtp, frames/frame_NNNNN.vtp, an exported bed): one
    row per body with x_m, y_m, z_m and the point arrays (radius_m, velocity_m_s as vx, vy,
    vz, id, species (1, 2, 3 as the scene numbers them), force_N as fx, fy, fz); the
    projectile is the row with id -1 (species 0). A contacts.vtp's
    contacts are its lines: read_contacts_vtp."""
    path = pathlib.Path(path)
    piece, file = _piece(path)
    points = file.array(piece.find("Points/DataArray"))
    frame = pd.DataFrame(points, columns=["x_m", "y_m", "z_m"])
    names = {"velocity_m_s": ["vx_m_s", "vy_m_s", "vz_m_s"], "force_N": ["fx_N", "fy_N", "fz_N"]}
    for array in piece.findall("PointData/DataArray"):
        values = file.array(array)
        name = array.get("Name")
        if values.ndim == 2:
            for k, column in enumerate(names.get(name, [f"{name}_{i}" for i in range(3)])):
                frame[column] = values[:, k]
        else:
            frame[name] = values
    return frame


def read_contacts_vtp(path: str | os.PathLike) -> pd.DataFrame:
    """The lines of a dembuf .vtp (a snapshot's contacts.vtp): one row per contact with its
    two ends (x1_m, y1_m, z1_m, x2_m, y2_m, z2_m) and its cell arrays (normal_force_N, ...).
    A file without lines gives no rows."""
    path = pathlib.Path(path)
    piece, file = _piece(path)
    columns = ["x1_m", "y1_m", "z1_m", "x2_m", "y2_m", "z2_m"]
    lines = piece.find("Lines")
    if lines is None or int(piece.get("NumberOfLines", "0")) == 0:
        return pd.DataFrame(columns=columns)
    points = file.array(piece.find("Points/DataArray")).reshape(-1, 3)
    arrays = {a.get("Name"): a for a in lines.findall("DataArray")}
    connectivity = file.array(arrays["connectivity"]).astype(np.int64)
    offsets = file.array(arrays["offsets"]).astype(np.int64)
    starts = np.concatenate(([0], offsets[:-1]))
    if np.any(offsets - starts != 2) or offsets[-1] != len(connectivity) or \
            connectivity.size and (connectivity.min() < 0 or connectivity.max() >= len(points)):
        raise ValueError(f"{path}: its lines are not pairs of its points")
    ends = points[connectivity].reshape(-1, 6)
    frame = pd.DataFrame(ends, columns=columns)
    for array in piece.findall("CellData/DataArray"):
        values = file.array(array)
        if len(values) != len(frame):
            raise ValueError(f"{path}: cell array {array.get('Name')} has {len(values)} values "
                             f"for {len(frame)} lines")
        if values.ndim == 2:
            for k in range(values.shape[1]):
                frame[f"{array.get('Name')}_{k}"] = values[:, k]
        else:
            frame[array.get("Name")] = values
    return frame


def read_pvd(path: str | os.PathLike) -> pd.DataFrame:
    """A .pvd collection (snapshots.pvd, frames.pvd): one row per file, with its time t_s,
    its part and its path (made absolute), in time order."""
    path = pathlib.Path(path)
    root = ET.parse(path).getroot()
    if root.get("type") != "Collection":
        raise ValueError(f"{path}: not a VTK collection")
    rows = [{"t_s": float(d.get("timestep")), "part": int(d.get("part", "0")),
             "file": path.parent / d.get("file")} for d in root.findall("Collection/DataSet")]
    return pd.DataFrame(rows, columns=["t_s", "part", "file"]).sort_values("t_s", kind="stable")
