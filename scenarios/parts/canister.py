"""A rounded-square canister for scenarios/canister.toml: walls a superellipse |x/a|^4 + |y/b|^4 = 1
(a = 50, b = 40 mm), 30 mm tall, then a roof 40 mm high closing to an apex (each ring the wall's
section scaled by cos phi at height 30 + 40 sin phi). `python3 canister.py [a_mm] [out.obj]`."""
import math, sys
a = float(sys.argv[1]) if len(sys.argv) > 1 else 50.0
out = sys.argv[2] if len(sys.argv) > 2 else "canister.obj"
b = 0.8 * a
wall, roof, n = 0.6 * a, 0.8 * a, 4.0
nu = 240
def sq(t):
    c, s = math.cos(t), math.sin(t)
    return (a * math.copysign(abs(c) ** (2 / n), c), b * math.copysign(abs(s) ** (2 / n), s))
rings = []
nz_wall = 16
for k in range(nz_wall + 1):
    rings.append((wall * k / nz_wall, 1.0))
nz_roof = 24
for k in range(1, nz_roof):
    phi = (math.pi / 2) * k / nz_roof
    rings.append((wall + roof * math.sin(phi), math.cos(phi)))
vs, fs = [], []
for z, s in rings:
    for i in range(nu):
        x, y = sq(2 * math.pi * i / nu)
        vs.append((s * x, s * y, z))
apex = len(vs)
vs.append((0.0, 0.0, wall + roof))
for r in range(len(rings) - 1):
    for i in range(nu):
        j = (i + 1) % nu
        p, q = r * nu + i, r * nu + j
        fs.append((p, q, q + nu)); fs.append((p, q + nu, p + nu))
last = (len(rings) - 1) * nu
for i in range(nu):
    fs.append((last + i, last + (i + 1) % nu, apex))
with open(out, "w") as f:
    for v in vs: f.write("v %.5f %.5f %.5f\n" % v)
    for t in fs: f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
print(len(vs), "verts", out)
