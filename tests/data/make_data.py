#!/usr/bin/env python3
"""Regenerates tests/data/ok and tests/data/broken (run from this folder). Kept for reference:
the generated files are committed and the tests read them."""
import math
import struct

# Cube [-0.5, 1.25]^3 (values exact in float32), 8 vertices, 6 outward quads.
A, B = -0.5, 1.25
V = [(A, A, A), (B, A, A), (B, B, A), (A, B, A), (A, A, B), (B, A, B), (B, B, B), (A, B, B)]
Q = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
T = [t for q in Q for t in ((q[0], q[1], q[2]), (q[0], q[2], q[3]))]


def fmt(x):
    return repr(float(x))


def w(path, data):
    mode = "wb" if isinstance(data, bytes) else "w"
    with open(path, mode) as f:
        f.write(data)


# ---------- ok/ ----------
obj = "# cube, quads, two groups\nmtllib none.mtl\n"
obj += "".join(f"v {fmt(x)} {fmt(y)} {fmt(z)}\n" for x, y, z in V)
obj += "vn 0 0 1\ng bottom_and_top\ns off\n"
obj += "".join("f " + " ".join(f"{i + 1}//1" for i in q) + "\n" for q in Q[:2])
obj += "o sides\nusemtl foo\n"
obj += "".join("f " + " ".join(str(i + 1) for i in q) + "\n" for q in Q[2:])
w("ok/cube.obj", obj)

# negative indices, objects interleaved with their vertices, CRLF line ends, w and colours
lines = ["o first"]
lines += [f"v {fmt(x)} {fmt(y)} {fmt(z)} 1.0" for x, y, z in V[:4]]
lines += ["f -4 -1 -2 -3"]  # quad 0 = 0 3 2 1
lines += ["o second"]
lines += [f"v {fmt(x)} {fmt(y)} {fmt(z)} 0.5 0.5 0.5" for x, y, z in V[4:]]
lines += ["f " + " ".join(str(i - 8) for i in q) for q in Q[1:]]
w("ok/cube_relative.obj", "\r\n".join(lines) + "\r\n")

off = "OFF\n# a cube\n8 6 12\n" + "".join(f"{fmt(x)} {fmt(y)} {fmt(z)}\n" for x, y, z in V)
off += "".join(f"4 {' '.join(map(str, q))}\n" for q in Q)
w("ok/cube.off", off)
off = "COFF 8 6 0 # counts on the header line\n\n"
off += "".join(f"{fmt(x)} {fmt(y)} {fmt(z)} 255 0 0 255 # red\n" for x, y, z in V)
off += "".join(f"4 {' '.join(map(str, q))} 0.1 0.2 0.3\n" for q in Q)
w("ok/cube_coff.off", off)
off = "NOFF\n8 6 12\n" + "".join(f"  {fmt(x)}\t{fmt(y)} {fmt(z)} 0 0 1\n" for x, y, z in V)
off += "".join(f"4 {' '.join(map(str, q))}\n" for q in Q)
w("ok/cube_noff.off", off)


def ply(enc, xyz_type, count_type, index_type):
    fmt_char = {"float": "f", "double": "d", "uchar": "B", "char": "b", "short": "h",
                "ushort": "H", "int": "i", "uint": "I"}
    head = (f"ply\nformat {enc} 1.0\ncomment cube with extra properties\n"
            f"obj_info made by make_data.py\n"
            f"element vertex 8\nproperty uchar red\nproperty {xyz_type} x\nproperty {xyz_type} y\n"
            f"property {xyz_type} z\nproperty list uchar float extra\nproperty short flag\n"
            f"element edge 2\nproperty list int int vertex_indices\nproperty double weight\n"
            f"element face 6\nproperty ushort id\nproperty list {count_type} {index_type} vertex_indices\n"
            f"property float quality\nelement empty 1000000000\nend_header\n")
    if enc == "ascii":
        body = "".join(f"7 {fmt(x)} {fmt(y)} {fmt(z)} 2 1.5 2.5 -3\n" for x, y, z in V)
        body += "2 0 1 0.5\n3 1 2 3 0.25\n"
        body += "".join(f"{k} 4 {' '.join(map(str, q))} 0.75\n" for k, q in enumerate(Q))
        return head.encode()
    e = "<" if enc == "binary_little_endian" else ">"
    body = b""
    for x, y, z in V:
        body += struct.pack(e + "B" + 3 * fmt_char[xyz_type], 7, x, y, z)
        body += struct.pack(e + "Bffh", 2, 1.5, 2.5, -3)
    body += struct.pack(e + "iiid", 2, 0, 1, 0.5) + struct.pack(e + "iiiid", 3, 1, 2, 3, 0.25)
    for k, q in enumerate(Q):
        body += struct.pack(e + "H" + fmt_char[count_type] + 4 * fmt_char[index_type] + "f",
                            k, 4, *q, 0.75)
    return head.encode() + body


def ply_ascii():
    head = ply("ascii", "float", "uchar", "int").decode()
    body = "".join(f"7 {fmt(x)} {fmt(y)} {fmt(z)} 2 1.5 2.5 -3\n" for x, y, z in V)
    body += "2 0 1 0.5\n3 1 2 3 0.25\n"
    body += "".join(f"{k} 4 {' '.join(map(str, q))} 0.75\n" for k, q in enumerate(Q))
    return head + body


w("ok/cube_ascii.ply", ply_ascii())
w("ok/cube_binary_le.ply", ply("binary_little_endian", "float", "uchar", "uint"))
w("ok/cube_binary_be.ply", ply("binary_big_endian", "double", "int", "short"))

