# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Renders a hand-held clip of a lit room with Cycles twice, without and with a synthetic object,
and writes the truth an insertion needs in vbme's conventions: the true cameras, the frame-0
scene with the room, the light and the object. It is the test footage of object insertion that
vbme's own renderer did not make (issue 21: camera effects are added to both clips afterwards,
in the tests, so that the truth carries exactly the same effects as the input).

    blender -b -P scripts/blender/insertion_clip.py -- OUT_DIR [--frames 24] [--samples 128]
        [--width 320] [--height 180] [--threads 2]

Writes into OUT_DIR:
  plate.mkv      the room without the object (FFV1, lossless, 8-bit sRGB): vbme's input
  truth.mkv      the same frames with the object in the room (shadow, interreflections)
  cameras.yml    the true camera path (K, frames: cam_from_world, OpenCV axes)
  scene.yml      the frame-0 scene: camera, room box, the ceiling light, the object
  sphere.obj     the object's mesh (the one Blender renders)

The room is the 4 x 5 x 2.6 m box of camera_track_clip.py (x in [-2, 2], y in [-1, 4],
z in [0, 2.6], z up, floor at z = 0) with diffuse walls whose albedo is procedural (0.1..0.8),
lit only by one square ceiling panel (an emissive polygon, emitting downwards) so that all the
light in the room is the annotated light and what the walls reflect. The camera walks slowly
with a hand shake, then pans 24 degrees in 8 frames (motion blur, shutter half a frame). The
object is a diffuse sphere resting on the floor in front of the camera.
"""
import math
import os
import subprocess
import sys

import bpy
import mathutils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vbme_blender as vb  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    sys.exit("usage: blender -b -P insertion_clip.py -- OUT_DIR [options]")
out_dir = os.path.abspath(argv[0])
opts = {"--frames": 24, "--samples": 128, "--width": 320, "--height": 180, "--threads": 2}
for i in range(1, len(argv) - 1, 2):
    opts[argv[i]] = int(argv[i + 1])
N, W, H = opts["--frames"], opts["--width"], opts["--height"]
FOCAL = 250.0 * W / 320.0  # pixels (65 degrees horizontal field of view)
ROOM_MIN, ROOM_MAX = (-2.0, -1.0, 0.0), (2.0, 4.0, 2.6)
LIGHT_CENTRE, LIGHT_SIDE, LIGHT_RADIANCE = (0.0, 1.6, 2.59), 0.8, (26.0, 24.0, 21.0)
SPHERE_CENTRE, SPHERE_RADIUS = (0.25, 1.9, 0.2), 0.2
SPHERE_ALBEDO = (0.7, 0.42, 0.22)

# ---------------------------------------------------------------- render settings
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = opts["--samples"]
scene.cycles.use_denoising = False
scene.cycles.max_bounces = 4
scene.cycles.diffuse_bounces = 4
scene.cycles.glossy_bounces = 0
scene.cycles.transmission_bounces = 0
scene.cycles.transparent_max_bounces = 0
scene.cycles.sample_clamp_indirect = 0.0
scene.cycles.seed = 1
scene.render.threads_mode = "FIXED"
scene.render.threads = opts["--threads"]
scene.render.resolution_x, scene.render.resolution_y = W, H
scene.render.resolution_percentage = 100
scene.render.fps = 30
scene.render.use_motion_blur = True
scene.render.motion_blur_shutter = 0.5  # of a frame, centred on the frame time
scene.cycles.motion_blur_position = "CENTER"
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.render.image_settings.color_depth = "8"
scene.view_settings.view_transform = "Standard"  # plain sRGB, exposure 0: vbme's `srgb`
scene.view_settings.look = "None"
scene.view_settings.exposure = 0.0
scene.view_settings.gamma = 1.0
scene.frame_start, scene.frame_end = 0, N - 1
world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world


def new_material(name):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    mat.node_tree.nodes.clear()
    return mat, mat.node_tree.nodes, mat.node_tree.links


def add_mesh(name, verts, faces, mat, smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    if smooth:
        for poly in mesh.polygons:
            poly.use_smooth = True
    obj = bpy.data.objects.new(name, mesh)
    obj.data.materials.append(mat)
    scene.collection.objects.link(obj)
    return obj


# ---------------------------------------------------------------- the room (diffuse, inwards)
x0, y0, z0 = ROOM_MIN
x1, y1, z1 = ROOM_MAX
verts = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
walls = [(4, 7, 6, 5), (0, 4, 5, 1), (2, 6, 7, 3), (0, 3, 7, 4), (1, 5, 6, 2)]
floor = [(0, 1, 2, 3)]

mat, n, links = new_material("walls")
coord = n.new("ShaderNodeTexCoord")
noise = n.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 2.0
noise.inputs["Detail"].default_value = 6.0
brick = n.new("ShaderNodeTexBrick")
brick.inputs["Scale"].default_value = 1.5
brick.inputs["Color1"].default_value = (0.75, 0.6, 0.45, 1)
brick.inputs["Color2"].default_value = (0.35, 0.45, 0.6, 1)
brick.inputs["Mortar"].default_value = (0.8, 0.8, 0.78, 1)
for t in (noise, brick):
    links.new(coord.outputs["Object"], t.inputs["Vector"])
mix = n.new("ShaderNodeMixRGB")
mix.blend_type = "MULTIPLY"
mix.inputs["Fac"].default_value = 0.5
links.new(brick.outputs["Color"], mix.inputs["Color1"])
links.new(noise.outputs["Color"], mix.inputs["Color2"])
diffuse = n.new("ShaderNodeBsdfDiffuse")
links.new(mix.outputs["Color"], diffuse.inputs["Color"])
out = n.new("ShaderNodeOutputMaterial")
links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
add_mesh("walls", verts, walls, mat)

mat, n, links = new_material("floor")
coord = n.new("ShaderNodeTexCoord")
checker = n.new("ShaderNodeTexChecker")
checker.inputs["Scale"].default_value = 2.5
checker.inputs["Color1"].default_value = (0.55, 0.42, 0.3, 1)
checker.inputs["Color2"].default_value = (0.3, 0.22, 0.15, 1)
noise = n.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 12.0
noise.inputs["Detail"].default_value = 4.0
for t in (checker, noise):
    links.new(coord.outputs["Object"], t.inputs["Vector"])
mix = n.new("ShaderNodeMixRGB")
mix.blend_type = "OVERLAY"
mix.inputs["Fac"].default_value = 0.35
links.new(checker.outputs["Color"], mix.inputs["Color1"])
links.new(noise.outputs["Color"], mix.inputs["Color2"])
diffuse = n.new("ShaderNodeBsdfDiffuse")
links.new(mix.outputs["Color"], diffuse.inputs["Color"])
out = n.new("ShaderNodeOutputMaterial")
links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
add_mesh("floor", verts, floor, mat)

# ---------------------------------------------------------------- the light: a ceiling panel
cx, cy, cz = LIGHT_CENTRE
h = LIGHT_SIDE / 2
light_corners = [(cx - h, cy - h, cz), (cx - h, cy + h, cz), (cx + h, cy + h, cz),
                 (cx + h, cy - h, cz)]  # counter-clockwise seen from below: normal -z
mat, n, links = new_material("panel")
emit = n.new("ShaderNodeEmission")
emit.inputs["Color"].default_value = (*LIGHT_RADIANCE, 1)
emit.inputs["Strength"].default_value = 1.0
geo = n.new("ShaderNodeNewGeometry")
black = n.new("ShaderNodeEmission")
black.inputs["Strength"].default_value = 0.0
mixs = n.new("ShaderNodeMixShader")
links.new(geo.outputs["Backfacing"], mixs.inputs["Fac"])
links.new(emit.outputs["Emission"], mixs.inputs[1])
links.new(black.outputs["Emission"], mixs.inputs[2])
out = n.new("ShaderNodeOutputMaterial")
links.new(mixs.outputs["Shader"], out.inputs["Surface"])
add_mesh("panel", light_corners, [(0, 1, 2, 3)], mat)

# ---------------------------------------------------------------- the object: a diffuse sphere
STACKS, SLICES = 24, 48
sv, sn, sf = [], [], []
for i in range(STACKS + 1):
    th = math.pi * i / STACKS
    for j in range(SLICES):
        ph = 2 * math.pi * j / SLICES
        d = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
        sn.append(d)
        sv.append(tuple(SPHERE_RADIUS * d[k] for k in range(3)))
for i in range(STACKS):
    for j in range(SLICES):
        a, b = i * SLICES + j, i * SLICES + (j + 1) % SLICES
        c, e = a + SLICES, b + SLICES
        if i > 0:
            sf.append((a, c, b))
        if i < STACKS - 1:
            sf.append((b, c, e))
# Unused pole duplicates are harmless; faces are wound counter-clockwise seen from outside.
os.makedirs(out_dir, exist_ok=True)
with open(os.path.join(out_dir, "sphere.obj"), "w") as fh:
    fh.write("# diffuse sphere of radius %g m centred at the origin (insertion_clip.py)\n" %
             SPHERE_RADIUS)
    for v in sv:
        fh.write("v %.6f %.6f %.6f\n" % v)
    for v in sn:
        fh.write("vn %.6f %.6f %.6f\n" % v)
    for f in sf:
        fh.write("f %d//%d %d//%d %d//%d\n" % (f[0] + 1, f[0] + 1, f[1] + 1, f[1] + 1,
                                                f[2] + 1, f[2] + 1))
mat, n, links = new_material("sphere")
diffuse = n.new("ShaderNodeBsdfDiffuse")
diffuse.inputs["Color"].default_value = (*SPHERE_ALBEDO, 1)
diffuse.inputs["Roughness"].default_value = 0.0
out = n.new("ShaderNodeOutputMaterial")
links.new(diffuse.outputs["BSDF"], out.inputs["Surface"])
sphere = add_mesh("sphere", sv, sf, mat, smooth=True)
sphere.location = SPHERE_CENTRE

# ---------------------------------------------------------------- camera
cam = vb.add_camera(scene, FOCAL, W)
shake_at = vb.HandShake(11)
smoothstep = vb.smoothstep


def pose(f):
    """Camera centre (m) and (yaw, pitch, roll) (rad) at frame f: walk, pan 24 degrees, walk."""
    yaw = math.radians(-3.0) * f / 30.0 + math.radians(24.0) * smoothstep(12, 20, f)
    pitch = 0.42 + 0.03 * math.sin(f / 9.0)
    roll = 0.0
    c = [0.25 * f / 24.0, 0.35 * f / 24.0, 1.45 + 0.03 * math.sin(f / 7.0)]
    for k in range(3):
        c[k] += 0.008 * shake_at(k, f)  # 8 mm
    yaw += math.radians(0.4) * shake_at(3, f)
    pitch += math.radians(0.4) * shake_at(4, f)
    roll += math.radians(0.4) * shake_at(5, f)
    return c, yaw, pitch, roll


vb.animate_camera(cam, pose, N)

# ---------------------------------------------------------------- truth in vbme's conventions
K = vb.intrinsics(FOCAL, W, H)
poses = [vb.cam_from_world(scene, cam, f) for f in range(N)]
vb.write_camera_path(os.path.join(out_dir, "cameras.yml"), (W, H), K, poses)
R0, t0 = poses[0]
with open(os.path.join(out_dir, "scene.yml"), "w") as fh:
    vb.write_scene_camera(fh, (W, H), K, R0, t0)
    fh.write("room:\n   min: [ %g, %g, %g ]\n   max: [ %g, %g, %g ]\n" % (ROOM_MIN + ROOM_MAX))
    fh.write("lights:\n   - { type: polygon, corners: [ %s ], radiance: [ %s ] }\n" % (
        ", ".join("[ %s ]" % vb.vec(c) for c in light_corners), vb.vec(LIGHT_RADIANCE)))
    fh.write("objects:\n   - { mesh: sphere.obj, world_from_object: [ 1, 0, 0, %g, 0, 1, 0, %g, "
             "0, 0, 1, %g, 0, 0, 0, 1 ], material: { type: lambertian, albedo: [ %s ] } }\n" %
             (*SPHERE_CENTRE, vb.vec(SPHERE_ALBEDO)))
    fh.write("render: { spp: 16, max_depth: 4, seed: 0 }\n")

# Check of the axes: the sphere's centre projects where Blender's own world_to_camera_view puts it.
from bpy_extras.object_utils import world_to_camera_view  # noqa: E402

scene.frame_set(0)
p = mathutils.Vector(SPHERE_CENTRE)
v = world_to_camera_view(scene, cam, p)
ref = (v.x * W - 0.5, (1 - v.y) * H - 0.5)
X = R0 @ p + t0
ours = (K[0][0] * X.x / X.z + K[0][2], K[1][1] * X.y / X.z + K[1][2])
print("sphere centre: vbme projection (%.3f, %.3f), Blender (%.3f, %.3f)" % (*ours, *ref))
assert abs(ours[0] - ref[0]) < 1e-3 and abs(ours[1] - ref[1]) < 1e-3


def render_clip(name, with_object):
    sphere.hide_render = not with_object
    folder = os.path.join(out_dir, name)
    os.makedirs(folder, exist_ok=True)
    for f in range(N):
        scene.frame_set(f)
        scene.render.filepath = os.path.join(folder, "frame_%05d.png" % f)
        bpy.ops.render.render(write_still=True)
    subprocess.check_call(["ffmpeg", "-loglevel", "error", "-y", "-framerate", "30", "-i",
                           os.path.join(folder, "frame_%05d.png"), "-c:v", "ffv1", "-pix_fmt",
                           "bgr0", os.path.join(out_dir, name + ".mkv")])


render_clip("plate", False)
render_clip("truth", True)
