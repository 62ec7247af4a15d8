"""subdivide_ply.py IN.ply OUT.ply LEVELS: splits every triangle of a binary PLY
written by hdt_mesh_to_ply (double x y z; uchar/uint index lists) into four at
its edge midpoints, LEVELS times (dragon 100 K -> 1.6 M triangles at 2), for
the >= 1 M-triangle runs of the multi-GPU bench. The surface is the same up to
rounding of the midpoints, so the volume is nearly the dragon's (at 1024^3: 19
of 1.5 M surface voxels differ)."""
import struct
import sys


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    nv = int(next(l for l in header if l.startswith("element vertex")).split()[2])
    nf = int(next(l for l in header if l.startswith("element face")).split()[2])
    verts = list(struct.iter_unpack("<3d", data[end:end + 24 * nv]))
    at, faces = end + 24 * nv, []
    for _ in range(nf):
        faces.append(struct.unpack_from("<3I", data, at + 1))
        at += 13
    return verts, faces


def subdivide(verts, faces):
    mid = {}

    def midpoint(a, b):
        key = (a, b) if a < b else (b, a)
        if key not in mid:
            pa, pb = verts[a], verts[b]
            mid[key] = len(verts)
            verts.append(((pa[0] + pb[0]) * 0.5, (pa[1] + pb[1]) * 0.5, (pa[2] + pb[2]) * 0.5))
        return mid[key]

    out = []
    for a, b, c in faces:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    return verts, out


def write_ply(path, verts, faces):
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\ncomment subdivided by subdivide_ply.py\n"
                 "element vertex %d\nproperty double x\nproperty double y\nproperty double z\n"
                 "element face %d\nproperty list uchar uint vertex_indices\nend_header\n"
                 % (len(verts), len(faces))).encode())
        f.write(b"".join(struct.pack("<3d", *v) for v in verts))
        f.write(b"".join(struct.pack("<B3I", 3, *t) for t in faces))


verts, faces = read_ply(sys.argv[1])
for _ in range(int(sys.argv[3])):
    verts, faces = subdivide(verts, faces)
write_ply(sys.argv[2], verts, faces)
print("%s: %d triangles, %d vertices" % (sys.argv[2], len(faces), len(verts)))
