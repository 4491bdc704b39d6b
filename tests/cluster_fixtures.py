#!/usr/bin/python3
"""SciPy reference results for the hierarchical clustering (test-cluster.c).

Writes, for a few seeded point sets, SciPy's linkage matrix for each method
the clusterer offers and the flat clusters of fcluster with the
'inconsistent' and 'distance' criteria, as JSON:

    /usr/bin/python3 tests/cluster_fixtures.py [output]   # default: stdout

The committed tests/data/cluster-fixtures.json is this script's output;
test-cluster.c also reruns it when SciPy is available. Exits 77 (skip)
without SciPy.
"""
import json
import sys

try:
    import numpy as np
    import scipy
    from scipy.cluster.hierarchy import fcluster, linkage
except ImportError:
    sys.stderr.write("cluster_fixtures.py: needs numpy and scipy\n")
    sys.exit(77)

METHODS = ["ward", "single", "complete", "average", "centroid"]
INCONSISTENT = [(0.8, 3), (1.0, 3), (1.2, 3), (1.45, 3), (2.0, 3), (1.0, 2)]


def polar(r, az_deg, el_deg=0.0):
    """Sensor frame position of (range, azimuth, elevation)."""
    r, az, el = np.broadcast_arrays(r, np.radians(az_deg),
                                    np.radians(el_deg))
    return np.stack([r * np.cos(el) * np.sin(az), r * np.sin(el),
                     r * np.cos(el) * np.cos(az)], axis=-1)


def point_sets(rng):
    sets = {}
    sets["one"] = rng.normal(size=(1, 3))
    sets["two"] = rng.normal(size=(2, 3))
    sets["three"] = rng.normal(size=(3, 3))
    # Blobs of different sizes and spreads, like peaks around reflectors.
    blobs = [(polar(1.0, 0.0), 40, 0.01), (polar(2.0, -35.0), 15, 0.03),
             (polar(1.5, 30.0, 10.0), 5, 0.005), (polar(3.0, 60.0), 1, 0)]
    sets["blobs"] = np.concatenate(
        [c + s * rng.normal(size=(m, 3)) for c, m, s in blobs])
    # The smeared lobe at 80 degrees: an arc of +-10 degrees, narrow in
    # range, next to a compact blob at broadside.
    az = 80.0 + rng.uniform(-10.0, 10.0, 60)
    arc = polar(1.5 + 0.003 * rng.normal(size=60), az)
    sets["arc80"] = np.concatenate(
        [arc, polar(1.2, 0.0) + 0.01 * rng.normal(size=(20, 3))])
    sets["plane"] = rng.uniform(-1.0, 1.0, size=(30, 2))
    # Equal distances everywhere: ties in every linkage step.
    sets["lattice"] = np.array([[i, j, 0.0] for i in range(5)
                                for j in range(4)]) * 0.003
    sets["random500"] = rng.uniform(-2.0, 2.0, size=(500, 3))
    return sets


def fixture(name, points):
    n = len(points)
    # Exactly tied distances: which tie wins depends on the last bit of
    # every distance update.
    ties = name == "lattice"
    entry = {"name": name, "dims": points.shape[1], "ties": ties,
             "points": points.tolist(), "methods": {}}
    for method in METHODS:
        if n < 2:
            entry["methods"][method] = {
                "Z": [], "inconsistent": [
                    {"t": t, "depth": d, "labels": [1]}
                    for t, d in INCONSISTENT],
                "distance": [{"t": 1.0, "labels": [1]}]}
            continue
        Z = linkage(points, method)
        heights = np.sort(Z[:, 2])
        # Cuts half-way between two heights: no height sits on a cut.
        cuts = sorted({0.5 * (heights[i] + heights[i + 1])
                       for i in {(n - 2) // 2, (9 * (n - 2)) // 10}
                       if i + 1 < n - 1} | {heights[-1] + 1.0})
        entry["methods"][method] = {
            "Z": Z.tolist(),
            "inconsistent": [
                {"t": t, "depth": d,
                 "labels": fcluster(Z, t, "inconsistent", depth=d).tolist()}
                for t, d in INCONSISTENT],
            "distance": [
                {"t": float(t), "labels": fcluster(Z, t, "distance").tolist()}
                for t in cuts]}
    return entry


def main():
    rng = np.random.default_rng(20240611)
    out = {"generator": "tests/cluster_fixtures.py",
           "scipy": scipy.__version__,
           "sets": [fixture(k, v) for k, v in point_sets(rng).items()]}
    text = json.dumps(out, separators=(",", ":")) + "\n"
    if len(sys.argv) > 1:
        with open(sys.argv[1], "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
