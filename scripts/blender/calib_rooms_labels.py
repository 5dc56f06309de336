# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Which Manhattan directions of the calib_rooms images a labeller could mark, from the scene
GEOMETRY (never from any calibration result): rebuilds the seeded scenes of calib_rooms.py
without rendering and measures, for each image and each world axis, the visible projected length
of the scene's edges along that axis.

    blender -b -P scripts/blender/calib_rooms_labels.py -- --out test/data/calib_rooms \
        [--count 32] [--seed 19] [--only N] [--draw DIR]

--draw DIR writes each image with its visible axis lines drawn (x red, y green, z blue; dark
when shorter than 5 % of the diagonal) as DIR/room_NNN.png; --only N does image N alone (and
writes a labels.csv of that image only: use a scratch --out).

Rule (fixed before any image's outcome was looked at):
  - an edge is a mesh edge whose two faces meet at 30 deg or more (or a boundary edge): box
    edges count, the facets of a 32-sided cylinder do not; texture lines do not count;
  - it runs along a world axis when its direction is within 1 deg of it;
  - edges on the same 3D line (lines within 2 cm of each other) are one line;
  - a line's visible length is the length, in pixels of the image, of the parts of it that are
    inside the frame, in front of the camera and not hidden (sample points along the edge,
    Blender's scene.ray_cast from the camera centre to each; the distorted images project
    through their k1);
  - an axis is labellable when at least two distinct lines along it each show at least 5 % of
    the image diagonal (40 px on 640x480): a vanishing point needs two lines;
  - an image is labelled when all three axes are.

The camera of every rebuilt scene is checked against truth.csv (rotation to 1e-6, focal to
1e-4 px): the script stops if a scene is not the one that was rendered.

Writes labels.csv beside truth.csv (atomically), one row per image:
name,labelled,x_lines,y_lines,z_lines,x_len1,x_len2,y_len1,y_len2,z_len1,z_len2
where a_lines is the number of distinct lines along axis a with >= 5 % of the diagonal visible
and a_len1, a_len2 the visible lengths (px) of its two longest lines.
"""
import math
import os
import random
import sys

import bpy
from mathutils import Vector

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import calib_rooms as cr  # noqa: E402  (the scene builder, same random draws)

MIN_FRACTION = 0.05  # of the image diagonal
MIN_LINES = 2
AXIS_TOL_DEG = 1.0
FEATURE_DEG = 30.0
SAME_LINE_M = 0.02


def parse_args():
    return cr.parse_args({"out": "calib_rooms", "count": 32, "seed": 19, "only": -1, "draw": ""})


def read_truth(path):
    out = {}
    with open(path) as fh:
        for line in fh.read().splitlines()[1:]:
            t = line.split(",")
            if len(t) >= 18:
                out[t[0]] = t
    return out


def feature_edges(ob):
    """World-space end points of the object's feature edges (faces meeting at >= 30 deg)."""
    me = ob.data
    mw = ob.matrix_world
    nrm = mw.to_3x3().inverted().transposed()
    faces_of = {}
    for p in me.polygons:
        for ek in p.edge_keys:
            faces_of.setdefault(ek, []).append((nrm @ p.normal).normalized())
    cos_lim = math.cos(math.radians(FEATURE_DEG))
    out = []
    for (i, j), ns in faces_of.items():
        if len(ns) == 2 and ns[0].dot(ns[1]) > cos_lim:
            continue
        out.append((mw @ me.vertices[i].co, mw @ me.vertices[j].co))
    return out


def project(R, C, f, cx, cy, k1, p):
    """Pixel of world point p (OpenCV camera: X_cam = R (X - C)), or None behind the camera."""
    d = p - C
    xc = [sum(R[r][k] * d[k] for k in range(3)) for r in range(3)]
    if xc[2] <= 0.05:
        return None
    x, y = xc[0] / xc[2], xc[1] / xc[2]
    if k1 != 0.0:
        # Beyond the fold of a barrel lens (d r_d / d r_u = 0) the model maps points of no
        # image back into the frame: not seen.
        if k1 < 0 and x * x + y * y >= 1 / (-3 * k1):
            return None
        s = 1 + k1 * (x * x + y * y)
        x, y = x * s, y * s
    return (cx + f * x, cy + f * y)


def visible_pieces(scene, depsgraph, C, R, f, cx, cy, k1, W, H, a, b, axis):
    """The visible pieces of edge a-b (along world axis @p axis), each as its interval of the
    axis coordinate, its length in pixels and its image end points."""
    pa = project(R, C, f, cx, cy, k1, a)
    pb = project(R, C, f, cx, cy, k1, b)
    # Sample about every 2 px of the projection (every 1 cm when an end is behind the camera).
    if pa and pb:
        n = int(min(400, max(8, math.hypot(pa[0] - pb[0], pa[1] - pb[1]) / 2)))
    else:
        n = int(min(400, max(8, (b - a).length / 0.01)))
    pts = []
    for s in range(n + 1):
        p = a.lerp(b, s / n)
        q = project(R, C, f, cx, cy, k1, p)
        vis = False
        if q and -0.5 <= q[0] <= W - 0.5 and -0.5 <= q[1] <= H - 0.5:
            d = p - C
            dist = d.length
            hit, loc, _, _, _, _ = scene.ray_cast(depsgraph, C, d / dist, distance=dist - 0.005)
            vis = not hit
        pts.append((q, vis))
    segs = []  # (axis coordinate interval t0 < t1, its pixels, image end points)
    for s in range(n):
        (q0, v0), (q1, v1) = pts[s], pts[s + 1]
        if v0 and v1:
            t0, t1 = a.lerp(b, s / n)[axis], a.lerp(b, (s + 1) / n)[axis]
            segs.append((min(t0, t1), max(t0, t1), math.hypot(q1[0] - q0[0], q1[1] - q0[1]),
                         q0, q1))
    return segs


def union_length(segs):
    """Pixels of a line's visible pieces, a piece that overlaps (along the axis) pieces of an
    edge already counted counting only for its uncovered part: two boxes sharing an edge show
    one line, not one twice as long."""
    L, end = 0.0, -math.inf  # pieces in order of t0: what is covered is (.., end]
    for t0, t1, px, _, _ in sorted(segs, key=lambda x: x[0]):
        if t1 > t0:
            L += px * max(0.0, t1 - max(t0, end)) / (t1 - t0)
            end = max(end, t1)
    return L


def label_image(a_truth, W, H):
    scene = bpy.context.scene
    depsgraph = bpy.context.evaluated_depsgraph_get()
    cam = scene.camera
    C = cam.matrix_world.translation.copy()
    f = float(a_truth[4])
    cx, cy, k1 = float(a_truth[5]), float(a_truth[6]), float(a_truth[7])
    R = [[float(a_truth[9 + 3 * r + c]) for c in range(3)] for r in range(3)]
    axes = [Vector((1, 0, 0)), Vector((0, 1, 0)), Vector((0, 0, 1))]
    cos_tol = math.cos(math.radians(AXIS_TOL_DEG))
    lines = [[], [], []]  # per axis: [(point on line, visible length)]
    for ob in scene.objects:
        if ob.type != "MESH":
            continue
        for p, q in feature_edges(ob):
            d = q - p
            if d.length < 1e-6:
                continue
            u = d.normalized()
            for ax in range(3):
                if abs(u.dot(axes[ax])) < cos_tol:
                    continue
                segs = visible_pieces(scene, depsgraph, C, R, f, cx, cy, k1, W, H, p, q, ax)
                if not segs:
                    continue
                # The line's position across the axis (the other two coordinates at the middle).
                m = (p + q) / 2
                key = [m[k] for k in range(3) if k != ax]
                for e in lines[ax]:
                    if math.hypot(e[0][0] - key[0], e[0][1] - key[1]) < SAME_LINE_M:
                        e[2] += segs
                        break
                else:
                    lines[ax].append([key, 0.0, segs])
    for ax in range(3):
        for e in lines[ax]:
            e[1] = union_length(e[2])
    diag = math.hypot(W, H)
    res = []
    for ax in range(3):
        ls = sorted((e[1] for e in lines[ax]), reverse=True)
        n = sum(1 for x in ls if x >= MIN_FRACTION * diag)
        res.append((n, ls[0] if ls else 0.0, ls[1] if len(ls) > 1 else 0.0))
    return res, lines


def draw(src, dst, lines, W, H, diag):
    """The image with every visible axis line drawn (x red, y green, z blue; bright when it
    counts, >= 5 % of the diagonal, dark otherwise)."""
    img = bpy.data.images.load(src)
    px = list(img.pixels[:])
    for ax in range(3):
        for _, L, segs in lines[ax]:
            col = [0.0, 0.0, 0.0]
            col[ax] = 1.0 if L >= MIN_FRACTION * diag else 0.35
            for _, _, _, q0, q1 in segs:
                m = int(max(abs(q1[0] - q0[0]), abs(q1[1] - q0[1]))) + 1
                for k in range(m + 1):
                    u = int(round(q0[0] + (q1[0] - q0[0]) * k / m))
                    v = int(round(q0[1] + (q1[1] - q0[1]) * k / m))
                    if 0 <= u < W and 0 <= v < H:
                        o = ((H - 1 - v) * W + u) * 4
                        px[o:o + 3] = col
    out = bpy.data.images.new("drawn", W, H, alpha=False)
    out.pixels[:] = px
    out.file_format = "PNG"
    out.filepath_raw = dst
    out.save()


def main():
    a = parse_args()
    truth = read_truth(os.path.join(a["out"], "truth.csv"))
    rows = []
    W, H = cr.W, cr.H
    for idx in range(a["count"]):
        name = "room_%03d.jpg" % idx
        if name not in truth or (a["only"] >= 0 and idx != a["only"]):
            continue
        t = truth[name]
        # The same random draws as calib_rooms.main() up to the camera.
        rng = random.Random(a["seed"] * 1000 + idx)
        distorted, f35, k1, f = cr.draw_lens(rng, idx)
        cr.clear_scene()
        corridor, X, Y, Z = cr.build_scene(rng, idx)
        R = cr.place_camera(rng, corridor, X, Y, Z, f35, cr.lens_overscan(f, k1))
        dR = max(abs(R[i][j] - float(t[9 + 3 * i + j])) for i in range(3) for j in range(3))
        df = abs(f - float(t[4]))
        dk = abs(k1 - float(t[7]))
        if dR > 1e-6 or df > 1e-4 or dk > 1e-6:
            raise SystemExit("%s: rebuilt camera differs from truth.csv (R %.2g, f %.2g px, "
                             "k1 %.2g): not the rendered scene" % (name, dR, df, dk))
        bpy.context.view_layer.update()
        res, lines = label_image(t, W, H)
        if a["draw"]:
            os.makedirs(a["draw"], exist_ok=True)
            draw(os.path.join(a["out"], name), os.path.join(a["draw"], name[:-4] + ".png"), lines,
                 W, H, math.hypot(W, H))
        labelled = all(n >= MIN_LINES for n, _, _ in res)
        rows.append(",".join([name, "1" if labelled else "0"] + ["%d" % n for n, _, _ in res] +
                             ["%.1f,%.1f" % (l1, l2) for _, l1, l2 in res]))
        print("calib_rooms_labels: %s camera matches truth (R %.1e, f %.1e px); lines x/y/z %d/%d/%d"
              " -> %s" % (name, dR, df, res[0][0], res[1][0], res[2][0],
                          "labelled" if labelled else "NOT labelled"), flush=True)
    path = os.path.join(a["out"], "labels.csv")
    with open(path + ".tmp", "w") as fh:
        fh.write("name,labelled,x_lines,y_lines,z_lines,x_len1,x_len2,y_len1,y_len2,z_len1,z_len2\n")
        fh.write("\n".join(rows) + "\n")
    os.replace(path + ".tmp", path)


if __name__ == "__main__":
    main()
