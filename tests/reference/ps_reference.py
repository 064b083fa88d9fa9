# Owns: the naive, independent plain-Python reference of docs/scheme.md (paired-method preprocessing + P-S steps) used by the tests.
"""Naive reference implementation of the P-S subdivision scheme as stated in docs/scheme.md.

Deliberately simple and independent of the C++ engine: plain lists and dicts, no
half-edge structure beyond a dict keyed by directed edges (a, b).

    python3 ps_reference.py IN.obj -o OUT.obj --levels N [--preprocess auto|always|never]
                            [--boundary paper|smooth]

--boundary smooth (beyond the paper): P-S steps 1, 3, 5, ... also split every boundary edge
a->b at M = (a + b) / 2, appended after the F-vertices in edge order, into the triangles
[a, M, F_f], [M, b, F_f]; a manifold boundary vertex moves to (prev + 6 v + next) / 8.

Output order (docs/scheme.md, "Output order" plus the engine's face-order convention):
  vertices: V-vertices of the old vertices in old order, then F-vertices in old face order;
  faces:    old faces in order, within a face its edges corner i -> corner i+1; a new face is
            emitted the first time an undirected edge is met, built from that half-edge a->b:
            interior (f holds a->b, g holds b->a): [a, F_g, b, F_f]; boundary: [a, b, F_f].
"""
import argparse
import math
import os
import sys


class MeshError(Exception):
    pass


# ---------------------------------------------------------------- OBJ I/O

def read_obj(path):
    """Return (positions, faces); positions: list of [x, y, z], faces: list of lists of 0-based ints."""
    try:
        with open(path, 'r') as fh:
            lines = fh.readlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise MeshError('%s: cannot read file: %s' % (path, exc))
    pos = []
    faces = []
    for lineno, line in enumerate(lines, 1):
        parts = line.split()
        if not parts:
            continue
        tag = parts[0]
        if tag == 'v':
            if len(parts) < 4:
                raise MeshError('%s:%d: vertex needs 3 coordinates' % (path, lineno))
            try:
                p = [float(parts[1]), float(parts[2]), float(parts[3])]
            except ValueError:
                raise MeshError('%s:%d: bad vertex coordinate' % (path, lineno))
            if not all(math.isfinite(c) for c in p):
                raise MeshError('%s:%d: vertex %d has a non-finite coordinate' % (path, lineno, len(pos) + 1))
            pos.append(p)
        elif tag == 'f':
            face = []
            for tok in parts[1:]:
                s = tok.split('/')[0]
                try:
                    k = int(s)
                except ValueError:
                    raise MeshError('%s:%d: bad face index %r' % (path, lineno, tok))
                if k > 0:
                    idx = k - 1
                elif k < 0:
                    idx = len(pos) + k
                else:
                    raise MeshError('%s:%d: face %d uses index 0' % (path, lineno, len(faces) + 1))
                if idx < 0 or idx >= len(pos):
                    raise MeshError('%s:%d: face %d: index %d out of range (%d vertices so far)'
                                    % (path, lineno, len(faces) + 1, k, len(pos)))
                face.append(idx)
            if len(face) < 3:
                raise MeshError('%s:%d: face %d has fewer than 3 vertices' % (path, lineno, len(faces) + 1))
            if len(set(face)) != len(face):
                raise MeshError('%s:%d: face %d repeats a vertex' % (path, lineno, len(faces) + 1))
            faces.append(face)
        # every other statement is ignored
    if not pos or not faces:
        raise MeshError('%s: empty mesh (no %s)' % (path, 'vertices' if not pos else 'faces'))
    return pos, faces


def write_obj(path, pos, faces):
    out = []
    for p in pos:
        out.append('v %.17g %.17g %.17g\n' % (p[0], p[1], p[2]))
    for f in faces:
        out.append('f ' + ' '.join(str(i + 1) for i in f) + '\n')
    tmp = path + '.tmp'
    with open(tmp, 'w') as fh:
        fh.writelines(out)
    os.replace(tmp, path)


# ---------------------------------------------------------------- topology

