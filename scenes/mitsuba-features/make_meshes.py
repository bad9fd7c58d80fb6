#!/usr/bin/env python3
"""Writes this scene's meshes (run from this folder; standard library only):
meshes/torus.serialized, a torus in Mitsuba's .serialized format (version 4,
zlib, float32, with normals and uvs; mitsuba3 src/shapes/serialized.cpp), and
meshes/icosphere.ply, a subdivided icosahedron as binary little-endian PLY
without normals (Mitsuba computes smooth ones)."""
import math, struct, zlib


def torus(R=1.0, r=0.35, n=48, m=24):
    pos, nor, uv, tri = [], [], [], []
    for i in range(n + 1):
        u = 2 * math.pi * i / n
        for j in range(m + 1):
            v = 2 * math.pi * j / m
            c = (math.cos(u), 0.0, math.sin(u))
            nn = (math.cos(v) * c[0], math.sin(v), math.cos(v) * c[2])
            pos.append(tuple(R * c[k] + r * nn[k] for k in range(3)))
            nor.append(nn)
            uv.append((i / n, j / m))
    for i in range(n):
        for j in range(m):
            a, b = i * (m + 1) + j, (i + 1) * (m + 1) + j
            tri += [(a, a + 1, b), (b, a + 1, b + 1)]
    return pos, nor, uv, tri


def serialized(pos, nor, uv, tri, name=b"torus"):
    body = struct.pack("<I", 0x0001 | 0x0002 | 0x1000) + name + b"\0"
    body += struct.pack("<QQ", len(pos), len(tri))
    for arr in (pos, nor):
        body += b"".join(struct.pack("<3f", *p) for p in arr)
    body += b"".join(struct.pack("<2f", *t) for t in uv)
    body += b"".join(struct.pack("<3I", *t) for t in tri)
    data = struct.pack("<HH", 0x041C, 4) + zlib.compress(body, 9)
    return data + struct.pack("<Q", 0) + struct.pack("<I", 1)


def icosphere(levels=2):
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(sum(x * x for x in p)) for c in p) for p in v]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
         (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
         (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        cache, g = {}, []
        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = [(v[a][k] + v[b][k]) / 2 for k in range(3)]
                l = math.sqrt(sum(x * x for x in p))
                v.append(tuple(x / l for x in p))
                cache[key] = len(v) - 1
            return cache[key]
        for a, b, c in f:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            g += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        f = g
    return v, f


def ply(v, f):
    head = ("ply\nformat binary_little_endian 1.0\ncomment icosphere of make_meshes.py\n"
            f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n")
    body = b"".join(struct.pack("<3f", *p) for p in v)
    body += b"".join(struct.pack("<B3i", 3, *t) for t in f)
    return head.encode() + body


open("meshes/torus.serialized", "wb").write(serialized(*torus()))
open("meshes/icosphere.ply", "wb").write(ply(*icosphere()))
