#!/usr/bin/env python3
"""Writes the generated seed files of the fuzz targets into fuzz/seeds/<target>/ (committed; rerun
to refresh). Small valid files in every variant each reader supports, so that the fuzzer starts
from inputs that reach deep into the parsers. scripts/fuzz.sh adds the malformed files of
tests/data/malformed and the JSON files in fuzz/seeds/ that come from real sessions.
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
SEEDS = os.path.join(HERE, "seeds")

# A tetrahedron: 4 vertices, 4 triangles (one written as a quad with a repeated corner elsewhere).
V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
N = [(-0.577, -0.577, -0.577), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
C = [(255, 0, 0), (0, 255, 0), (0, 0, 255), (128, 128, 128)]
F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def put(target, name, data):
    d = os.path.join(SEEDS, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def ply():
    props = ("property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\n"
             "property float nz\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
             "property double quality\n")
    for fmt, name in (("ascii", "tet_ascii.ply"), ("binary_little_endian", "tet_le.ply"),
                      ("binary_big_endian", "tet_be.ply")):
        h = (f"ply\nformat {fmt} 1.0\ncomment seed\nelement vertex 4\n{props}element face 4\n"
             "property list uchar int vertex_indices\nend_header\n")
        if fmt == "ascii":
            body = "".join(f"{p[0]} {p[1]} {p[2]} {n[0]} {n[1]} {n[2]} {c[0]} {c[1]} {c[2]} {i * 0.5}\n"
                           for i, (p, n, c) in enumerate(zip(V, N, C)))
            body += "".join(f"3 {a} {b} {c}\n" for a, b, c in F)
            put("ply", name, h + body)
        else:
            e = "<" if fmt.endswith("little_endian") else ">"
            body = b"".join(struct.pack(e + "6f3Bd", *p, *n, *c, i * 0.5) for i, (p, n, c) in enumerate(zip(V, N, C)))
            body += b"".join(struct.pack(e + "B3i", 3, *f) for f in F)
            put("ply", name, h.encode() + body)
    # A point cloud with double coordinates and a quad face element using vertex_index and ushort.
    h = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
         "property double z\nproperty short scan_id\nelement face 1\nproperty list uint ushort vertex_index\n"
         "element extra 1\nproperty char flag\nend_header\n")
    body = b"".join(struct.pack("<3dh", *p, 7) for p in V) + struct.pack("<I4H", 4, 0, 1, 2, 3) + b"\x01"
    put("ply", "quad_double_le.ply", h.encode() + body)
    put("ply", "points_ascii.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
        "property float intensity\nend_header\n0 0 0 1\n1 2 3 4\n")


def obj():
    s = "# seed\nmtllib none.mtl\no tet\n"
    s += "".join(f"v {p[0]} {p[1]} {p[2]} {c[0] / 255} {c[1] / 255} {c[2] / 255}\n" for p, c in zip(V, C))
    s += "".join(f"vn {n[0]} {n[1]} {n[2]}\n" for n in N)
    s += "vt 0 0\nvt 1 0\nvt 0 1\ng g1\nusemtl m\ns 1\n"
    s += f"f 1/1/1 3/3/3 2/2/2\nf 1//1 2//2 4//4\nf -4/-3 -1/-2 -2/-1\nf {F[3][0] + 1} {F[3][1] + 1} {F[3][2] + 1}\n"
    put("obj", "tet.obj", s)
    put("obj", "quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl 1 2\n")


def off():
    put("off", "tet.off", "OFF\n# seed\n4 4 6\n" + "".join(f"{p[0]} {p[1]} {p[2]}\n" for p in V)
        + "".join(f"3 {a} {b} {c}\n" for a, b, c in F))
    put("off", "tet.coff", "COFF\n4 4 0\n" + "".join(f"{p[0]} {p[1]} {p[2]} {c[0]} {c[1]} {c[2]} 255\n"
                                                        for p, c in zip(V, C))
        + "".join(f"3 {a} {b} {c} 1 0 0\n" for a, b, c in F))
    put("off", "tet.noff", "NOFF\n4 4 0\n" + "".join(f"{p[0]} {p[1]} {p[2]} {n[0]} {n[1]} {n[2]}\n"
                                                        for p, n in zip(V, N))
        + "".join(f"3 {a} {b} {c}\n" for a, b, c in F))
    put("off", "tet.cnoff", "CNOFF 4 1 0 " + " ".join(f"{p[0]} {p[1]} {p[2]} {n[0]} {n[1]} {n[2]} 0.5 0.5 0.5 1"
                                                      for p, n in zip(V, N)) + " 4 0 1 2 3\n")


def stl():
    s = "solid tet\n"
    for f in F:
        s += "  facet normal 0 0 1\n    outer loop\n"
        s += "".join(f"      vertex {V[i][0]} {V[i][1]} {V[i][2]}\n" for i in f)
        s += "    endloop\n  endfacet\n"
    put("stl", "tet_ascii.stl", s + "endsolid tet\n")
    b = b"binary seed".ljust(80, b" ") + struct.pack("<I", len(F))
    for f in F:
        b += struct.pack("<3f", 0, 0, 1) + b"".join(struct.pack("<3f", *V[i]) for i in f) + struct.pack("<H", 0)
    put("stl", "tet_binary.stl", b)
    # A binary file whose header starts with "solid" (a classic trap for format detection).
    put("stl", "tet_binary_solid.stl", b"solid".ljust(80, b" ") + b[80:])


def pose():
    for i, s in enumerate(["1,2,3,-1,-2,-3", " 0.5 , 0 , 1e-3 , 0 , 0 , -1 ", "1,0,0,-1,0,0,0,1,0",
                           '{"position":[1,0,0],"direction":[-1,0,0]}',
                           '{"position":[0,0,2],"direction":[0,0,-1],"up":[0,1,0]}']):
        put("pose", f"pose_{i}.txt", s)


if __name__ == "__main__":
    ply()
    obj()
    off()
    stl()
    pose()
