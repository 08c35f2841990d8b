"""Peer timing for the geodesic benchmark: geometry-central's heat method via potpourri3d.

Usage: python3 peer_potpourri3d.py MESH.obj SOURCE_VERTEX REPEATS
Prints: setup_s=<s> solve_s=<s> (mean over repeats) n=<vertices>
"""
import sys
import time

import potpourri3d as pp3d

path, src, reps = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
V, F = pp3d.read_mesh(path)
t0 = time.perf_counter()
solver = pp3d.MeshHeatMethodDistanceSolver(V, F)
t1 = time.perf_counter()
for k in range(reps):
    solver.compute_distance((src + 997 * k) % len(V))
t2 = time.perf_counter()
print(f"setup_s={t1 - t0:.4f} solve_s={(t2 - t1) / reps:.4f} n={len(V)}")
