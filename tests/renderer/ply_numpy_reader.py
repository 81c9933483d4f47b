#!/usr/bin/env python3
"""An independent PLY reader for tests/renderer/test_ply_reader.cpp, written with numpy.

    ply_numpy_reader.py OUT FILE.ply [FILE.ply.gz ...]

Reads each file as the PLY specification describes it (header; then each element's records in
header order) and writes to OUT, for each in turn, what Tessera's load_ply (renderer/
mesh_io.h) must return for it: positions, normals (nx/ny/nz), uvs (the first of u/v, s/t,
texture_u/texture_v, texture_s/texture_t, as pbrt-v4 takes them), triangles (faces with 3 or
more vertices fanned from their first vertex), the face each triangle comes from and the
per-face "face_indices" per triangle. A file it cannot read gets "error <why>" instead.

Output per file: a line "mesh", then one line "name dtype count" per array followed by count
little-endian values of dtype (f4, u4 or i4), then a line "end". Binary elements without lists
are decoded as numpy structured arrays; lists record by record, or as one structured array when
every list of an element has the same length (checked). Exits 77 when numpy is missing, so that
the test can skip.
"""
import gzip
import sys

try:
    import numpy as np
except ImportError:
    print("ply_numpy_reader.py: numpy not found", file=sys.stderr)
    sys.exit(77)

TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
UV_NAMES = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")]


class PlyError(Exception):
    pass


