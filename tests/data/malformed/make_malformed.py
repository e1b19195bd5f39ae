#!/usr/bin/env python3
"""Generates the malformed-file corpus in this folder (the files are committed; rerun to refresh).

Each file is small and broken in one way. EXPECTED.tsv lists, per file, a fragment the error
message must contain (tests/io/test_malformed.cpp and tests/cli/test_cli_io.cpp read it).
"""
import os
import random
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
CASES = []  # (file name, expected message fragment)


def put(name, data, expect):
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)
    CASES.append((name, expect))


def ply_header(fmt, nv, nf, vprops="property float x\nproperty float y\nproperty float z\n",
               fprops="property list uchar int vertex_indices\n"):
    h = f"ply\nformat {fmt} 1.0\nelement vertex {nv}\n{vprops}"
    if nf is not None:
        h += f"element face {nf}\n{fprops}"
    return h + "end_header\n"


def bply_header(*args, **kw):
    return ply_header(*args, **kw).encode()


TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def ascii_body(verts, faces):
    s = "".join(f"{x} {y} {z}\n" for x, y, z in verts)
    return s + "".join(f"3 {a} {b} {c}\n" for a, b, c in faces)


def bin_body(verts, faces, e="<"):
    b = b"".join(struct.pack(e + "fff", *v) for v in verts)
    return b + b"".join(struct.pack(e + "Biii", 3, *f) for f in faces)


rng = random.Random(7)
garbage = bytes(rng.randrange(256) for _ in range(700))

# --- empty / wrong magic / not the format at all
put("empty.ply", b"", "is empty")
put("empty.obj", b"", "is empty")
put("empty.off", b"", "is empty")
put("empty.stl", b"", "is empty")
put("no_magic.ply", "plx\nformat ascii 1.0\nelement vertex 0\nend_header\n", "not a PLY file")
put("obj_named_ply.ply", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "not a PLY file")
put("no_magic.off", "OFX\n4 4 0\n" + ascii_body(TET_V, TET_F), "not an OFF file")
put("garbage.ply", b"ply\n" + garbage, "binary data")
put("garbage.obj", garbage, "binary data")
put("garbage.off", garbage, "binary data")
put("garbage.stl", garbage, "not a valid STL file")
put("unknown_extension.abc", ascii_body(TET_V, []), "unknown file format")
put("no_extension", "OFF\n4 4 0\n" + ascii_body(TET_V, TET_F), "unknown file format")

# --- PLY header problems
put("ply_bad_format.ply", ply_header("binary_middle_endian", 4, 4) + ascii_body(TET_V, TET_F), "unknown PLY format")
put("ply_no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n", "end_header")
put("ply_unknown_type.ply",
    ply_header("ascii", 4, 4, vprops="property float128 x\nproperty float y\nproperty float z\n")
    + ascii_body(TET_V, TET_F), "unknown property type")
put("ply_missing_z.ply", ply_header("ascii", 4, 4, vprops="property float x\nproperty float y\n")
    + "".join(f"{x} {y}\n" for x, y, _ in TET_V) + ascii_body([], TET_F), "no 'z' property")
put("ply_negative_count.ply", ply_header("ascii", -4, 4) + ascii_body(TET_V, TET_F), "invalid count")
put("ply_no_vertex_indices.ply", ply_header("ascii", 4, 4, fprops="property int foo\n")
    + ascii_body(TET_V, []) + "1\n2\n3\n4\n", "vertex_indices")
put("ply_absurd_count.ply", bply_header("binary_little_endian", 10**12, 4) + bin_body(TET_V, TET_F), "claims 1000000000000")

# --- PLY body problems
put("ply_truncated_ascii.ply", ply_header("ascii", 8, 4) + ascii_body(TET_V, [])[:-1], "truncated")
put("ply_truncated_le.ply", bply_header("binary_little_endian", 4, 4) + bin_body(TET_V, TET_F)[:-7], "truncated")
put("ply_truncated_be.ply", bply_header("binary_big_endian", 4, 4) + bin_body(TET_V, TET_F, ">")[:-7], "truncated")
put("ply_index_out_of_range.ply", ply_header("ascii", 4, 4) + ascii_body(TET_V, TET_F[:3] + [(1, 2, 99)]),
    "out of range")
