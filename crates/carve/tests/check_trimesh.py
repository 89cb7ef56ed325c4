#!/usr/bin/env python3
"""Development-time check that `flexshape carve` surfaces are closed manifolds by trimesh's own
definitions (every edge in exactly two faces, windings agreeing, outward volume), independently
of the Rust tests' own check.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install trimesh
    flexshape simulate --out REC --frames 10 --motion 30 --seed 2
    flexshape carve REC -o CARVED
    /tmp/v/bin/python crates/carve/tests/check_trimesh.py CARVED/*.surface.ply

Not run by the test command (the product and its tests need no Python).
"""
import sys

import trimesh

bad = 0
for path in sys.argv[1:]:
    mesh = trimesh.load(path, process=True)  # merges coincident corners, as a user's load does
    ok = mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    bad += not ok
    print(f"{path}: {len(mesh.faces)} triangles, watertight {mesh.is_watertight}, "
          f"winding consistent {mesh.is_winding_consistent}, volume {mesh.volume:.1f} mm³, "
          f"Euler {mesh.euler_number}")
print(f"{len(sys.argv) - 1 - bad} of {len(sys.argv) - 1} closed and consistent")
sys.exit(1 if bad else 0)
