#!/usr/bin/env python3
# Writes eccentric-stenosis.stl (scenes/imported.toml): a vessel no hemocosim shape makes, as an
# imaging pipeline might hand it over. A tube of radius R0 whose centre line bends sideways by
# `shift` in the x-z plane between its inlet (centred at the origin, facing -z) and its outlet
# (facing +z), with a plaque on one side: the wall on the +x side of the centre line moves in by
# up to `plaque` of R0 over `plaque_length` about mid-length (a raised cosine along the line and
# around it), the -x side not at all. Rings of `around` points, `rings` + 1 of them, flat caps
# fanned about their centres; solids "vessel", "inflow", "outflow"; metres; 7 digits.
#
#   python3 make_eccentric_stenosis.py > eccentric-stenosis.stl
# SPDX-License-Identifier: GPL-3.0-or-later
import math
import sys

R0 = 50e-6            # m, the unobstructed radius (a 100-um vessel, the paper's)
LENGTH = 300e-6       # m, along z from the inlet to the outlet
SHIFT = 30e-6         # m, the centre line's sideways move
PLAQUE = 0.6          # of R0: the deepest the plaque reaches in, on the +x side
PLAQUE_LENGTH = 120e-6
AROUND, RINGS = 36, 40


def centre(z):
    x = SHIFT * (1 - math.cos(math.pi * z / LENGTH)) / 2
    slope = SHIFT * math.pi / LENGTH * math.sin(math.pi * z / LENGTH) / 2
    return (x, 0.0, z), slope


def radius(z, theta):
    s = (z - LENGTH / 2) / PLAQUE_LENGTH
    along = (1 + math.cos(2 * math.pi * s)) / 2 if abs(s) <= 0.5 else 0.0
    return R0 * (1 - PLAQUE * along * (1 + math.cos(theta)) / 2)


def ring(k):
    z = LENGTH * k / RINGS
    (cx, cy, cz), slope = centre(z)
    norm = math.hypot(1.0, slope)
    u = (1 / norm, 0.0, -slope / norm)  # in the x-z plane, across the centre line, towards +x
    v = (0.0, 1.0, 0.0)
    pts = []
    for j in range(AROUND):
        theta = 2 * math.pi * j / AROUND
        r = radius(z, theta)
        c, s = math.cos(theta), math.sin(theta)
        pts.append(tuple(p + r * (c * a + s * b) for p, a, b in zip((cx, cy, cz), u, v)))
    return pts, (cx, cy, cz)


def facet(out, a, b, c):
    n = [(b[1] - a[1]) * (c[2] - a[2]) - (b[2] - a[2]) * (c[1] - a[1]),
         (b[2] - a[2]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[2] - a[2]),
         (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])]
    length = math.sqrt(sum(x * x for x in n))
    out.write(" facet normal %.4g %.4g %.4g\n  outer loop\n" % tuple(x / length for x in n))
    for p in (a, b, c):
        out.write("   vertex %.7g %.7g %.7g\n" % p)
    out.write("  endloop\n endfacet\n")


def main(out):
    rings = [ring(k) for k in range(RINGS + 1)]
    out.write("solid vessel\n")
    for k in range(RINGS):
        lo, hi = rings[k][0], rings[k + 1][0]
        for j in range(AROUND):
            j1 = (j + 1) % AROUND
            facet(out, lo[j], lo[j1], hi[j1])  # counter-clockwise seen from outside
            facet(out, lo[j], hi[j1], hi[j])
    out.write("endsolid vessel\nsolid inflow\n")
    first, c0 = rings[0]
    for j in range(AROUND):
        facet(out, c0, first[(j + 1) % AROUND], first[j])
    out.write("endsolid inflow\nsolid outflow\n")
    last, c1 = rings[RINGS]
    for j in range(AROUND):
        facet(out, c1, last[j], last[(j + 1) % AROUND])
    out.write("endsolid outflow\n")


if __name__ == "__main__":
    main(sys.stdout)