def build_halfedges(faces):
    """dict (a, b) -> face index; raises on non-manifold edges / inconsistent orientation."""
    count = {}  # undirected edge -> number of faces using it
    for fi, f in enumerate(faces):
        k = len(f)
        for i in range(k):
            a = f[i]
            b = f[(i + 1) % k]
            key = (a, b) if a < b else (b, a)
            c = count.get(key, 0) + 1
            count[key] = c
            if c > 2:
                raise MeshError('edge %d-%d is shared by more than two faces (face %d)' % (a + 1, b + 1, fi + 1))
    he = {}
    for fi, f in enumerate(faces):
        k = len(f)
        for i in range(k):
            a = f[i]
            b = f[(i + 1) % k]
            if (a, b) in he:
                raise MeshError('inconsistent orientation: faces %d and %d both traverse edge %d->%d'
                                % (he[(a, b)] + 1, fi + 1, a + 1, b + 1))
            he[(a, b)] = fi
    return he


def is_ps_legal(faces, he):
    """Legal P-S input: quads, plus triangles that have at least one boundary edge."""
    for f in faces:
        if len(f) == 4:
            continue
        if len(f) == 3:
            if any((f[(i + 1) % 3], f[i]) not in he for i in range(3)):
                continue
        return False
    return True


def subdivide_topology(nv, faces, he, split=False):
    """The common topology of preprocessing and of one P-S step (see module docstring).
    With split, boundary edge number i gets the vertex nv + len(faces) + i."""
    new_faces = []
    edge_point = nv + len(faces)
    seen = set()
    for fi, f in enumerate(faces):
        k = len(f)
        for i in range(k):
            a = f[i]
            b = f[(i + 1) % k]
            key = (a, b) if a < b else (b, a)
            if key in seen:
                continue
            seen.add(key)
            g = he.get((b, a))
            if g is None and split:
                new_faces.append([a, edge_point, nv + fi])
                new_faces.append([edge_point, b, nv + fi])
                edge_point += 1
            elif g is None:
                new_faces.append([a, b, nv + fi])
            else:
                new_faces.append([a, nv + g, b, nv + fi])
    return new_faces


def face_centroids(pos, faces):
    out = []
    for f in faces:
        x = y = z = 0.0
        for v in f:
            p = pos[v]
            x += p[0]
            y += p[1]
            z += p[2]
        k = float(len(f))
        out.append([x / k, y / k, z / k])
    return out


def vertex_classes(nv, faces, he):
    """For each vertex: 'unused', 'boundary', 'nonmanifold' or 'interior'."""
    incident = [[] for _ in range(nv)]  # list of (face, corner)
    for fi, f in enumerate(faces):
        for i, v in enumerate(f):
            incident[v].append((fi, i))
    boundary = [False] * nv
    for (a, b) in he:
        if (b, a) not in he:
            boundary[a] = True
            boundary[b] = True
    cls = []
    for v in range(nv):
        inc = incident[v]
        if not inc:
            cls.append('unused')
            continue
        if boundary[v]:
            cls.append('boundary')
            continue
        # walk the fan: from face f with outgoing v->x, go to face g holding x->v, take its outgoing edge
        fi, i = inc[0]
        start = fi
        visited = 0
        cur_f, cur_i = fi, i
        while True:
            visited += 1
            f = faces[cur_f]
            x = f[(cur_i + 1) % len(f)]
            g = he[(x, v)]
            gf = faces[g]
            cur_f, cur_i = g, gf.index(v)
            if cur_f == start or visited > len(inc):
                break
        cls.append('interior' if visited == len(inc) else 'nonmanifold')
    return cls, incident


def boundary_curve_neighbours(v, faces, he, incident):
    """(prev, next) for a manifold boundary vertex (one open fan), else None."""
    outs = [f[(i + 1) % len(f)] for (fi, i) in incident[v] for f in [faces[fi]]
            if (f[(i + 1) % len(f)], v) not in he]
    ins = [f[(i - 1) % len(f)] for (fi, i) in incident[v] for f in [faces[fi]]
           if (v, f[(i - 1) % len(f)]) not in he]
    if len(outs) != 1 or len(ins) != 1:
        return None
    # walk the fan from the face holding v->next across interior edges p->v / v->p
    f = he[(v, outs[0])]
    visited = 1
    while True:
        face = faces[f]
        p = face[(face.index(v) - 1) % len(face)]
        if (v, p) not in he:
            break
        f = he[(v, p)]
        visited += 1
        if visited > len(incident[v]):
            return None
    return (ins[0], outs[0]) if visited == len(incident[v]) else None


