# Owns: the OBJ result comparator of docs/scheme.md, "Output order" (vertex positions index by index, faces as a multiset up to rotation).
"""Compare two OBJ meshes the way docs/scheme.md, "Output order" defines equality.

    python3 compare_obj.py A.obj B.obj [--tol 1e-5]

Equal when the vertex counts match, |a - b| <= tol * max(1, bbox diagonal of A) for every
coordinate of every vertex (index by index), and the multisets of faces agree after rotating
each face to start at its smallest index (cyclic order kept, no reflection).
Prints a one-line verdict (then the first differences); exit 0 when equal, 1 otherwise (also on
unreadable input).
"""
import argparse
import math
import sys
from collections import Counter

MAX_SHOWN = 10


def read_obj(path):
    pos = []
    faces = []
    with open(path, 'r') as fh:
        for lineno, line in enumerate(fh, 1):
            parts = line.split()
            if not parts:
                continue
            if parts[0] == 'v':
                pos.append((float(parts[1]), float(parts[2]), float(parts[3])))
            elif parts[0] == 'f':
                face = []
                for tok in parts[1:]:
                    k = int(tok.split('/')[0])
                    idx = k - 1 if k > 0 else len(pos) + k
                    if k == 0 or idx < 0 or idx >= len(pos):
                        raise ValueError('%s:%d: face index %d out of range' % (path, lineno, k))
                    face.append(idx)
                faces.append(tuple(face))
    return pos, faces


def canonical(face):
    i = face.index(min(face))
    return face[i:] + face[:i]


def bbox_diag(pos):
    if not pos:
        return 0.0
    lo = [min(p[k] for p in pos) for k in range(3)]
    hi = [max(p[k] for p in pos) for k in range(3)]
    return math.sqrt(sum((hi[k] - lo[k]) ** 2 for k in range(3)))


def compare(a_path, b_path, tol):
    """Return (equal, lines) where lines[0] is the verdict."""
    pa, fa = read_obj(a_path)
    pb, fb = read_obj(b_path)
    diffs = []
    if len(pa) != len(pb):
        diffs.append('vertex count differs: %d vs %d' % (len(pa), len(pb)))
    diag = bbox_diag(pa)
    thr = tol * max(1.0, diag)
    nbad = 0
    worst = 0.0
    for i in range(min(len(pa), len(pb))):
        a = pa[i]
        b = pb[i]
        d = max(abs(a[0] - b[0]), abs(a[1] - b[1]), abs(a[2] - b[2]))
        if not (d <= thr):  # also catches NaN
            nbad += 1
            if not (d <= worst):
                worst = d
            if nbad <= MAX_SHOWN:
                diffs.append('vertex %d: %r vs %r (|d| = %.3g > %.3g)' % (i + 1, a, b, d, thr))
    if nbad:
        diffs.append('%d vertices differ beyond %.3g (worst %.3g)' % (nbad, thr, worst))
    if len(fa) != len(fb):
        diffs.append('face count differs: %d vs %d' % (len(fa), len(fb)))
    ca = Counter(canonical(f) for f in fa)
    cb = Counter(canonical(f) for f in fb)
    if ca != cb:
        only_a = ca - cb
        only_b = cb - ca
        diffs.append('faces differ: %d only in A, %d only in B'
                     % (sum(only_a.values()), sum(only_b.values())))
        for f in list(only_a)[:MAX_SHOWN]:
            diffs.append('  only in A: f %s' % ' '.join(str(i + 1) for i in f))
        for f in list(only_b)[:MAX_SHOWN]:
            diffs.append('  only in B: f %s' % ' '.join(str(i + 1) for i in f))
    if diffs:
        return False, ['DIFFERENT: %s vs %s' % (a_path, b_path)] + diffs
    return True, ['EQUAL: %s vs %s (%d vertices, %d faces, tol %.3g)'
                  % (a_path, b_path, len(pa), len(fa), thr)]


def main(argv=None):
    ap = argparse.ArgumentParser(description='Compare two OBJ meshes (docs/scheme.md, "Output order").')
    ap.add_argument('a')
    ap.add_argument('b')
    ap.add_argument('--tol', type=float, default=1e-5)
    args = ap.parse_args(argv)
    try:
        equal, lines = compare(args.a, args.b, args.tol)
    except (OSError, ValueError, IndexError) as exc:
        print('ERROR: %s' % exc)
        return 1
    print('\n'.join(lines))
    return 0 if equal else 1


if __name__ == '__main__':
    sys.exit(main())