def parse_header(data):
    """Returns (format, elements, body offset); elements are (name, count, [properties]) and a
    property is (name, type) or (name, count type, item type)."""
    pos = 0
    lines = []
    while True:
        nl = data.find(b"\n", pos)
        if nl < 0:
            raise PlyError("no end_header")
        line = data[pos:nl].rstrip(b"\r").decode("latin-1")
        pos = nl + 1
        lines.append(line)
        if line.split() == ["end_header"]:
            break
    if lines[0] != "ply":
        raise PlyError("not ply")
    fmt, elements = None, []
    for line in lines[1:]:
        w = line.split()
        if not w or w[0] in ("comment", "obj_info", "end_header"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            if w[1] == "list":
                elements[-1][2].append((w[4], TYPES[w[2]], TYPES[w[3]]))
            else:
                elements[-1][2].append((w[2], TYPES[w[1]]))
        else:
            raise PlyError("bad header line " + line)
    return fmt, elements, pos


def read_binary(body, elements, endian):
    """Returns {element name: {property name: array or list of arrays}}."""
    out, off = {}, 0
    for name, count, props in elements:
        cols = {}
        if not any(len(p) == 3 for p in props):
            dt = np.dtype([(p[0], endian + p[1]) for p in props])
            rec = np.frombuffer(body, dtype=dt, count=count, offset=off)
            off += dt.itemsize * count
            cols = {p[0]: rec[p[0]] for p in props}
        elif len(props) == 1 and count > 0:
            # One list: try a structured array of records of the first record's length.
            pname, ct, it = props[0]
            n0 = int(np.frombuffer(body, dtype=endian + ct, count=1, offset=off)[0])
            dt = np.dtype([("n", endian + ct), ("i", endian + it, (max(n0, 0),))])
            if n0 >= 0 and off + dt.itemsize * count <= len(body):
                rec = np.frombuffer(body, dtype=dt, count=count, offset=off)
                if np.all(rec["n"] == n0):
                    cols = {pname: rec["i"]}  # a 2D array: one row per record
                    off += dt.itemsize * count
                    out[name] = cols
                    continue
            cols, off = read_records(body, off, count, props, endian)
        else:
            cols, off = read_records(body, off, count, props, endian)
        out[name] = cols
    return out


def read_records(body, off, count, props, endian):
    cols = {p[0]: [] for p in props}
    for _ in range(count):
        for p in props:
            if len(p) == 3:
                ct, it = np.dtype(endian + p[1]), np.dtype(endian + p[2])
                n = int(np.frombuffer(body, dtype=ct, count=1, offset=off)[0])
                off += ct.itemsize
                if n < 0:
                    raise PlyError("negative list length")
                cols[p[0]].append(np.frombuffer(body, dtype=it, count=n, offset=off))
                off += it.itemsize * n
            else:
                t = np.dtype(endian + p[1])
                cols[p[0]].append(np.frombuffer(body, dtype=t, count=1, offset=off)[0])
                off += t.itemsize
    return {k: (v if any(len(p) == 3 and p[0] == k for p in props) else np.array(v))
            for k, v in cols.items()}, off


def read_ascii(body, elements):
    tokens = body.split()
    out, t = {}, 0
    for name, count, props in elements:
        cols = {p[0]: [] for p in props}
        for _ in range(count):
            for p in props:
                if len(p) == 3:
                    n = int(tokens[t])
                    conv = float if p[2][0] == "f" else int
                    cols[p[0]].append(np.array([conv(x) for x in tokens[t + 1:t + 1 + n]]))
                    t += 1 + n
                else:
                    tok = tokens[t].decode()
                    cols[p[0]].append(float(tok) if p[1][0] == "f" else int(tok))
                    t += 1
        for p in props:
            if len(p) == 2:
                cols[p[0]] = np.array(cols[p[0]], dtype=np.float64 if p[1] == "f8" else None)
                if p[1] == "f4":  # as float: the decimal rounded once (tokens hold floats)
                    cols[p[0]] = np.array([np.float32(x) for x in cols[p[0]]], dtype=np.float32)
        out[name] = cols
    return out


def mesh_of(path):
    data = open(path, "rb").read()
    if path.endswith(".gz"):
        data = gzip.decompress(data)
    fmt, elements, off = parse_header(data)
    body = data[off:]
    if fmt == "ascii":
        el = read_ascii(body, elements)
    else:
        el = read_binary(body, elements, "<" if fmt == "binary_little_endian" else ">")
    v, f = el["vertex"], el["face"]
    arrays = {}
    f4 = lambda a: np.asarray(a).astype(np.float32)
    arrays["p"] = np.stack([f4(v["x"]), f4(v["y"]), f4(v["z"])], axis=1)
    if all(k in v for k in ("nx", "ny", "nz")):
        arrays["n"] = np.stack([f4(v["nx"]), f4(v["ny"]), f4(v["nz"])], axis=1)
    for a, b in UV_NAMES:
        if a in v and b in v:
            arrays["uv"] = np.stack([f4(v[a]), f4(v[b])], axis=1)
            break
    lists = f["vertex_indices"] if "vertex_indices" in f else f["vertex_index"]
    nverts = len(arrays["p"])
    fid = f.get("face_indices")
    if isinstance(lists, np.ndarray):  # every face of the same length
        lengths = np.full(len(lists), lists.shape[1], dtype=np.int64)
        flat = lists.reshape(-1).astype(np.int64)
    else:
        lengths = np.array([len(x) for x in lists], dtype=np.int64)
        flat = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists] +
                              [np.zeros(0, dtype=np.int64)])
    if len(flat) and (flat.min() < 0 or flat.max() >= nverts):
        raise PlyError("index out of range")
    # Fan every face with 3 or more vertices from its first: triangle j of a face is
    # (v0, v[j], v[j+1]), j = 1 .. n-2.
    per_face = np.maximum(lengths - 2, 0)
    face_of = np.repeat(np.arange(len(lengths), dtype=np.int64), per_face)
    first_triangle = np.cumsum(per_face) - per_face
    corner = np.arange(len(face_of), dtype=np.int64) - first_triangle[face_of] + 1
    start = (np.cumsum(lengths) - lengths)[face_of]
    tris = np.stack([flat[start], flat[start + corner], flat[start + corner + 1]], axis=1)
    polygons = bool((lengths > 3).any())
    ids = np.asarray(fid).astype(np.float64)[face_of].astype(np.int64) if fid is not None else None
    arrays["indices"] = tris.astype(np.uint32).reshape(-1)
    if polygons:
        arrays["face_of_triangle"] = face_of.astype(np.uint32)
    if ids is not None:
        arrays["face_indices"] = ids.astype(np.int32)
    return arrays


def main():
    with open(sys.argv[1], "wb") as out:
        for path in sys.argv[2:]:
            out.write(b"mesh\n")
            try:
                arrays = mesh_of(path)
            except (PlyError, KeyError, ValueError, IndexError) as e:
                out.write(("error %s\n" % e).encode())
                arrays = {}
            for name, a in arrays.items():
                dt = {"f": "f4", "u": "u4", "i": "i4"}[a.dtype.kind]
                a = a.astype("<" + dt).reshape(-1)
                out.write(("%s %s %d\n" % (name, dt, a.size)).encode())
                out.write(a.tobytes())
            out.write(b"end\n")


if __name__ == "__main__":
    main()
