# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Checks that Blender's compositor lens (Movie Distortion node, POLYNOMIAL model, k1 only) is
vbme's / OpenCV's k1: a grid of 3x3-pixel dots on a black pinhole image is distorted by the node
and each dot's centroid is compared with where x_d = x (1 + k1 |x|^2), x = (p - c) / f, puts
its centre (c = ((w - 1) / 2, (h - 1) / 2), pixel centres at integers). Used by
calib_rooms.py --lens compositor (the same clip settings).

    blender -b --factory-startup -P scripts/blender/lens_check.py -- [--w 160 --h 120 --f 100
        --k1 -0.2 --step 16]

Prints the largest and the mean centroid error in pixels and the largest displacement.
"""
import os
import sys
import tempfile

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import calib_rooms  # noqa: E402 (the lens settings it renders with)

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
a = {"w": 160, "h": 120, "f": 100.0, "k1": -0.2, "step": 16}
for i in range(0, len(argv), 2):
    k = argv[i].lstrip("-")
    a[k] = type(a[k])(argv[i + 1])
W, H, f, k1, step = a["w"], a["h"], a["f"], a["k1"], a["step"]
cx, cy = (W - 1) / 2.0, (H - 1) / 2.0
tmp = tempfile.mkdtemp()

# the pinhole image: dots centred on integer pixels (Blender stores rows bottom-up)
px = [0.0] * (W * H * 4)
px[3::4] = [1.0] * (W * H)
dots = []
for v in range(4, H - 4, step):
    for u in range(4, W - 4, step):
        dots.append((u, v))
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                i = ((H - 1 - (v + dy)) * W + u + dx) * 4
                px[i:i + 3] = [1.0, 1.0, 1.0]
img = bpy.data.images.new("dots", W, H, float_buffer=True)
img.pixels[:] = px
img.filepath_raw = os.path.join(tmp, "dots.png")
img.file_format = "PNG"
img.save()

# the lens: calib_rooms.py's own movie clip settings
clip = calib_rooms.lens_clip(img.filepath_raw, f, k1)

sc = bpy.context.scene
sc.render.resolution_x, sc.render.resolution_y = W, H
sc.render.resolution_percentage = 100
sc.render.engine = "BLENDER_WORKBENCH"
sc.view_settings.view_transform = "Standard"
if sc.camera is None:
    c = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    sc.collection.objects.link(c)
    sc.camera = c
sc.use_nodes = True
nt = sc.node_tree
for n in list(nt.nodes):
    nt.nodes.remove(n)
src = nt.nodes.new("CompositorNodeImage")
src.image = img
md = nt.nodes.new("CompositorNodeMovieDistortion")
md.clip = clip
md.distortion_type = "DISTORT"
out = nt.nodes.new("CompositorNodeComposite")
nt.links.new(src.outputs[0], md.inputs[0])
nt.links.new(md.outputs[0], out.inputs[0])
sc.render.filepath = os.path.join(tmp, "out.png")
sc.render.image_settings.file_format = "PNG"
bpy.ops.render.render(write_still=True)

res = bpy.data.images.load(sc.render.filepath)
rp = list(res.pixels[:])
worst, total, n, moved = 0.0, 0.0, 0, 0.0
for u, v in dots:
    x, y = (u - cx) / f, (v - cy) / f
    s = 1 + k1 * (x * x + y * y)
    ud, vd = cx + f * x * s, cy + f * y * s
    sw = sx = sy = 0.0
    for yy in range(int(vd) - 4, int(vd) + 6):
        for xx in range(int(ud) - 4, int(ud) + 6):
            if 0 <= xx < W and 0 <= yy < H:
                g = rp[((H - 1 - yy) * W + xx) * 4]
                if g > 0.05:
                    sw, sx, sy = sw + g, sx + g * xx, sy + g * yy
    if sw == 0:
        continue
    e = ((sx / sw - ud) ** 2 + (sy / sw - vd) ** 2) ** 0.5
    worst, total, n = max(worst, e), total + e, n + 1
    moved = max(moved, ((u - ud) ** 2 + (v - vd) ** 2) ** 0.5)
print("lens_check: %dx%d f %.1f k1 %.3f: %d dots, centroid error max %.3f px, mean %.3f px; "
      "largest displacement %.1f px" % (W, H, f, k1, n, worst, total / max(n, 1), moved))