put("ply_index_out_of_range_le.ply", bply_header("binary_little_endian", 4, 4)
    + bin_body(TET_V, TET_F[:3] + [(1, 2, -5)]), "out of range")
put("ply_nan.ply", ply_header("ascii", 4, 4) + ascii_body(TET_V[:3] + [("nan", 0, 1)], TET_F), "non-finite")
put("ply_inf_be.ply", bply_header("binary_big_endian", 4, 4) + bin_body(TET_V[:3] + [(float("inf"), 0, 1)], TET_F, ">"),
    "non-finite")
put("ply_too_many_faces.ply", ply_header("ascii", 4, 3) + ascii_body(TET_V, TET_F), "unexpected data after the last element")
put("ply_too_few_vertices.ply", ply_header("ascii", 3, 4) + ascii_body(TET_V, TET_F), "line 13")
put("ply_trailing_bytes_le.ply", bply_header("binary_little_endian", 3, 0) + bin_body(TET_V, []),
    "unexpected data after the last element")
put("ply_face_two_vertices.ply", ply_header("ascii", 4, 1) + ascii_body(TET_V, []) + "2 0 1\n", "at least 3")
put("ply_bad_number.ply", ply_header("ascii", 4, 4) + ascii_body(TET_V, TET_F).replace("1 0 0", "1 zero 0", 1),
    "is not a number")
put("ply_no_properties.ply", "ply\nformat ascii 1.0\nelement vertex 1000000\nend_header\n", "no properties")

