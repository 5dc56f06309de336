# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Renders a test clip for object removal with Blender Cycles (not vbme's renderer).

An orange ball rolls over a striped wooden floor in front of a brick wall and a crate, lit by
a soft sun (key light) and a sky, filmed by a hand-held camera. Three renders per frame
(the scene with the ball; the same frame without the ball, the clean plate that is the oracle
of the fill; the ball alone on a transparent film), stored in OUT as
  frames.mkv      the scene with the ball (FFV1, lossless),
  clean.mkv       the clean plate near the ball (FFV1, lossless): within 3 ball radii of the
                  ball's bounding box, black elsewhere to keep the file small,
  ball_%05d.png   the ball's coverage (its alpha, 8-bit; 0 = background).
The ball's cast shadow is where frame / clean < 1 outside the ball; the tests derive it.
Needs ffmpeg (Debian package) for the FFV1 files.

Usage (from the repository root):
  blender -b -P scripts/blender/inpaint_clip.py -- --case static --out DIR [--frames 24]
      [--width 320 --height 180 --samples 48] [--grain] [--travel 1.8]
The committed clips: test/data/inpaint_static (--case static) and test/data/inpaint_pan
(--case pan --frames 20 --samples 32 --grain --travel 1.0) and test/data/inpaint_static_glass
(--case static --frame-list 0,4,8 --samples 128 --glass: frames.mkv only, the ball in glass).
Cases: "static" (a tripod-less but standing camera: small hand-held shake) and "pan" (the
camera travels sideways and turns, so that floor, crate and wall move with parallax).
Renders are deterministic (fixed Cycles seed, same for every frame).
"""
import argparse
import math
import os
import random
import shutil
import subprocess
import sys

import bpy
from mathutils import Vector

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
ap = argparse.ArgumentParser()
ap.add_argument("--case", choices=["static", "pan"], default="static")
ap.add_argument("--out", required=True)
ap.add_argument("--frames", type=int, default=24)
ap.add_argument("--width", type=int, default=320)
ap.add_argument("--height", type=int, default=180)
ap.add_argument("--samples", type=int, default=48)
ap.add_argument("--grain", action="store_true", help="2-D grain on the floor's bands")
ap.add_argument("--travel", type=float, default=1.8, help="pan: the camera's sideways travel (m)")
ap.add_argument("--frame-list", default="",
                help="comma-separated frame indices of the N-frame clip to render (default: all)")
ap.add_argument("--glass", action="store_true",
                help="the ball in clear glass (IOR 1.5), its caustic path traced")
args = ap.parse_args(argv)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = args.samples
scene.cycles.use_denoising = False
scene.cycles.seed = 0
scene.cycles.use_animated_seed = False
scene.cycles.max_bounces = 4
scene.render.resolution_x = args.width
scene.render.resolution_y = args.height
scene.render.resolution_percentage = 100
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.render.image_settings.color_depth = "8"
scene.view_settings.view_transform = "Standard"
scene.view_settings.look = "None"
scene.render.filter_size = 1.5


def node_mat(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    bsdf = nt.nodes.new("ShaderNodeBsdfPrincipled")
    nt.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return m, nt, bsdf


# Floor: striped wood (wave bands distorted by noise, two browns, fine grain).
floor_mat, nt, bsdf = node_mat("wood")
tc = nt.nodes.new("ShaderNodeTexCoord")
wave = nt.nodes.new("ShaderNodeTexWave")
wave.wave_type = "BANDS"
wave.bands_direction = "X"
wave.inputs["Scale"].default_value = 2.0
wave.inputs["Distortion"].default_value = 3.0
wave.inputs["Detail"].default_value = 1.5
nt.links.new(tc.outputs["Object"], wave.inputs["Vector"])
ramp = nt.nodes.new("ShaderNodeValToRGB")
ramp.color_ramp.elements[0].color = (0.16, 0.07, 0.025, 1)
ramp.color_ramp.elements[1].color = (0.55, 0.32, 0.14, 1)
nt.links.new(wave.outputs["Fac"], ramp.inputs["Fac"])
checker = nt.nodes.new("ShaderNodeTexChecker")  # planks: alternate tone per board
checker.inputs["Scale"].default_value = 6.0
checker.inputs["Color1"].default_value = (1.0, 1.0, 1.0, 1)
checker.inputs["Color2"].default_value = (0.75, 0.7, 0.65, 1)
nt.links.new(tc.outputs["Object"], checker.inputs["Vector"])
mix = nt.nodes.new("ShaderNodeMixRGB")
mix.blend_type = "MULTIPLY"
mix.inputs["Fac"].default_value = 1.0
nt.links.new(ramp.outputs["Color"], mix.inputs["Color1"])
nt.links.new(checker.outputs["Color"], mix.inputs["Color2"])
if args.grain:
    # Fine 2-D grain (knots, pores): the bands alone are nearly one-dimensional, which
    # leaves an aligner nothing to lock onto along them.
    grain = nt.nodes.new("ShaderNodeTexNoise")
    grain.inputs["Scale"].default_value = 40.0
    grain.inputs["Detail"].default_value = 4.0
    nt.links.new(tc.outputs["Object"], grain.inputs["Vector"])
    gr = nt.nodes.new("ShaderNodeValToRGB")
    gr.color_ramp.elements[0].color = (0.7, 0.7, 0.7, 1)
    gr.color_ramp.elements[1].color = (1.2, 1.2, 1.2, 1)
    nt.links.new(grain.outputs["Fac"], gr.inputs["Fac"])
    mix2 = nt.nodes.new("ShaderNodeMixRGB")
    mix2.blend_type = "MULTIPLY"
    mix2.inputs["Fac"].default_value = 1.0
    nt.links.new(mix.outputs["Color"], mix2.inputs["Color1"])
    nt.links.new(gr.outputs["Color"], mix2.inputs["Color2"])
    nt.links.new(mix2.outputs["Color"], bsdf.inputs["Base Color"])
else:
    nt.links.new(mix.outputs["Color"], bsdf.inputs["Base Color"])
bsdf.inputs["Roughness"].default_value = 0.8
bsdf.inputs["Specular"].default_value = 0.2

bpy.ops.mesh.primitive_plane_add(size=24, location=(0, 4, 0))
floor = bpy.context.active_object
floor.data.materials.append(floor_mat)

# Wall: bricks.
wall_mat, nt, bsdf = node_mat("brick")
tc = nt.nodes.new("ShaderNodeTexCoord")
brick = nt.nodes.new("ShaderNodeTexBrick")
brick.inputs["Scale"].default_value = 6.0
brick.inputs["Color1"].default_value = (0.45, 0.12, 0.07, 1)
brick.inputs["Color2"].default_value = (0.30, 0.09, 0.05, 1)
brick.inputs["Mortar"].default_value = (0.6, 0.58, 0.52, 1)
brick.inputs["Mortar Size"].default_value = 0.02
nt.links.new(tc.outputs["Object"], brick.inputs["Vector"])
nt.links.new(brick.outputs["Color"], bsdf.inputs["Base Color"])
bsdf.inputs["Roughness"].default_value = 0.9
bsdf.inputs["Specular"].default_value = 0.1
bpy.ops.mesh.primitive_plane_add(size=12, location=(0, 3.2, 3), rotation=(math.pi / 2, 0, 0))
wall = bpy.context.active_object
wall.data.materials.append(wall_mat)

# A crate nearer the camera than the wall (a second depth for parallax).
crate_mat, nt, bsdf = node_mat("crate")
tc = nt.nodes.new("ShaderNodeTexCoord")
noise = nt.nodes.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 12.0
noise.inputs["Detail"].default_value = 6.0
nt.links.new(tc.outputs["Object"], noise.inputs["Vector"])
ramp = nt.nodes.new("ShaderNodeValToRGB")
ramp.color_ramp.elements[0].color = (0.15, 0.25, 0.35, 1)
ramp.color_ramp.elements[1].color = (0.6, 0.65, 0.55, 1)
nt.links.new(noise.outputs["Fac"], ramp.inputs["Fac"])
nt.links.new(ramp.outputs["Color"], bsdf.inputs["Base Color"])
bsdf.inputs["Roughness"].default_value = 0.7
bpy.ops.mesh.primitive_cube_add(size=0.6, location=(-1.3, 1.6, 0.3))
crate = bpy.context.active_object
crate.data.materials.append(crate_mat)

# The ball: orange with a darker band, so that its rolling shows.
ball_mat, nt, bsdf = node_mat("ball")
tc = nt.nodes.new("ShaderNodeTexCoord")
chk = nt.nodes.new("ShaderNodeTexChecker")
chk.inputs["Scale"].default_value = 2.0
chk.inputs["Color1"].default_value = (0.8, 0.25, 0.02, 1)
chk.inputs["Color2"].default_value = (0.55, 0.15, 0.01, 1)
nt.links.new(tc.outputs["Object"], chk.inputs["Vector"])
nt.links.new(chk.outputs["Color"], bsdf.inputs["Base Color"])
bsdf.inputs["Roughness"].default_value = 0.35
R = 0.22
bpy.ops.mesh.primitive_uv_sphere_add(radius=R, segments=48, ring_count=24, location=(0, 0, R))
bpy.ops.object.shade_smooth()
ball = bpy.context.active_object
ball.data.materials.append(ball_mat)
if args.glass:
    gm = bpy.data.materials.new("glass")
    gm.use_nodes = True
    gnt = gm.node_tree
    for n in list(gnt.nodes):
        if n.type != "OUTPUT_MATERIAL":
            gnt.nodes.remove(n)
    glass = gnt.nodes.new("ShaderNodeBsdfGlass")
    glass.inputs["IOR"].default_value = 1.5
    glass.inputs["Roughness"].default_value = 0.0
    gnt.links.new(glass.outputs["BSDF"], gnt.nodes["Material Output"].inputs["Surface"])
    ball.data.materials[0] = gm
    # The sun's light refracted onto the floor is path traced (the sun is 6 degrees wide, so
    # BSDF samples reach it): Cycles' manifold next-event estimation (shadow caustics) lost
    # energy with this sun in a trial (shadow region mean 0.59 against 0.70 without it).

# Light: a soft sun (about 6 degrees wide) from the front left, and a sky.
sun_data = bpy.data.lights.new("sun", type="SUN")
sun_data.energy = 3.5
sun_data.angle = math.radians(6)
sun = bpy.data.objects.new("sun", sun_data)
scene.collection.objects.link(sun)
sun.rotation_euler = (math.radians(40), math.radians(-25), math.radians(-20))
world = bpy.data.worlds.new("sky")
scene.world = world
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
bg.inputs["Color"].default_value = (0.45, 0.6, 0.85, 1)
bg.inputs["Strength"].default_value = 0.6

# Camera.
cam_data = bpy.data.cameras.new("cam")
cam_data.lens = 32
cam = bpy.data.objects.new("cam", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam

rng = random.Random(14)
N = args.frames
shake = [(rng.gauss(0, 1), rng.gauss(0, 1), rng.gauss(0, 1)) for _ in range(N + 4)]


def smooth(i, k):
    return sum(shake[i + j][k] for j in range(4)) / 2.0


def place(i):
    u = i / max(1, N - 1)
    # Ball: rolls along +x, 1.9 m over the clip, without slipping.
    x = -0.95 + 1.9 * u
    ball.location = (x, 0.55, R)
    ball.rotation_euler = (0, x / R, 0)
    if args.case == "static":
        eye = Vector((0.05 * smooth(i, 0) * 0.02, -2.6, 1.15))
        target = Vector((0, 0.9, 0.25))
        roll = math.radians(0.3) * smooth(i, 2)
        eye.z += 0.004 * smooth(i, 1)
    else:
        h = args.travel / 2
        eye = Vector((-h + 2 * h * u, -2.6 + 0.2 * u, 1.15 + 0.004 * smooth(i, 1)))
        target = Vector((-0.2 * h / 0.9 + 0.4 * h / 0.9 * u, 0.9, 0.25))
        roll = math.radians(0.3) * smooth(i, 2)
    cam.location = eye
    d = target - eye
    q = d.to_track_quat("-Z", "Y")
    cam.rotation_euler = q.to_euler()
    cam.rotation_euler.rotate_axis("Z", roll)
    # Hand-held: small pan/tilt jitter (about 0.15 degrees).
    cam.rotation_euler.rotate_axis("X", math.radians(0.15) * smooth(i, 1))
    cam.rotation_euler.rotate_axis("Y", math.radians(0.15) * smooth(i, 0))


os.makedirs(args.out, exist_ok=True)
others = [floor, wall, crate]
FRAMES = [int(v) for v in args.frame_list.split(",")] if args.frame_list else list(range(N))
for j, i in enumerate(FRAMES):
    place(i)
    bpy.context.view_layer.update()
    scene.render.film_transparent = False
    ball.hide_render = False
    scene.render.filepath = os.path.join(args.out, "frame_%05d.png" % j)
    bpy.ops.render.render(write_still=True)
    ball.hide_render = True
    scene.render.filepath = os.path.join(args.out, "clean_%05d.png" % j)
    bpy.ops.render.render(write_still=True)
    # The ball alone on a transparent film: its alpha is the ball's coverage.
    ball.hide_render = False
    for o in others:
        o.hide_render = True
    sun.hide_render = True
    scene.render.film_transparent = True
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = os.path.join(args.out, "ball_rgba_%05d.png" % j)
    bpy.ops.render.render(write_still=True)
    scene.render.image_settings.color_mode = "RGB"
    sun.hide_render = False
    for o in others:
        o.hide_render = False
print("done", args.case, len(FRAMES))


def load(path):
    """Pixels of an image as a flat list, rows from the top, and its size and channels."""
    img = bpy.data.images.load(path)
    w, h = img.size
    c = img.channels
    flat = list(img.pixels[:])
    bpy.data.images.remove(img)
    rows = [flat[(h - 1 - y) * w * c:(h - y) * w * c] for y in range(h)]
    return [v for r in rows for v in r], w, h, c


def save(path, flat, w, h, noncolor=False):
    """Writes an RGB image given as a flat top-first list of RGB floats."""
    img = bpy.data.images.new("tmp", w, h, alpha=False)
    if noncolor:
        img.colorspace_settings.name = "Non-Color"
    px = []
    for y in range(h - 1, -1, -1):
        for x in range(w):
            k = (y * w + x) * 3
            px.extend((flat[k], flat[k + 1], flat[k + 2], 1.0))
    img.pixels[:] = px
    img.filepath_raw = path
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


tmp = os.path.join(args.out, "tmp")
os.makedirs(tmp, exist_ok=True)
for i in range(len(FRAMES)):
    fr = os.path.join(args.out, "frame_%05d.png" % i)
    cl = os.path.join(args.out, "clean_%05d.png" % i)
    rgba = os.path.join(args.out, "ball_rgba_%05d.png" % i)
    ba, w, h, c = load(rgba)
    cover = [min(255, max(0, round(ba[k * c + 3] * 255))) for k in range(w * h)]
    pts = [(k % w, k // w) for k in range(w * h) if cover[k] > 0]
    x0 = y0 = x1 = y1 = -1
    if pts:
        xs = [p[0] for p in pts]
        ys = [p[1] for p in pts]
        r = max(max(xs) - min(xs), max(ys) - min(ys)) / 2.0
        m = int(math.ceil(3 * r))
        x0, x1, y0, y1 = min(xs) - m, max(xs) + m, min(ys) - m, max(ys) + m
    cp, w, h, c = load(cl)
    clean = []
    for k in range(w * h):
        x, y = k % w, k // w
        inside = x0 <= x <= x1 and y0 <= y <= y1
        clean.extend(cp[k * c:k * c + 3] if inside else (0.0, 0.0, 0.0))
    save(os.path.join(tmp, "clean_%05d.png" % i), clean, w, h)
    save(os.path.join(args.out, "ball_%05d.png" % i),
         [v / 255.0 for v in cover for _ in range(3)], w, h, noncolor=True)
    os.replace(fr, os.path.join(tmp, "frame_%05d.png" % i))
    os.remove(cl)
    os.remove(rgba)
for name in ("frame", "clean"):
    subprocess.check_call(["ffmpeg", "-loglevel", "error", "-y", "-framerate", "24", "-i",
                           os.path.join(tmp, name + "_%05d.png"), "-c:v", "ffv1", "-level", "3",
                           "-pix_fmt", "bgr0",
                           os.path.join(args.out, ("frames" if name == "frame" else name) + ".mkv")])
shutil.rmtree(tmp)
print("stored", args.out)
