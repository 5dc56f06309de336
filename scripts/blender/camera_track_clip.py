# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Renders a hand-held camera clip of a procedurally textured room with Cycles, and writes the
true camera of every frame in vbme's conventions, for the camera-tracking tests and benchmark.

    blender -b -P scripts/blender/camera_track_clip.py -- OUT_DIR [--frames 60] [--samples 8]
        [--width 640] [--height 360] [--threads 2] [--subframes 10]

Writes into OUT_DIR:
  frames/frame_%05d.png   the rendered frames (8-bit sRGB)
  truth.yml               vbme camera path (K, image_size, frames: cam_from_world, OpenCV axes)
  scene.yml               the frame-0 scene (image size, camera K, R, t; the room box)

test/data/camtrack_blender/clip.mkv is the default run's frames encoded with
    ffmpeg -framerate 30 -i OUT_DIR/frames/frame_%05d.png -c:v libx264 -crf 12 -pix_fmt yuv444p clip.mkv

The room is a 4 x 5 x 2.6 m box (x in [-2, 2], y in [-1, 4], z in [0, 2.6], z up, floor at
z = 0) whose walls carry emission shaders fed by procedural textures (noise, Voronoi cells and
bricks in object coordinates), so that every camera sample sees the exact texture and the only
noise is anti-aliasing and motion blur. The camera walks slowly, pans fast while walking on (up
to 6 degrees per frame, with motion blur), then walks on, with a band-limited hand shake throughout.
"""
import math
import os
import sys

import bpy
import mathutils

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import vbme_blender as vb  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if not argv:
    sys.exit("usage: blender -b -P camera_track_clip.py -- OUT_DIR [options]")
out_dir = os.path.abspath(argv[0])
opts = {"--frames": 60, "--samples": 8, "--width": 640, "--height": 360, "--threads": 2,
        "--subframes": 10}
for i in range(1, len(argv) - 1, 2):
    opts[argv[i]] = int(argv[i + 1])
N, W, H = opts["--frames"], opts["--width"], opts["--height"]
FOCAL = 500.0 * W / 640.0  # pixels
ROOM_MIN, ROOM_MAX = (-2.0, -1.0, 0.0), (2.0, 4.0, 2.6)

# ---------------------------------------------------------------- scene
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = opts["--samples"]
scene.cycles.use_denoising = False
scene.cycles.max_bounces = 0
scene.cycles.seed = 1
scene.render.threads_mode = "FIXED"
scene.render.threads = opts["--threads"]
scene.render.resolution_x, scene.render.resolution_y = W, H
scene.render.resolution_percentage = 100
scene.render.fps = 30
scene.render.use_motion_blur = True
scene.render.motion_blur_shutter = 0.3  # of a frame, centred on the frame time
scene.cycles.motion_blur_position = "CENTER"
scene.render.image_settings.file_format = "PNG"
scene.render.image_settings.color_mode = "RGB"
scene.render.image_settings.color_depth = "8"
scene.view_settings.view_transform = "Standard"  # plain sRGB
scene.view_settings.look = "None"
scene.frame_start, scene.frame_end = 0, N - 1

# The room: a box with faces wound inwards.
x0, y0, z0 = ROOM_MIN
x1, y1, z1 = ROOM_MAX
verts = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
         (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
faces = [(0, 1, 2, 3), (4, 7, 6, 5), (0, 4, 5, 1), (2, 6, 7, 3), (0, 3, 7, 4), (1, 5, 6, 2)]
mesh = bpy.data.meshes.new("room")
mesh.from_pydata(verts, [], faces)
mesh.update()
room = bpy.data.objects.new("room", mesh)
scene.collection.objects.link(room)

mat = bpy.data.materials.new("walls")
mat.use_nodes = True
nt = mat.node_tree
nt.nodes.clear()
n = nt.nodes
coord = n.new("ShaderNodeTexCoord")
noise = n.new("ShaderNodeTexNoise")
noise.inputs["Scale"].default_value = 3.0
noise.inputs["Detail"].default_value = 8.0
noise.inputs["Roughness"].default_value = 0.6
vor = n.new("ShaderNodeTexVoronoi")
vor.inputs["Scale"].default_value = 5.0
vor_fine = n.new("ShaderNodeTexVoronoi")
vor_fine.inputs["Scale"].default_value = 18.0
brick = n.new("ShaderNodeTexBrick")
brick.inputs["Scale"].default_value = 2.0
brick.inputs["Color1"].default_value = (0.8, 0.55, 0.35, 1)
brick.inputs["Color2"].default_value = (0.25, 0.3, 0.45, 1)
brick.inputs["Mortar"].default_value = (0.95, 0.95, 0.9, 1)
for t in (noise, vor, vor_fine, brick):
    nt.links.new(coord.outputs["Object"], t.inputs["Vector"])
mix1 = n.new("ShaderNodeMixRGB")
mix1.blend_type = "MIX"
mix1.inputs["Fac"].default_value = 0.55
nt.links.new(vor.outputs["Color"], mix1.inputs["Color1"])
nt.links.new(noise.outputs["Color"], mix1.inputs["Color2"])
mix2 = n.new("ShaderNodeMixRGB")
mix2.blend_type = "MULTIPLY"
mix2.inputs["Fac"].default_value = 0.6
nt.links.new(mix1.outputs["Color"], mix2.inputs["Color1"])
nt.links.new(brick.outputs["Color"], mix2.inputs["Color2"])
# Dark fine cells' edges: distance to the nearest fine Voronoi seed, thresholded into spots.
ramp = n.new("ShaderNodeValToRGB")
ramp.color_ramp.elements[0].position = 0.12
ramp.color_ramp.elements[0].color = (0.05, 0.05, 0.05, 1)
ramp.color_ramp.elements[1].position = 0.14
ramp.color_ramp.elements[1].color = (1, 1, 1, 1)
nt.links.new(vor_fine.outputs["Distance"], ramp.inputs["Fac"])
mix3 = n.new("ShaderNodeMixRGB")
mix3.blend_type = "MULTIPLY"
mix3.inputs["Fac"].default_value = 1.0
nt.links.new(mix2.outputs["Color"], mix3.inputs["Color1"])
nt.links.new(ramp.outputs["Color"], mix3.inputs["Color2"])
emit = n.new("ShaderNodeEmission")
emit.inputs["Strength"].default_value = 0.85
nt.links.new(mix3.outputs["Color"], emit.inputs["Color"])
out = n.new("ShaderNodeOutputMaterial")
nt.links.new(emit.outputs["Emission"], out.inputs["Surface"])
room.data.materials.append(mat)

# ---------------------------------------------------------------- camera
cam = vb.add_camera(scene, FOCAL, W)
shake_at = vb.HandShake(7)
smoothstep = vb.smoothstep


def pose(f):
    """Camera centre (m) and (yaw, pitch, roll) (rad) at frame f: slow walk, fast pan, walk."""
    # Fast pan: 60 degrees to the left over frames 26..41 (up to 6 degrees per frame), walking
    # on while turning (as people turn), so that the wall turned to is seen with parallax.
    yaw = math.radians(4.0) * f / 30.0 + math.radians(60.0) * smoothstep(26, 41, f)
    pitch = 0.25 + 0.05 * math.sin(f / 20.0)
    roll = 0.0
    c = [0.3 * f / 60.0 - 0.2 * smoothstep(40, 60, f),
         0.6 * f / 60.0 + 0.3 * smoothstep(26, 41, f), 1.5 + 0.05 * math.sin(f / 15.0)]
    for k in range(3):
        c[k] += 0.008 * shake_at(k, f)  # 8 mm
    yaw += math.radians(0.4) * shake_at(3, f)
    pitch += math.radians(0.4) * shake_at(4, f)
    roll += math.radians(0.4) * shake_at(5, f)
    return c, yaw, pitch, roll


# Keyframes every 1/SUB frame of the smooth path (see vb.animate_camera), and Cycles samples the
# camera at 2^(MOTION_STEPS-1) times in the shutter.
SUB = opts["--subframes"]
vb.animate_camera(cam, pose, N, SUB)
cam.cycles.motion_steps = 5 if SUB > 1 else 1

# ---------------------------------------------------------------- truth in vbme's conventions
K = vb.intrinsics(FOCAL, W, H)
poses = [vb.cam_from_world(scene, cam, f) for f in range(N)]
os.makedirs(os.path.join(out_dir, "frames"), exist_ok=True)
vb.write_camera_path(os.path.join(out_dir, "truth.yml"), (W, H), K, poses)
R0, t0 = poses[0]
with open(os.path.join(out_dir, "scene.yml"), "w") as fh:
    vb.write_scene_camera(fh, (W, H), K, R0, t0)
    fh.write("room:\n   min: [ %g, %g, %g ]\n   max: [ %g, %g, %g ]\n" % (ROOM_MIN + ROOM_MAX))

# Check of the axes: a room corner in front of frame 0's camera projects where Blender's own
# world_to_camera_view puts it.
from bpy_extras.object_utils import world_to_camera_view  # noqa: E402

scene.frame_set(0)
for corner in [(x0, y1, z0), (x1, y1, z0), (x0, y1, z1), (x1, y1, z1)]:
    p = mathutils.Vector(corner)
    v = world_to_camera_view(scene, cam, p)
    ref = (v.x * W - 0.5, (1 - v.y) * H - 0.5)  # Blender's normalised view -> vbme pixels
    X = R0 @ p + t0
    ours = (K[0][0] * X.x / X.z + K[0][2], K[1][1] * X.y / X.z + K[1][2])
    print("corner %s: vbme projection (%.3f, %.3f), Blender (%.3f, %.3f)" % (corner, *ours, *ref))
    assert abs(ours[0] - ref[0]) < 1e-3 and abs(ours[1] - ref[1]) < 1e-3

for f in range(N):
    scene.frame_set(f)
    scene.render.filepath = os.path.join(out_dir, "frames", "frame_%05d.png" % f)
    bpy.ops.render.render(write_still=True)