stl = "solid cube\n"
for t in T:
    stl += "  facet normal 0 0 0\n    outer loop\n"
    stl += "".join(f"      vertex {fmt(V[i][0])} {fmt(V[i][1])} {fmt(V[i][2])}\n" for i in t)
    stl += "    endloop\n  endfacet\n"
stl += "endsolid cube\n"
w("ok/cube_ascii.stl", stl)


def stl_binary(tris, count=None):
    head = b"solid cube (binary, but the header starts with solid)".ljust(80, b" ")
    body = b"".join(struct.pack("<12f", 0, 0, 0, *V[t[0]], *V[t[1]], *V[t[2]]) + b"\0\0" for t in tris)
    return head + struct.pack("<I", len(tris) if count is None else count) + body


w("ok/cube_binary.stl", stl_binary(T))

# ---------- broken/ (reader errors) ----------
w("broken/truncated_binary.ply", ply("binary_little_endian", "float", "uchar", "uint")[:-40])
w("broken/truncated_binary.stl", b"binary STL".ljust(80, b"\0") + struct.pack("<I", 12)
  + stl_binary(T)[84:84 + 7 * 50])
w("broken/truncated_header.stl", b"binary STL, cut in its header")
off = "OFF\n8 6 12\n" + "".join(f"{fmt(x)} {fmt(y)} {fmt(z)}\n" for x, y, z in V)
off += "".join(f"4 {' '.join(map(str, q))}\n" for q in Q[:4])
w("broken/truncated_faces.off", off)
w("broken/garbled_header.ply", "ply\nformat ascii 1.0\nelement vertex eight\nproperty float x\nend_header\n")
w("broken/no_end_header.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n")
w("broken/unsupported_format.ply", "ply\nformat binary_middle_endian 1.0\nelement vertex 0\nend_header\n")
w("broken/no_vertex_indices.ply",
  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
  "element face 1\nproperty list uchar int vertex_list\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
w("broken/index_out_of_range.ply",
  "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
  "element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
  "3 0 1 2\n3 0 2 3\n")
w("broken/nan_coordinate.obj", "# NaN in the third vertex\nv 0 0 0\nv 1 0 0\nv nan 0 0\nf 1 2 3\n")
w("broken/inf_coordinate.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e999 1 0\nf 1 2 3\nf 2 4 3\n")
w("broken/huge_coordinate.obj", "v 0 0 0\nv 1e200 0 0\nv 0 1e200 0\nv 1e200 1e200 0\nf 1 2 3\nf 2 4 3\n")
w("broken/bad_number.obj", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n")
w("broken/index_out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n# faces\nf 1 2 3\nf 2 4 9\n")
w("broken/zero_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
w("broken/index_out_of_range.off", "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 4\n")
w("broken/empty.obj", "")
w("broken/no_faces.obj", "# a point cloud\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n")
w("broken/two_vertex_face.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n")
w("broken/unsupported_dimension.off", "4OFF\n1 0 0\n0 0 0 0\n")

# ---------- broken/ (topology, for TriMesh::from_soup; they read fine) ----------
def obj_text(comment, verts, faces):
    s = f"# {comment}\n" + "".join(f"v {fmt(x)} {fmt(y)} {fmt(z)}\n" for x, y, z in verts)
    return s + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in faces)


w("broken/nonmanifold_edge.obj", obj_text(
    "three triangles share the edge 1-2",
    [(0, 0, 0), (1, 0, 0), (0.5, 1, 0), (0.5, -1, 0), (0.5, 0, 1)],
    [(0, 1, 2), (1, 0, 3), (0, 1, 4)]))
w("broken/nonmanifold_vertex.obj", obj_text(
    "two triangles touching only at vertex 1",
    [(0, 0, 0), (1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0)],
    [(0, 1, 2), (0, 3, 4)]))
N, R, H = 5, 2.0, 0.5
mv = []
for i in range(N):
    th = 2 * math.pi * i / N
    for s in (H, -H):
        r = R + s * math.cos(th / 2)
        mv.append((r * math.cos(th), r * math.sin(th), s * math.sin(th / 2)))
mf = []
for i in range(N):
    a, b = 2 * i, 2 * i + 1
    a1, b1 = (2 * i + 2, 2 * i + 3) if i < N - 1 else (1, 0)  # half twist closes the strip
    mf += [(a, b, b1), (a, b1, a1)]
w("broken/nonorientable.obj", obj_text("Moebius strip, 10 triangles", mv, mf))
ov = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
of = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
of[1] = of[1][::-1]
of[6] = of[6][::-1]
w("broken/inconsistent_orientation.obj",
  obj_text("closed octahedron, faces 1 and 6 flipped (orientable: repairable)", ov, of))
w("broken/degenerate.obj", obj_text(
    "square with a T-junction closed by a zero-area triangle (face 3: vertices 2 5 1, collinear)",
    [(0, 0, 0), (2, 0, 0), (2, 2, 0), (0, 2, 0), (1, 0, 0)],
    [(0, 4, 3), (4, 1, 2), (4, 2, 3), (1, 4, 0)]))
tv = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
tf = [(0, 2, 1), (0, 1, 3), (1, 2, 3), (0, 3, 2)]
w("broken/duplicate_faces.obj", obj_text("tetrahedron with face 1 repeated as face 4",
                                         tv, tf + [tf[1]]))
w("broken/unreferenced_vertices.obj", obj_text(
    "tetrahedron plus two vertices no face uses (the 3rd and 6th v lines)",
    tv[:2] + [(5, 5, 5)] + tv[2:] + [(6, 6, 6)],
    [tuple(i if i < 2 else i + 1 for i in f) for f in tf]))
