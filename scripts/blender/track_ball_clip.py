# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Renders a phone-like test clip for vbme_track with Blender (Cycles, CPU).

A pale, low-saturation ping-pong ball rolls away from a hand-held camera along a glossy,
warm-brown table that mirrors it (perspective shrink > 3x), decelerating (motion blur while it
is fast and near), passes behind a standing box (a stretch where it is hidden), while an orange
bat (same hue as the ball) lies in the background. With --inseparable the ball shows the
table's own apparent colour and grain (the tracker must refuse it on frame 0).

Writes into OUT:
  frame_0000.png ...   the rendered frames (8-bit sRGB)
  mask_0000.png ...    the ball's visible pixels (object-index pass; 255 = ball)
  truth.csv            frame,cx,cy,r,visible_fraction: the ball's silhouette at mid-exposure
                       (a circle fitted to the projected tangent circle of the sphere) and the
                       fraction of that disk covered by the visible-ball mask

Usage:
  blender -b -t 2 -P scripts/blender/track_ball_clip.py -- --out DIR [--frames 48]
      [--width 640 --height 360 --samples 16] [--inseparable] [--seed 3]
Then scripts/blender/phone_media.sh makes the phone-like videos from DIR.
"""
import argparse
import csv
import math
import os
import random
import sys

import bpy
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--out", required=True)
ap.add_argument("--frames", type=int, default=48)
ap.add_argument("--width", type=int, default=640)
ap.add_argument("--height", type=int, default=360)
ap.add_argument("--samples", type=int, default=16)
ap.add_argument("--seed", type=int, default=3)
ap.add_argument("--hide-from", type=int, default=14, help="first frame fully hidden")
ap.add_argument("--hide-to", type=int, default=18, help="first frame visible again (approx.)")
ap.add_argument("--only", default="", help="comma-separated frames to render (preview)")
ap.add_argument("--inseparable", action="store_true", help="ball showing the table's colour")
args = ap.parse_args(argv)
os.makedirs(args.out, exist_ok=True)
rng = random.Random(args.seed)

# ---- scene ---------------------------------------------------------------------------------
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = args.samples
scene.cycles.use_denoising = False
scene.cycles.sample_clamp_indirect = 3.0
scene.cycles.blur_glossy = 1.0
scene.cycles.max_bounces = 4
scene.render.resolution_x = args.width
scene.render.resolution_y = args.height
scene.render.resolution_percentage = 100
scene.render.fps = 30
scene.frame_start = 0
scene.frame_end = args.frames - 1
scene.render.use_motion_blur = True
scene.render.motion_blur_shutter = 0.5  # 1/60 s at 30 fps, centred on the frame time
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.render.film_transparent = False


def principled(name, rgb, roughness, specular=0.5, coat=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    b = m.node_tree.nodes["Principled BSDF"]
    b.inputs["Base Color"].default_value = (*rgb, 1)
    b.inputs["Roughness"].default_value = roughness
    b.inputs["Specular"].default_value = specular
    b.inputs["Clearcoat"].default_value = coat
    b.inputs["Clearcoat Roughness"].default_value = 0.03
    return m, b


def wood(name):
    """Glossy warm-brown varnished table with a stretched-noise grain."""
    m, b = principled(name, (0.1, 0.04, 0.015), 0.2, specular=0.5, coat=1.0)
    nt = m.node_tree
    tex = nt.nodes.new("ShaderNodeTexNoise")
    tex.inputs["Scale"].default_value = 6.0
    tex.inputs["Detail"].default_value = 6.0
    tex.inputs["Distortion"].default_value = 2.0
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (1.0, 12.0, 1.0)  # grain along x
    coord = nt.nodes.new("ShaderNodeTexCoord")
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.06, 0.02, 0.008, 1)
    ramp.color_ramp.elements[1].color = (0.15, 0.055, 0.022, 1)
    nt.links.new(coord.outputs["Object"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], b.inputs["Base Color"])
    return m


table_mat = wood("table")


def table_coloured(name):
    """A ball that shows the table's own apparent colour (sRGB ~ (150, 110, 87), measured on the
    rendered table around the ball) with the same kind of grain, whatever the light."""
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.remove(nt.nodes["Principled BSDF"])
    em = nt.nodes.new("ShaderNodeEmission")
    tex = nt.nodes.new("ShaderNodeTexNoise")
    tex.inputs["Scale"].default_value = 40.0
    ramp = nt.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.elements[0].color = (0.26, 0.13, 0.08, 1)
    ramp.color_ramp.elements[1].color = (0.35, 0.18, 0.11, 1)
    nt.links.new(tex.outputs["Fac"], ramp.inputs["Fac"])
    nt.links.new(ramp.outputs["Color"], em.inputs["Color"])
    nt.links.new(em.outputs["Emission"], nt.nodes["Material Output"].inputs["Surface"])
    return m


ball_mat = (table_coloured("ball") if args.inseparable else
            principled("ball", (0.85, 0.62, 0.42), 0.35)[0])
bat_mat = principled("bat", (0.8, 0.22, 0.03), 0.5)[0]
box_mat = principled("box", (0.12, 0.18, 0.30), 0.6)[0]
wall_mat = principled("wall", (0.55, 0.50, 0.44), 0.9)[0]

bpy.ops.mesh.primitive_plane_add(size=1, location=(0.2, 1.2, 0))
table = bpy.context.object
table.scale = (3.0, 3.2, 1)
table.data.materials.append(table_mat)

bpy.ops.mesh.primitive_plane_add(size=1, location=(0.2, 2.8, 0.8), rotation=(math.pi / 2, 0, 0))
wall = bpy.context.object
wall.scale = (4, 2, 1)
wall.data.materials.append(wall_mat)

R = 0.02  # ping-pong ball radius (m)
bpy.ops.mesh.primitive_uv_sphere_add(radius=R, segments=48, ring_count=24)
ball = bpy.context.object
bpy.ops.object.shade_smooth()
ball.data.materials.append(ball_mat)
ball.pass_index = 1

# Bat: a flat red-orange blade and a handle, far back on the table.
bpy.ops.mesh.primitive_cylinder_add(radius=0.075, depth=0.01, location=(-0.32, 1.75, 0.005))
bat = bpy.context.object
bat.scale = (1.0, 0.85, 1)
bat.data.materials.append(bat_mat)
bpy.ops.mesh.primitive_cube_add(size=1, location=(-0.42, 1.68, 0.012), rotation=(0, 0, 0.6))
handle = bpy.context.object
handle.scale = (0.1, 0.025, 0.02)
handle.data.materials.append(principled("handle", (0.45, 0.3, 0.15), 0.6)[0])

# Lights: a soft ceiling lamp (soft shadow), a window to the side, a dim warm room.
bpy.ops.object.light_add(type="AREA", location=(0.3, 0.9, 1.6))
lamp = bpy.context.object
lamp.data.size = 0.6
lamp.data.energy = 60
lamp.data.color = (1.0, 0.93, 0.82)
bpy.ops.object.light_add(type="AREA", location=(-1.5, 0.8, 1.0), rotation=(0, -1.1, 0))
window = bpy.context.object
window.data.size = 1.0
window.data.energy = 40
window.data.color = (0.9, 0.95, 1.0)
world = bpy.data.worlds.new("room")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.20, 0.17, 0.14, 1)
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
scene.world = world

# ---- motion --------------------------------------------------------------------------------
N = args.frames
CAM = Vector((0.0, 0.0, 0.15))
P0, P1 = Vector((-0.07, 0.34, R)), Vector((0.42, 1.30, R))


def ball_pos(f):
    """Decelerating roll: fast (blurred) near the camera, slow far away."""
    t = min(max(f / (N - 1), 0.0), 1.0)
    s = 1 - (1 - t) ** 1.4
    return P0.lerp(P1, s)


for f in range(-1, N + 1):  # one frame beyond each end so motion blur is defined
    p = ball_pos(f)
    ball.location = p
    dist = (p - P0).length
    ball.rotation_euler = (-dist / R, 0, 0.3)  # rolling
    ball.keyframe_insert("location", frame=f)
    ball.keyframe_insert("rotation_euler", frame=f)

# Box (a standing book) between the camera and the ball's path over the hidden stretch.
def azimuth(p):
    return math.atan2(p.x - CAM.x, p.y - CAM.y)


ph0, ph1 = ball_pos(args.hide_from), ball_pos(args.hide_to - 1)
frac = 0.55
a0 = azimuth(ph0) - R / (ph0 - CAM).length * 1.1
a1 = azimuth(ph1) + R / (ph1 - CAM).length * 1.1
dmid = 0.5 * ((ph0 - CAM).length + (ph1 - CAM).length) * frac
am = 0.5 * (a0 + a1)
width = 2 * dmid * math.tan(0.5 * (a1 - a0))
bpy.ops.mesh.primitive_cube_add(size=1)
box = bpy.context.object
box.location = (CAM.x + dmid * math.sin(am), CAM.y + dmid * math.cos(am), 0.055)
box.rotation_euler = (0, 0, -am)
box.scale = (width, 0.02, 0.11)
box.data.materials.append(box_mat)

# Hand-held camera: smooth random shake of a few tenths of a degree and a few millimetres.
cam_data = bpy.data.cameras.new("phone")
cam_data.sensor_fit = "HORIZONTAL"
cam_data.sensor_width = 36
cam_data.lens = 760 * 36 / args.width * (args.width / 640)  # ~760 px focal at 640 wide
cam = bpy.data.objects.new("phone", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
base_rot = (math.radians(90 - 13.5), 0, 0)
ph = [rng.uniform(0, 6.28) for _ in range(6)]
for f in range(-1, N + 1):
    w = 2 * math.pi * f / 30
    cam.location = CAM + Vector((0.003 * math.sin(1.3 * w + ph[0]), 0.003 * math.sin(0.9 * w + ph[1]),
                                 0.003 * math.sin(1.7 * w + ph[2])))
    cam.rotation_euler = (base_rot[0] + math.radians(0.5) * math.sin(1.1 * w + ph[3]),
                          base_rot[1] + math.radians(0.4) * math.sin(0.7 * w + ph[4]),
                          base_rot[2] + math.radians(0.5) * math.sin(1.4 * w + ph[5]))
    cam.keyframe_insert("location", frame=f)
    cam.keyframe_insert("rotation_euler", frame=f)

# ---- visible-ball mask through the compositor ----------------------------------------------
scene.view_layers[0].use_pass_object_index = True
scene.use_nodes = True
nt = scene.node_tree
for n in list(nt.nodes):
    nt.nodes.remove(n)
rl = nt.nodes.new("CompositorNodeRLayers")
comp = nt.nodes.new("CompositorNodeComposite")
nt.links.new(rl.outputs["Image"], comp.inputs["Image"])
idm = nt.nodes.new("CompositorNodeIDMask")
idm.index = 1
idm.use_antialiasing = False
out = nt.nodes.new("CompositorNodeOutputFile")
out.base_path = args.out
out.format.file_format = "PNG"
out.format.color_mode = "BW"
out.file_slots[0].path = "mask_"
nt.links.new(rl.outputs["IndexOB"], idm.inputs["ID value"])
nt.links.new(idm.outputs["Alpha"], out.inputs[0])


# ---- truth ---------------------------------------------------------------------------------
def silhouette_disk(center):
    """Circle fitted (mean centre, mean distance) to the projected tangent circle of the sphere."""
    cam_pos = cam.matrix_world.translation
    v = center - cam_pos
    d = v.length
    u = v.normalized()
    # Tangent circle: centre at distance d - R^2/d from the camera, radius R*sqrt(1-R^2/d^2).
    c = cam_pos + u * (d - R * R / d)
    rr = R * math.sqrt(1 - (R / d) ** 2)
    a = u.orthogonal().normalized()
    b = u.cross(a)
    pts = []
    for k in range(72):
        th = 2 * math.pi * k / 72
        p = c + rr * (math.cos(th) * a + math.sin(th) * b)
        q = world_to_camera_view(scene, cam, p)
        pts.append((q.x * args.width - 0.5, (1 - q.y) * args.height - 0.5))
    cx = sum(p[0] for p in pts) / len(pts)
    cy = sum(p[1] for p in pts) / len(pts)
    r = sum(math.hypot(p[0] - cx, p[1] - cy) for p in pts) / len(pts)
    return cx, cy, r


def visible_fraction(path, cx, cy, r):
    """Fraction of the truth disk's pixels that the visible-ball mask covers."""
    import array
    img = bpy.data.images.load(path)
    w, h = img.size
    px = array.array("f", [0.0]) * (w * h * img.channels)
    img.pixels.foreach_get(px)
    inside = covered = 0
    for y in range(max(0, int(cy - r) - 1), min(h, int(cy + r) + 2)):
        row = (h - 1 - y) * w  # Blender's pixel rows run bottom-up
        for x in range(max(0, int(cx - r) - 1), min(w, int(cx + r) + 2)):
            if (x - cx) ** 2 + (y - cy) ** 2 <= r * r:
                inside += 1
                if px[(row + x) * img.channels] > 0.5:
                    covered += 1
    bpy.data.images.remove(img)
    return covered / inside if inside else 0.0


only = [int(v) for v in args.only.split(",") if v] or list(range(N))
rows = []
for f in only:
    scene.frame_set(f)
    scene.render.filepath = os.path.join(args.out, "frame_%04d.png" % f)
    bpy.ops.render.render(write_still=True)
    cx, cy, r = silhouette_disk(ball.matrix_world.translation.copy())
    vis = visible_fraction(os.path.join(args.out, "mask_%04d.png" % f), cx, cy, r)
    rows.append((f, cx, cy, r, vis))
    print("frame %d: centre (%.1f, %.1f) r %.2f visible %.3f" % (f, cx, cy, r, vis), flush=True)

with open(os.path.join(args.out, "truth.csv"), "w", newline="") as fh:
    w = csv.writer(fh)
    w.writerow(["frame", "cx", "cy", "r", "visible_fraction"])
    for f, cx, cy, r, vis in rows:
        w.writerow([f, "%.3f" % cx, "%.3f" % cy, "%.3f" % r, "%.4f" % vis])
print("rendered", len(rows), "frames into", args.out)
