"""Reproducible agglomerates of sintered spheres.

The procedure (random sequential attachment with sintering, seeded):

1. Sphere 0 sits at the origin.
2. Each new sphere k picks, with the seeded generator, an existing sphere p
   (uniformly) and a direction u (uniform on the unit sphere) and is placed at
   c_p + d u, d = 2 r (1 - overlap): it overlaps its parent by the sintering
   neck. The place is accepted only if the new sphere keeps at least the
   distance d from every other sphere, i.e. overlaps no other sphere more
   deeply than the neck; otherwise a new parent and direction are drawn. It
   may still touch or overlap (by less than the neck) spheres other than its
   parent: such pairs are not listed connections, and the rigid component
   joins them with an unbreakable implicit bond (README, "Break-up and
   sticking"; agglomerate_16/32/64: 1, 4 and 13 such pairs).
3. Every attachment is a connection (parent, k): the agglomerate is a tree of
   n - 1 connections, asymmetric and of fractal-like open structure.
4. The agglomerate is shifted so that its centroid is at the origin.

The same (n, radius, overlap, seed) always gives the same agglomerate on any
machine (numpy's PCG64 generator, IEEE arithmetic). Used by models/make_scenes.py.
"""
import argparse
import math

import numpy as np


def generate(n, radius, overlap=0.1, seed=1, max_tries=100000):
    """Returns (centers [n,3] array, connections list of (parent, child))."""
    if n < 1:
        raise ValueError("n must be >= 1")
    if not 0.0 <= overlap < 0.5:
        raise ValueError("overlap must be in [0, 0.5)")
    rng = np.random.Generator(np.random.PCG64(seed))
    d = 2.0 * radius * (1.0 - overlap)
    centers = [np.zeros(3)]
    connections = []
    for k in range(1, n):
        for _ in range(max_tries):
            p = int(rng.integers(0, len(centers)))
            u = rng.normal(size=3)
            u /= np.linalg.norm(u)
            c = centers[p] + d * u
            others = [np.linalg.norm(c - centers[j]) for j in range(len(centers)) if j != p]
            if all(dist >= d * (1.0 - 1e-12) for dist in others):
                centers.append(c)
                connections.append((p, k))
                break
        else:
            raise RuntimeError(f"could not place sphere {k} after {max_tries} tries")
    centers = np.array(centers)
    centers -= centers.mean(axis=0)
    return centers, connections


def extent(centers, radius):
    """Half-widths of the axis-aligned box around the agglomerate."""
    return np.max(np.abs(centers), axis=0) + radius


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("n", type=int)
    ap.add_argument("--radius", type=float, default=1.0)
    ap.add_argument("--overlap", type=float, default=0.1)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    c, conn = generate(a.n, a.radius, a.overlap, a.seed)
    for i, x in enumerate(c):
        print(f"sphere {i}: {x[0]: .6f} {x[1]: .6f} {x[2]: .6f}")
    for p, k in conn:
        print(f"connection {p} {k}")
    print("extent", extent(c, a.radius), "gyration radius",
          math.sqrt(float(np.mean(np.sum(c * c, axis=1)))))


if __name__ == "__main__":
    main()