# --- OBJ
put("obj_index_out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "out of range")
put("obj_zero_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "index 0")
put("obj_bad_number.obj", "v 0 0 0\nv 1.0 abc 0\nv 0 1 0\nf 1 2 3\n", "line 2")
put("obj_nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n", "non-finite")
put("obj_unknown_statement.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nfoo 1 2 3\n", "unknown OBJ statement")
put("obj_no_vertices.obj", "# nothing but a comment\ng empty\n", "no vertices")
put("obj_face_two_vertices.obj", "v 0 0 0\nv 1 0 0\nf 1 2\n", "at least 3")

# --- OFF
put("off_truncated.off", "OFF\n4 4 0\n" + ascii_body(TET_V, TET_F)[:40], "truncated")
put("off_index_out_of_range.off", "OFF\n4 4 0\n" + ascii_body(TET_V, TET_F[:3] + [(1, 2, 4)]), "out of range")
put("off_face_two_vertices.off", "OFF\n4 1 0\n" + ascii_body(TET_V, []) + "2 0 1\n", "at least 3")
put("off_negative_count.off", "OFF\n-4 4 0\n" + ascii_body(TET_V, TET_F), "negative")
put("off_absurd_count.off", "OFF\n4 1000000000000 0\n" + ascii_body(TET_V, TET_F), "claims")
put("off_inf.off", "OFF\n4 4 0\n" + ascii_body(TET_V[:3] + [(0, "inf", 1)], TET_F), "non-finite")
put("off_binary.off", b"OFF BINARY\n" + struct.pack(">iii", 4, 4, 0) + b"\0" * 48, "binary")
put("off_too_many_vertices.off", "OFF\n3 4 0\n" + ascii_body(TET_V, TET_F), "line 6")
put("off_extra_faces.off", "OFF\n4 3 0\n" + ascii_body(TET_V, TET_F), "unexpected data after the last face")

# --- STL
tri = struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0)
put("stl_truncated_binary.stl", b"\0" * 80 + struct.pack("<I", 3) + tri * 2 + tri[:20], "not a valid STL file")
put("stl_absurd_count.stl", b"\0" * 80 + struct.pack("<I", 4000000000) + tri, "4000000000 triangles")
put("stl_nan_binary.stl", b"\0" * 80 + struct.pack("<I", 1) + struct.pack("<12fH", 0, 0, 1, 0, 0, 0, float("nan"), 0, 0,
                                                                       0, 1, 0, 0), "non-finite")
stl_ascii = ("solid t\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n   vertex 0 1 0\n"
             "  endloop\n endfacet\nendsolid t\n")
put("stl_ascii_truncated.stl", stl_ascii[:73], "truncated")
put("stl_ascii_bad_vertex.stl", stl_ascii.replace("vertex 1 0 0", "vertex 1 zz 0"), "line 5")
put("stl_ascii_two_vertices.stl", stl_ascii.replace("   vertex 0 1 0\n", ""), "at least 3")
put("stl_tiny.stl", b"abc", "too small")

# --- Numbers out of range where they enter (issue 21: items 3 and 8)
put("ply_float_overflow.ply", ply_header("ascii", 4, 4) + ascii_body(TET_V[:3] + [(0, "1e300", 1)], TET_F),
    "overflows the property's type float")
put("ply_scalar_float_overflow.ply",
    ply_header("ascii", 4, 4, vprops="property float x\nproperty float y\nproperty float z\nproperty float quality\n")
    + "".join(f"{x} {y} {z} {q}\n" for (x, y, z), q in zip(TET_V, [0, 1, "1e300", 2]))
    + ascii_body([], TET_F), "overflows the property's type float")
put("ply_char_out_of_range.ply",
    ply_header("ascii", 4, 4, vprops="property float x\nproperty float y\nproperty float z\nproperty char flag\n")
    + "".join(f"{x} {y} {z} {c}\n" for (x, y, z), c in zip(TET_V, [0, 1, 300, 2]))
    + ascii_body([], TET_F), "overflows the property's type char")
put("ply_double_too_large.ply",
    ply_header("ascii", 4, 4, vprops="property double x\nproperty double y\nproperty double z\n")
    + ascii_body(TET_V[:3] + [("1e300", 0, 1)], TET_F), "beyond")
put("ply_double_overflow.ply",
    ply_header("ascii", 4, 4, vprops="property double x\nproperty double y\nproperty double z\n")
    + ascii_body(TET_V[:3] + [("1e999", 0, 1)], TET_F), "overflows the property's type double")
put("ply_scalar_nan_le.ply",
    bply_header("binary_little_endian", 4, 4,
                vprops="property float x\nproperty float y\nproperty float z\nproperty float quality\n")
    + b"".join(struct.pack("<ffff", *v, q) for v, q in zip(TET_V, [0, float("nan"), 1, 2]))
    + b"".join(struct.pack("<Biii", 3, *f) for f in TET_F), "non-finite")
put("ply_duplicate_property.ply",
    ply_header("ascii", 4, 4, vprops="property float x\nproperty float y\nproperty float z\nproperty float y\n")
    + ascii_body(TET_V, TET_F), "declared twice")
put("obj_bad_texture_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/x 2 3\n", "face texture index")
put("obj_texture_index_out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", "out of range")
put("obj_empty_normal_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1// 2// 3//\n", "no normal index")
put("obj_coordinate_too_large.obj", "v 0 0 0\nv 1e300 0 0\nv 0 1 0\nf 1 2 3\n", "beyond")
put("off_short_colour.off", "COFF\n4 4 0\n0 0 0 255 0 0\n1 0 0 0 255\n0 1 0 0 0 255\n0 0 1 9 9 9\n"
    + ascii_body([], TET_F), "colour values")
put("off_coordinate_too_large.off", "OFF\n4 4 0\n" + ascii_body(TET_V[:3] + [(0, "-1e300", 1)], TET_F), "beyond")
put("stl_ascii_too_large.stl", stl_ascii.replace("vertex 1 0 0", "vertex 1e300 0 0"), "beyond")

with open(os.path.join(HERE, "EXPECTED.tsv"), "w") as f:
    f.write("# file\tfragment the error message must contain (generated by make_malformed.py)\n")
    for name, expect in CASES:
        f.write(f"{name}\t{expect}\n")
print(f"{len(CASES)} malformed files")