def ps_step(pos, faces, split=False):
    """One P-S step on legal P-S input; returns (new_pos, new_faces)."""
    nv = len(pos)
    he = build_halfedges(faces)
    if not is_ps_legal(faces, he):
        raise MeshError('not legal P-S input (a face is neither a quad nor a boundary triangle)')
    cls, incident = vertex_classes(nv, faces, he)

    # edge neighbours of each vertex (undirected edges)
    nbrs = [[] for _ in range(nv)]
    for (a, b) in he:
        if (b, a) not in he or a < b:
            nbrs[a].append(b)
            nbrs[b].append(a)

    new_pos = []
    for v in range(nv):
        P = pos[v]
        around = boundary_curve_neighbours(v, faces, he, incident) if split and cls[v] == 'boundary' else None
        if around is not None:
            a, b = pos[around[0]], pos[around[1]]
            new_pos.append([(a[k] + 6.0 * P[k] + b[k]) / 8.0 for k in range(3)])
            continue
        if cls[v] != 'interior':
            new_pos.append(list(P))
            continue
        n = len(nbrs[v])
        si = [0.0, 0.0, 0.0]
        for w in nbrs[v]:
            q = pos[w]
            si[0] += q[0]
            si[1] += q[1]
            si[2] += q[2]
        sj = [0.0, 0.0, 0.0]
        m = 0
        tri = 0
        for (fi, i) in incident[v]:
            f = faces[fi]
            if len(f) == 4:
                m += 1
                q = pos[f[(i + 2) % 4]]
                sj[0] += q[0]
                sj[1] += q[1]
                sj[2] += q[2]
            else:
                tri += 1
        if tri == 0:
            c = (n - 3.0) / n
            d = 2.0 / (n * n)
            e = 1.0 / (n * n)
        else:
            c = 1.0 / (1.0 + n / 2.0 + m / 4.0)
            d = c / 2.0
            e = c / 4.0
        new_pos.append([c * P[k] + d * si[k] + e * sj[k] for k in range(3)])
    new_pos.extend(face_centroids(pos, faces))
    new_faces = subdivide_topology(nv, faces, he, split)
    if split:  # edge points, in the order subdivide_topology numbered them
        seen = set()
        for f in faces:
            for i in range(len(f)):
                a, b = f[i], f[(i + 1) % len(f)]
                key = (min(a, b), max(a, b))
                if key in seen:
                    continue
                seen.add(key)
                if (b, a) not in he:
                    new_pos.append([(pos[a][k] + pos[b][k]) / 2.0 for k in range(3)])
    return new_pos, new_faces


def preprocess(pos, faces):
    """Paired method: polygon mesh -> quads + boundary triangles."""
    he = build_halfedges(faces)
    new_pos = [list(p) for p in pos] + face_centroids(pos, faces)
    return new_pos, subdivide_topology(len(pos), faces, he)


def needs_preprocess(faces, he):
    return not is_ps_legal(faces, he)


def run(pos, faces, levels, mode='auto', boundary='paper'):
    he = build_halfedges(faces)  # validates the input
    if mode == 'always' or (mode == 'auto' and needs_preprocess(faces, he)):
        pos, faces = preprocess(pos, faces)
    elif mode == 'never' and not is_ps_legal(faces, he):
        raise MeshError('--preprocess never: input is not legal P-S input '
                        '(only quads and triangles with a boundary edge are)')
    for step in range(1, levels + 1):
        pos, faces = ps_step(pos, faces, split=(boundary == 'smooth' and step % 2 == 1))
    return pos, faces


def main(argv=None):
    ap = argparse.ArgumentParser(description='Naive reference P-S subdivision (docs/scheme.md).')
    ap.add_argument('input')
    ap.add_argument('-o', '--output', required=True)
    ap.add_argument('--levels', type=int, default=1)
    ap.add_argument('--preprocess', choices=('auto', 'always', 'never'), default='auto')
    ap.add_argument('--boundary', choices=('paper', 'smooth'), default='paper')
    args = ap.parse_args(argv)
    if args.levels < 0:
        print('ps_reference: --levels must be >= 0', file=sys.stderr)
        return 1
    try:
        pos, faces = read_obj(args.input)
        try:
            pos, faces = run(pos, faces, args.levels, args.preprocess, args.boundary)
        except MeshError as exc:
            raise MeshError('%s: %s' % (args.input, exc))
        write_obj(args.output, pos, faces)
    except MeshError as exc:
        print('ps_reference: error: %s' % exc, file=sys.stderr)
        return 1
    return 0


if __name__ == '__main__':
    sys.exit(main())
