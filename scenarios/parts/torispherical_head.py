"""A torispherical pressure-vessel head for scenarios/torispherical_head.toml (ASME 10 %
flanged-and-dished): outside diameter D, crown radius D, knuckle radius 0.1 D, on a straight
flange; closed at the crown's apex. `python3 torispherical_head.py [D_mm] [flange_mm] [out.obj]`."""
import math, sys
D = float(sys.argv[1]) if len(sys.argv) > 1 else 160.0
hf = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
out = sys.argv[3] if len(sys.argv) > 3 else "torispherical_head.obj"
a, rc, rk = D / 2, D, 0.1 * D
zc = hf - math.sqrt((rc - rk) ** 2 - (a - rk) ** 2)
bt = math.atan2(hf - zc, a - rk)  # the knuckle meets the crown at this normal angle
prof = [(a, hf * k / 8) for k in range(8)]
prof += [(a - rk + rk * math.cos(b), hf + rk * math.sin(b)) for b in (bt * k / 12 for k in range(12))]
prof += [(rc * math.cos(b), zc + rc * math.sin(b)) for b in (bt + (math.pi / 2 - bt) * k / 24 for k in range(24))]
top = zc + rc
nu = 180
vs, fs = [], []
for r, z in prof:
    for i in range(nu):
        t = 2 * math.pi * i / nu
        vs.append((r * math.cos(t), r * math.sin(t), z))
apex = len(vs)
vs.append((0.0, 0.0, top))
for k in range(len(prof) - 1):
    for i in range(nu):
        j = (i + 1) % nu
        p, q = k * nu + i, k * nu + j
        fs.append((p, q, q + nu)); fs.append((p, q + nu, p + nu))
last = (len(prof) - 1) * nu
for i in range(nu):
    fs.append((last + i, last + (i + 1) % nu, apex))
with open(out, "w") as f:
    for v in vs: f.write("v %.5f %.5f %.5f\n" % v)
    for t in fs: f.write("f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1))
print(len(vs), "verts", out, "height %.1f mm, knuckle meets crown %.1f deg from horizontal" % (top, 90 - math.degrees(bt)))
