#!/usr/bin/env python3
"""What a triangle of level geometry costs against a body (docs/loadbalance.md,
"Triangles"): callgrind instruction counts of soda run on 64 resting bodies
of one shape over a flat heightfield of several sample spacings and over a
box ground, and of terrain 200 between steps 60 and 120.

    /usr/bin/python3 bench/triangle_cost.py build/bin/soda /tmp/triangle-cost

Prints one CSV line per case: shape, ground, triangles within reach per body
(soda partition), triangle tests per body-step (calls of the concave
callback), instructions per body-step; then the weights. Takes about 15
minutes (callgrind runs each scene twice).
"""
import json
import math
import os
import re
import subprocess
import sys


def scene(kind, ground, n_side=8, pitch=3.0, half=15.0):
    bodies = []
    if ground == "box":
        bodies.append({"id": 0, "type": "static", "shape": {"type": "box", "half_extents": [half, 0.5, half]},
                       "position": [0, -0.5, 0], "orientation": [0, 0, 0, 1], "friction": 0.8, "restitution": 0})
    else:
        s = float(ground[2:])
        cols = int(round(2 * half / s)) + 1
        bodies.append({"id": 0, "type": "static",
                       "shape": {"type": "heightfield", "columns": cols, "rows": cols,
                                 "heights": [0.0] * (cols * cols), "spacing": [s, 1, s]},
                       "position": [0, 0, 0], "orientation": [0, 0, 0, 1], "friction": 0.8, "restitution": 0})
    i = 1
    for a in range(n_side):
        for b in range(n_side):
            x = (a - (n_side - 1) / 2) * pitch
            z = (b - (n_side - 1) / 2) * pitch
            if kind == "sphere":
                sh = {"type": "sphere", "radius": 0.5}
            elif kind == "box":
                sh = {"type": "box", "half_extents": [0.5, 0.5, 0.5]}
            else:
                pts = [[0.5 * math.cos(2 * math.pi * k / 10), -0.5 if k % 2 else 0.5,
                        0.5 * math.sin(2 * math.pi * k / 10)] for k in range(10)]
                sh = {"type": "convex_hull", "points": pts}
            bodies.append({"id": i, "type": "dynamic", "mass": 1, "shape": sh,
                           "position": [x + 0.13, 0.501, z + 0.07], "orientation": [0, 0, 0, 1],
                           "linear_velocity": [0, 0, 0], "angular_velocity": [0, 0, 0],
                           "friction": 0.8, "restitution": 0})
            i += 1
    return {"format": "soda-scene", "version": 1, "name": "triangle-cost", "seed": 1,
            "settings": {"steps": 100}, "bodies": bodies}


def callgrind(soda, out, scene_arg, steps, extra=()):
    """Total instructions, calls of the concave triangle callback, and the
    instructions of its largest callee (the narrowphase of each triangle)."""
    subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=" + out, soda, "run", "--scene",
                    scene_arg, "--steps", str(steps), *extra], check=True, capture_output=True)
    text = subprocess.run(["callgrind_annotate", "--tree=caller", out], check=True, capture_output=True,
                          text=True).stdout
    total = int(re.search(r"([\d,]+) \(100.0%\)\s+PROGRAM TOTALS", text).group(1).replace(",", ""))
    calls = 0
    narrowphase = 0
    for line in text.splitlines():
        m = re.search(r"^\s*([\d,]+) .*<.*TriangleTests::processTriangle.*\(([\d,]+)x\)", line)
        if m:
            calls = max(calls, int(m.group(2).replace(",", "")))
            narrowphase = max(narrowphase, int(m.group(1).replace(",", "")))
    return total, calls, narrowphase


def reach(soda, scene_arg):
    text = subprocess.run([soda, "partition", "--scene", scene_arg, "--territories", "1", "--json", "-"],
                          check=True, capture_output=True, text=True).stdout
    j = json.loads(text[text.index("\n{") + 1:])
    w = j["worlds"][0]
    return w["body_triangles"] / w["bodies"]


def main():
    soda, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    print("shape,ground,triangles_within_reach,tests_per_body_step,instructions_per_body_step")
    base = {}
    for kind in ("sphere", "box", "hull"):
        for ground in ("box", "hf0.5", "hf0.25"):
            path = os.path.join(out, f"{kind}_{ground}.json")
            with open(path, "w") as f:
                json.dump(scene(kind, ground), f)
            i0, c0, _ = callgrind(soda, os.path.join(out, "cg0"), path, 0)
            i1, c1, _ = callgrind(soda, os.path.join(out, "cg1"), path, 100)
            per = (i1 - i0) / 6400
            t = reach(soda, path) if ground != "box" else 0
            print(f"{kind},{ground},{t:.1f},{(c1 - c0) / 6400:.2f},{per:.0f}", flush=True)
            if ground == "box":
                base[kind] = per
            else:
                print(f"  weight {kind} {ground}: {(per - base[kind]) / t / base[kind]:.4f}", flush=True)
    i0, c0, n0 = callgrind(soda, os.path.join(out, "cg0"), "terrain", 60)
    i1, c1, n1 = callgrind(soda, os.path.join(out, "cg1"), "terrain", 120)
    per, narrow, t = (i1 - i0) / 12000, (n1 - n0) / 12000, reach(soda, "terrain")
    print(f"terrain 200, steps 60-120: {per:.0f} instructions per body-step, {narrow:.0f} of them in the "
          f"narrowphase of triangles, {(c1 - c0) / 12000:.2f} triangle callbacks; triangles within reach per body "
          f"at the start {t:.1f}; weight {narrow / t / (per - narrow):.4f}")


if __name__ == "__main__":
    main()
