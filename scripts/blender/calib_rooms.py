# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""Renders realistic stills of furnished rooms and corridors with known camera intrinsics,
rotation and (optionally) radial lens distortion, as test data for single-image calibration
(vanishing points, focal length, plumb-line distortion).

    blender -b -t 2 -P scripts/blender/calib_rooms.py -- --out test/data/calib_rooms \
        [--count 32] [--seed 19] [--samples 12] [--only 3] [--skip_existing 1] [--truth_only 1]
        [--lens compositor --distorted_only 1]

Scene: a box room (or a long corridor) with textured walls (procedural brick, noise, plain),
a wooden floor, doors, picture frames, windows, shelves, tables, boxes (some turned by an
arbitrary angle about the vertical: non-Manhattan lines), cylinders; lit by an area light and
a point light. World frame (Blender's): z up, walls along x and y, so the Manhattan frame is the
world axes.

Camera: focal 18-70 mm 35 mm-equivalent (36 mm wide sensor, horizontal fit), principal point at
the image centre, random yaw, pitch -25..+12 deg, roll -6..+6 deg, inside the room.

Post-process (pure Python, no numpy needed): radial distortion for the images that have it,
Gaussian noise (sigma 2 grey levels), JPEG (quality 88).

Distortion model (OpenCV / COLMAP SIMPLE_RADIAL, one coefficient): with normalised undistorted
coordinates x_u = (u - cx) / f, the distorted point is x_d = x_u (1 + k1 |x_u|^2) and the pixel
is cx + f x_d (pixel centres at integers, cx = (w - 1) / 2). Such images are rendered larger
(same focal in pixels) and resampled into 640x480.

--lens compositor: the distortion is Blender's own instead of the resampling above: the
compositor's Movie Distortion node (distort) on the render, with a movie clip of the render's
size whose tracking camera has the POLYNOMIAL model, k1 (k2 = k3 = 0), the focal length in
pixels and the principal point at the render's centre; the frame is then the render's central
640x480 crop (no resampling). The node's model is OpenCV's k1 with these settings:
scripts/blender/lens_check.py distorts a grid of dots with it and finds every dot where
x_d = x (1 + k1 |x|^2) puts it (160x120, f 100 px, k1 -0.2: centroids 0.41 px off at most,
0.13 px on average, for displacements up to 16.5 px; 768x576, f 518.6, k1 -0.213: 0.39 / 0.13
px for up to 84.2 px). --distorted_only 1 renders only the distorted images (every fifth).

Ground truth: truth.csv, one row per image:
name,kind,width,height,f_px,cx,cy,k1,f35,r00,r01,r02,r10,r11,r12,r20,r21,r22
where R = (rij) is cam_from_world in OpenCV camera axes (x right, y down, z forward):
X_cam = R (X_world - C); the Manhattan directions are the world axes.
"""
import math
import os
import random
import sys

import bpy
from mathutils import Matrix, Vector

W, H = 640, 480


def parse_args(defaults=None):
    """--key value pairs after Blender's "--" into a copy of defaults (this script's when None),
    each value converted to its default's type; an unknown key stops the script."""
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    a = dict(defaults) if defaults is not None else {
        "out": "calib_rooms", "count": 32, "seed": 19, "samples": 12, "only": -1, "skip_existing": 0,
        "truth_only": 0, "lens": "resample", "distorted_only": 0}
    i = 0
    while i < len(argv):
        k = argv[i].lstrip("-")
        if k not in a:
            raise SystemExit("unknown option " + argv[i])
        a[k] = type(a[k])(argv[i + 1])
        i += 2
    return a


def clear_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)


# ------------------------------------------------------------------------------------------
# Materials


def mat_node_setup(name):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    bsdf = nt.nodes["Principled BSDF"]
    tc = nt.nodes.new("ShaderNodeTexCoord")
    mp = nt.nodes.new("ShaderNodeMapping")
    nt.links.new(tc.outputs["Object"], mp.inputs["Vector"])
    return m, nt, bsdf, mp


def rgb(c):
    return (c[0], c[1], c[2], 1.0)


def rand_color(rng, lo=0.15, hi=0.85, sat=0.35):
    base = rng.uniform(lo, hi)
    return tuple(max(0.0, min(1.0, base * (1 + rng.uniform(-sat, sat)))) for _ in range(3))


def make_material(rng, kind, plane="xy", scale=1.0):
    """kind: brick, wood, noise, plain; plane: the object-space plane the pattern lies in."""
    m, nt, bsdf, mp = mat_node_setup(kind)
    # Brick and wave textures pattern the x-y plane: turn x-z / y-z planes onto it.
    if plane == "xz":
        mp.inputs["Rotation"].default_value = (math.pi / 2, 0, 0)
    elif plane == "yz":
        mp.inputs["Rotation"].default_value = (math.pi / 2, 0, math.pi / 2)
    bsdf.inputs["Roughness"].default_value = rng.uniform(0.4, 0.9)
    if kind == "brick":
        t = nt.nodes.new("ShaderNodeTexBrick")
        t.inputs["Color1"].default_value = rgb(rand_color(rng, 0.3, 0.6))
        t.inputs["Color2"].default_value = rgb(rand_color(rng, 0.2, 0.5))
        t.inputs["Mortar"].default_value = rgb((0.75, 0.73, 0.7))
        t.inputs["Scale"].default_value = rng.uniform(2.0, 4.0) * scale
        t.inputs["Mortar Size"].default_value = 0.015
        nt.links.new(mp.outputs["Vector"], t.inputs["Vector"])
        nt.links.new(t.outputs["Color"], bsdf.inputs["Base Color"])
    elif kind == "wood":
        t = nt.nodes.new("ShaderNodeTexWave")
        t.inputs["Scale"].default_value = rng.uniform(1.5, 4.0) * scale
        t.inputs["Distortion"].default_value = rng.uniform(2, 6)
        t.inputs["Detail"].default_value = 3
        r = nt.nodes.new("ShaderNodeValToRGB")
        c1 = rand_color(rng, 0.25, 0.45, 0.1)
        r.color_ramp.elements[0].color = rgb((c1[0] * 1.2, c1[1] * 0.8, c1[2] * 0.5))
        r.color_ramp.elements[1].color = rgb((c1[0] * 0.7, c1[1] * 0.45, c1[2] * 0.25))
        nt.links.new(mp.outputs["Vector"], t.inputs["Vector"])
        nt.links.new(t.outputs["Fac"], r.inputs["Fac"])
        nt.links.new(r.outputs["Color"], bsdf.inputs["Base Color"])
    elif kind == "noise":
        t = nt.nodes.new("ShaderNodeTexNoise")
        t.inputs["Scale"].default_value = rng.uniform(3, 12) * scale
        t.inputs["Detail"].default_value = 6
        r = nt.nodes.new("ShaderNodeValToRGB")
        c = rand_color(rng, 0.35, 0.8)
        r.color_ramp.elements[0].color = rgb(tuple(0.75 * x for x in c))
        r.color_ramp.elements[1].color = rgb(c)
        nt.links.new(mp.outputs["Vector"], t.inputs["Vector"])
        nt.links.new(t.outputs["Fac"], r.inputs["Fac"])
        nt.links.new(r.outputs["Color"], bsdf.inputs["Base Color"])
    else:
        bsdf.inputs["Base Color"].default_value = rgb(rand_color(rng, 0.2, 0.85))
    return m


def emissive(strength, color=(1, 1, 1)):
    m = bpy.data.materials.new("emit")
    m.use_nodes = True
    nt = m.node_tree
    for n in list(nt.nodes):
        if n.type == "BSDF_PRINCIPLED":
            nt.nodes.remove(n)
    e = nt.nodes.new("ShaderNodeEmission")
    e.inputs["Color"].default_value = rgb(color)
    e.inputs["Strength"].default_value = strength
    nt.links.new(e.outputs["Emission"], nt.nodes["Material Output"].inputs["Surface"])
    return m


# ------------------------------------------------------------------------------------------
# Geometry


def box(center, size, mat, rot_z=0.0, name="box"):
    sx, sy, sz = (s / 2 for s in size)
    v = [(-sx, -sy, -sz), (sx, -sy, -sz), (sx, sy, -sz), (-sx, sy, -sz),
         (-sx, -sy, sz), (sx, -sy, sz), (sx, sy, sz), (-sx, sy, sz)]
    f = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    me = bpy.data.meshes.new(name)
    me.from_pydata(v, [], f)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = center
    ob.rotation_euler = (0, 0, rot_z)
    ob.data.materials.append(mat)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def cylinder(center, radius, height, mat):
    bpy.ops.mesh.primitive_cylinder_add(vertices=32, radius=radius, depth=height,
                                        location=center)
    ob = bpy.context.active_object
    ob.data.materials.append(mat)
    return ob


def table(rng, x, y, rot, mat):
    w, d, h = rng.uniform(0.8, 1.6), rng.uniform(0.6, 0.9), rng.uniform(0.7, 0.78)
    c, s = math.cos(rot), math.sin(rot)
    box((x, y, h - 0.02), (w, d, 0.04), mat, rot, "tabletop")
    for ex, ey in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        lx, ly = ex * (w / 2 - 0.05), ey * (d / 2 - 0.05)
        box((x + c * lx - s * ly, y + s * lx + c * ly, (h - 0.04) / 2), (0.05, 0.05, h - 0.04),
            mat, rot, "leg")


def shelf(rng, x, y, along_x, mat, mat_items):
    """A bookcase standing against a wall; along_x: its width runs along x."""
    w, d, h = rng.uniform(0.8, 1.4), 0.35, rng.uniform(1.4, 2.1)
    sx, sy = (w, d) if along_x else (d, w)
    for side in (-1, 1):
        if along_x:
            box((x + side * (w / 2 - 0.01), y, h / 2), (0.02, d, h), mat)
        else:
            box((x, y + side * (w / 2 - 0.01), h / 2), (d, 0.02, h), mat)
    n = rng.randint(3, 5)
    for k in range(n + 1):
        z = 0.05 + k * (h - 0.08) / n
        box((x, y, z), (sx, sy, 0.025), mat)
        if k < n and rng.random() < 0.7:  # books / boxes on the board
            nb = rng.randint(2, 6)
            for b in range(nb):
                t = (b + 0.5) / nb - 0.5
                bh = rng.uniform(0.12, 0.28) * min(1.0, (h - 0.08) / n / 0.3)
                bw = w / nb * rng.uniform(0.4, 0.9)
                if along_x:
                    box((x + t * w * 0.9, y, z + 0.0125 + bh / 2), (bw, d * 0.8, bh), mat_items)
                else:
                    box((x, y + t * w * 0.9, z + 0.0125 + bh / 2), (d * 0.8, bw, bh), mat_items)


def build_scene(rng, idx):
    corridor = idx % 4 == 3
    if corridor:
        X, Y, Z = rng.uniform(1.8, 2.6), rng.uniform(10, 16), rng.uniform(2.4, 3.0)
    else:
        X, Y, Z = rng.uniform(3.5, 7.5), rng.uniform(3.5, 8.5), rng.uniform(2.4, 3.2)
    t = 0.1
    wall_kind = rng.choice(["brick", "noise", "plain", "noise", "plain"])
    m_floor = make_material(rng, rng.choice(["wood", "wood", "noise", "brick"]), "xy")
    m_ceil = make_material(rng, "plain")
    m_wx = make_material(rng, wall_kind, "xz")  # walls whose plane is x-z (normal y)
    m_wy = make_material(rng, wall_kind, "yz")
    box((0, 0, -t / 2), (X + 2 * t, Y + 2 * t, t), m_floor, name="floor")
    box((0, 0, Z + t / 2), (X + 2 * t, Y + 2 * t, t), m_ceil, name="ceiling")
    box((0, -Y / 2 - t / 2, Z / 2), (X + 2 * t, t, Z), m_wx, name="wall_front")
    box((0, Y / 2 + t / 2, Z / 2), (X + 2 * t, t, Z), m_wx, name="wall_back")
    box((-X / 2 - t / 2, 0, Z / 2), (t, Y, Z), m_wy, name="wall_left")
    box((X / 2 + t / 2, 0, Z / 2), (t, Y, Z), m_wy, name="wall_right")
    m_wood = make_material(rng, "wood", "xy")
    m_item = make_material(rng, "noise", "xy", 2.0)
    m_frame = make_material(rng, "plain")
    # Skirting boards.
    m_skirt = make_material(rng, "plain")
    box((0, -Y / 2 + 0.01, 0.05), (X, 0.02, 0.1), m_skirt)
    box((0, Y / 2 - 0.01, 0.05), (X, 0.02, 0.1), m_skirt)
    box((-X / 2 + 0.01, 0, 0.05), (0.02, Y, 0.1), m_skirt)
    box((X / 2 - 0.01, 0, 0.05), (0.02, Y, 0.1), m_skirt)
    # Doors, pictures and windows on the walls.
    n_wall_items = rng.randint(3, 7) if not corridor else rng.randint(5, 10)
    for _ in range(n_wall_items):
        wall = rng.choice(["left", "right"] if corridor and rng.random() < 0.8
                          else ["front", "back", "left", "right"])
        span = X if wall in ("front", "back") else Y
        kind = rng.choice(["door", "picture", "picture", "window"])
        if kind == "door":
            w, h, z0 = 0.9, 2.05, 0.0
        elif kind == "picture":
            w, h = rng.uniform(0.3, 1.2), rng.uniform(0.3, 0.9)
            z0 = rng.uniform(1.0, Z - h - 0.2)
        else:
            w, h = rng.uniform(0.8, 1.6), rng.uniform(0.8, 1.2)
            z0 = rng.uniform(0.8, max(0.85, Z - h - 0.3))
        if span < w + 0.4:
            continue
        s = rng.uniform(-span / 2 + w / 2 + 0.2, span / 2 - w / 2 - 0.2)
        mat = {"door": m_wood, "picture": m_frame}.get(kind)
        if kind == "window":
            mat = emissive(rng.uniform(2.0, 5.0), (0.9, 0.95, 1.0))
        th = 0.04
        if wall in ("front", "back"):
            yy = (-Y / 2 + th / 2) if wall == "front" else (Y / 2 - th / 2)
            box((s, yy, z0 + h / 2), (w, th, h), mat)
            # frame
            for dz in (0, h):
                box((s, yy, z0 + dz), (w + 0.1, th * 1.5, 0.05), m_frame)
        else:
            xx = (-X / 2 + th / 2) if wall == "left" else (X / 2 - th / 2)
            box((xx, s, z0 + h / 2), (th, w, h), mat)
            for dz in (0, h):
                box((xx, s, z0 + dz), (th * 1.5, w + 0.1, 0.05), m_frame)
    # Furniture.
    def free_xy(margin=0.6):
        return rng.uniform(-X / 2 + margin, X / 2 - margin), rng.uniform(-Y / 2 + margin,
                                                                          Y / 2 - margin)

    if not corridor:
        for _ in range(rng.randint(1, 2)):
            x, y = free_xy(1.0)
            table(rng, x, y, rng.choice([0, math.pi / 2, rng.uniform(0, math.pi)]), m_wood)
        for _ in range(rng.randint(0, 2)):
            if rng.random() < 0.5:
                shelf(rng, rng.uniform(-X / 2 + 1, X / 2 - 1), rng.choice([-1, 1]) * (Y / 2 - 0.2),
                      True, m_wood, m_item)
            else:
                shelf(rng, rng.choice([-1, 1]) * (X / 2 - 0.2), rng.uniform(-Y / 2 + 1, Y / 2 - 1),
                      False, m_wood, m_item)
    for _ in range(rng.randint(2, 8)):
        x, y = free_xy(0.5 if not corridor else 0.3)
        if corridor:
            x = rng.choice([-1, 1]) * (X / 2 - 0.35)
        sz = (rng.uniform(0.2, 0.7), rng.uniform(0.2, 0.7), rng.uniform(0.2, 0.8))
        rot = rng.uniform(0, math.pi) if rng.random() < 0.45 else 0.0
        mat = rng.choice([m_item, make_material(rng, "plain"), make_material(rng, "noise")])
        box((x, y, sz[2] / 2), sz, mat, rot)
        if rng.random() < 0.3:  # stacked box, turned
            sz2 = (sz[0] * 0.7, sz[1] * 0.7, sz[2] * 0.6)
            box((x, y, sz[2] + sz2[2] / 2), sz2, make_material(rng, "plain"),
                rot + rng.uniform(-0.6, 0.6))
    for _ in range(rng.randint(0, 3)):
        x, y = free_xy(0.5)
        r, h = rng.uniform(0.1, 0.3), rng.uniform(0.3, 1.0)
        cylinder((x, y, h / 2), r, h, make_material(rng, rng.choice(["plain", "noise"])))
    # Ceiling light fixtures and wall cabinets.
    m_fix = make_material(rng, "plain")
    for _ in range(rng.randint(1, 3)):
        fx, fy = free_xy(0.8)
        box((fx, fy, Z - 0.03), (rng.uniform(0.4, 1.2), rng.uniform(0.2, 0.6), 0.06), m_fix)
    if not corridor and rng.random() < 0.6:
        along_x = rng.random() < 0.5
        span = X if along_x else Y
        n_c = rng.randint(2, 4)
        cw = min(0.6, (span - 1.0) / n_c)
        side = rng.choice([-1, 1])
        z0, ch = rng.uniform(1.5, 1.7), rng.uniform(0.5, 0.7)
        start = rng.uniform(-span / 2 + 0.3, span / 2 - 0.3 - n_c * cw)
        m_cab = make_material(rng, rng.choice(["plain", "wood"]), "xz" if along_x else "yz")
        for k in range(n_c):
            s0 = start + (k + 0.5) * cw
            if along_x:
                box((s0, side * (Y / 2 - 0.18), z0 + ch / 2), (cw - 0.01, 0.35, ch), m_cab)
            else:
                box((side * (X / 2 - 0.18), s0, z0 + ch / 2), (0.35, cw - 0.01, ch), m_cab)
    # Lights.
    bpy.ops.object.light_add(type="AREA", location=(rng.uniform(-X / 4, X / 4),
                                                    rng.uniform(-Y / 4, Y / 4), Z - 0.05))
    L = bpy.context.active_object
    L.data.size = 1.0
    L.data.energy = rng.uniform(120, 260) * (X * Y / 30) ** 0.5
    bpy.ops.object.light_add(type="POINT", location=(rng.uniform(-X / 3, X / 3),
                                                     rng.uniform(-Y / 3, Y / 3), Z * 0.8))
    bpy.context.active_object.data.energy = rng.uniform(40, 100)
    bpy.context.active_object.data.shadow_soft_size = 0.2
    world = bpy.data.worlds.new("w")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.05, 0.05, 0.05, 1)
    bpy.context.scene.world = world
    return corridor, X, Y, Z


def place_camera(rng, corridor, X, Y, Z, f35, overscan):
    cam_data = bpy.data.cameras.new("cam")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 36.0
    cam_data.lens = f35 / overscan  # same focal in pixels on an image `overscan` times wider
    cam_data.clip_start = 0.05
    cam = bpy.data.objects.new("cam", cam_data)
    bpy.context.scene.collection.objects.link(cam)
    m = 0.6 if not corridor else 0.4
    pos = Vector((rng.uniform(-X / 2 + m, X / 2 - m), rng.uniform(-Y / 2 + m, Y / 2 - m),
                  rng.uniform(1.1, 1.8)))
    if corridor:
        pos.y = rng.uniform(-Y / 2 + 0.5, -Y / 4)
        yaw = rng.uniform(-40, 40)  # roughly down the corridor (+y)
    else:
        # Stand away from the walls and look at a point of the room at least 2 m away, as a
        # photographer would (not at a blank wall from up close).
        pos.x = rng.uniform(-X / 2 + min(1.2, X / 4), X / 2 - min(1.2, X / 4))
        pos.y = rng.uniform(-Y / 2 + min(1.2, Y / 4), Y / 2 - min(1.2, Y / 4))
        for _ in range(100):
            tx, ty = rng.uniform(-X / 2, X / 2), rng.uniform(-Y / 2, Y / 2)
            if math.hypot(tx - pos.x, ty - pos.y) > 2.0:
                break
        # Blender yaw 0 looks along +y; positive yaw turns towards -x.
        yaw = math.degrees(math.atan2(-(tx - pos.x), ty - pos.y)) + rng.uniform(-15, 15)
    pitch = rng.uniform(-25, 12)
    roll = rng.uniform(-6, 6)
    # Blender camera looks along its local -z with local +y up; Rx(90) makes it look along +y.
    rot = (Matrix.Rotation(math.radians(yaw), 3, "Z") @
           Matrix.Rotation(math.radians(90 + pitch), 3, "X") @
           Matrix.Rotation(math.radians(roll), 3, "Z"))
    cam.matrix_world = Matrix.Translation(pos) @ rot.to_4x4()
    bpy.context.scene.camera = cam
    # cam_from_world in OpenCV axes: diag(1, -1, -1) * rot^T.
    Rt = rot.transposed()
    R = [[Rt[0][j] for j in range(3)], [-Rt[1][j] for j in range(3)], [-Rt[2][j] for j in range(3)]]
    return R


def setup_render(samples, w, h):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    sc.cycles.device = "CPU"
    sc.cycles.samples = samples
    sc.cycles.use_adaptive_sampling = False
    sc.cycles.use_denoising = False
    sc.cycles.max_bounces = 4
    sc.cycles.diffuse_bounces = 2
    sc.cycles.glossy_bounces = 1
    sc.cycles.transmission_bounces = 0
    sc.cycles.volume_bounces = 0
    sc.cycles.transparent_max_bounces = 0
    sc.cycles.caustics_reflective = False
    sc.cycles.caustics_refractive = False
    sc.cycles.seed = 0
    sc.render.resolution_x = w
    sc.render.resolution_y = h
    sc.render.resolution_percentage = 100
    sc.view_settings.view_transform = "Standard"
    sc.view_settings.exposure = 0.0
    sc.render.image_settings.file_format = "PNG"
    sc.render.image_settings.color_mode = "RGB"


def lens_clip(path, f, k1):
    """A movie clip of the image file @p path (its size is the frame's) whose tracking camera is
    vbme's / OpenCV's lens: POLYNOMIAL model with k1 (k2 = k3 = 0), focal f in pixels, the
    principal point at the image centre (Blender's pixel corners: w / 2, h / 2)."""
    clip = bpy.data.movieclips.load(path)
    cam = clip.tracking.camera
    cam.units = "PIXELS"
    cam.focal_length_pixels = f
    cam.principal = (clip.size[0] / 2.0, clip.size[1] / 2.0)
    cam.distortion_model = "POLYNOMIAL"
    cam.k1, cam.k2, cam.k3 = k1, 0.0, 0.0
    return clip


def compositor_lens(f, k1, sw, sh, out_dir):
    """Distorts the render with Blender's compositor (Movie Distortion, POLYNOMIAL k1)."""
    sc = bpy.context.scene
    blank = bpy.data.images.new("lens_clip", sw, sh)
    path = os.path.join(out_dir, "_lens_clip.png")
    blank.filepath_raw = path
    blank.file_format = "PNG"
    blank.save()
    clip = lens_clip(path, f, k1)
    sc.use_nodes = True
    nt = sc.node_tree
    for n in list(nt.nodes):
        nt.nodes.remove(n)
    rl = nt.nodes.new("CompositorNodeRLayers")
    md = nt.nodes.new("CompositorNodeMovieDistortion")
    md.clip = clip
    md.distortion_type = "DISTORT"
    comp = nt.nodes.new("CompositorNodeComposite")
    nt.links.new(rl.outputs["Image"], md.inputs[0])
    nt.links.new(md.outputs[0], comp.inputs[0])
    return path


def postprocess(src_png, dst_jpg, rng, f, k1, overscan):
    """Resamples the (larger, when distorted) render into W x H with radial distortion k1,
    adds Gaussian noise and writes a JPEG."""
    img = bpy.data.images.load(src_png)
    sw, sh = img.size
    px = list(img.pixels[:])  # RGBA floats, bottom row first
    out = [0.0] * (W * H * 4)
    cx, cy = (W - 1) / 2.0, (H - 1) / 2.0
    scx, scy = (sw - 1) / 2.0, (sh - 1) / 2.0
    sigma = 2.0 / 255.0
    gauss = rng.gauss
    if k1 == 0.0 and (sw, sh) == (W, H):  # plain copy + noise
        out = [min(1.0, max(0.0, p + gauss(0.0, sigma))) for p in px]
        out[3::4] = [1.0] * (W * H)
    for v in range(H if (k1 != 0.0 or (sw, sh) != (W, H)) else 0):
        for u in range(W):
            if k1 != 0.0:
                xd, yd = (u - cx) / f, (v - cy) / f
                rd2 = xd * xd + yd * yd
                ru = math.sqrt(rd2)
                rdn = ru
                for _ in range(20):  # solve r_d = r_u (1 + k1 r_u^2) for r_u
                    ru = rdn / (1 + k1 * ru * ru)
                s = ru / rdn if rdn > 0 else 1.0
                su, sv = scx + f * xd * s, scy + f * yd * s
            else:
                su, sv = u + (scx - cx), v + (scy - cy)
            # bilinear, image rows counted from the top (Blender stores bottom-up)
            x0 = min(max(int(math.floor(su)), 0), sw - 2)
            y0 = min(max(int(math.floor(sv)), 0), sh - 2)
            ax, ay = min(max(su - x0, 0.0), 1.0), min(max(sv - y0, 0.0), 1.0)
            r0, r1 = sh - 1 - y0, sh - 2 - y0
            i00, i10 = (r0 * sw + x0) * 4, (r0 * sw + x0 + 1) * 4
            i01, i11 = (r1 * sw + x0) * 4, (r1 * sw + x0 + 1) * 4
            o = ((H - 1 - v) * W + u) * 4
            for c in range(3):
                val = ((1 - ax) * (1 - ay) * px[i00 + c] + ax * (1 - ay) * px[i10 + c] +
                       (1 - ax) * ay * px[i01 + c] + ax * ay * px[i11 + c])
                out[o + c] = min(1.0, max(0.0, val + gauss(0.0, sigma)))
            out[o + 3] = 1.0
    res = bpy.data.images.new("out", W, H, alpha=False)
    res.pixels[:] = out
    res.file_format = "JPEG"
    res.filepath_raw = dst_jpg
    res.save(filepath=dst_jpg, quality=88)
    bpy.data.images.remove(img)
    bpy.data.images.remove(res)



def draw_lens(rng, idx):
    """The image's lens, the first draws of its random stream (calib_rooms_labels.py rebuilds
    the same scenes from them): (distorted, f35, k1, f in px)."""
    # Every fifth image (wide lenses) carries radial distortion.
    distorted = idx % 5 == 4
    f35 = math.exp(rng.uniform(math.log(18), math.log(70)))
    k1 = 0.0
    if distorted:
        # Barrel distortion of at most ~15 % at the corners (the model stays invertible).
        f35 = rng.uniform(22, 32)
        rd2 = ((W - 1) ** 2 + (H - 1) ** 2) / 4.0 / (f35 / 36.0 * W) ** 2
        k1 = -rng.uniform(0.4, 1.0) * min(0.25, 0.15 / rd2)
    return distorted, f35, k1, f35 / 36.0 * W

def lens_overscan(f, k1):
    """How many times wider than 640x480 the render must be (in steps of 0.05, 2 % margin) so
    that barrel distortion k1 < 0 pulls no pixel of the frame from outside it: the undistorted
    radius of the image corner over its distorted radius. 1 without barrel distortion."""
    if k1 >= 0:
        return 1.0
    xd, yd = ((W - 1) / 2) / f, ((H - 1) / 2) / f
    rd = math.hypot(xd, yd)
    ru = rd
    for _ in range(50):
        ru = rd / (1 + k1 * ru * ru)
    return math.ceil(ru / rd * 1.02 * 20) / 20


def main():
    a = parse_args()
    os.makedirs(a["out"], exist_ok=True)
    rows = []
    truth = os.path.join(a["out"], "truth.csv")
    existing = {}
    if os.path.exists(truth):
        with open(truth) as fh:
            for line in fh.read().splitlines()[1:]:
                existing[line.split(",")[0]] = line
    for idx in range(a["count"]):
        name = "room_%03d.jpg" % idx
        rng = random.Random(a["seed"] * 1000 + idx)
        distorted, f35, k1, f = draw_lens(rng, idx)
        if (a["only"] >= 0 and idx != a["only"]) or (a["distorted_only"] and not distorted):
            if name in existing:
                rows.append(existing[name])
            continue
        clear_scene()
        corridor, X, Y, Z = build_scene(rng, idx)
        overscan = lens_overscan(f, k1)
        R = place_camera(rng, corridor, X, Y, Z, f35, overscan)
        sw, sh = int(round(W * overscan)) // 2 * 2, int(round(H * overscan)) // 2 * 2
        # keep the focal in pixels exact: the lens scales with the actual width
        bpy.context.scene.camera.data.lens = f35 * W / sw
        setup_render(a["samples"], sw, sh)
        lens_clip = None
        if a["lens"] == "compositor" and k1 != 0.0:
            lens_clip = compositor_lens(f, k1, sw, sh, a["out"])
        tmp = os.path.join(a["out"], "_tmp_%03d.png" % idx)
        bpy.context.scene.render.filepath = tmp
        if a["truth_only"] or (a["skip_existing"] and os.path.exists(os.path.join(a["out"], name))):
            pass
        else:
            bpy.ops.render.render(write_still=True)
            # with the compositor's lens the render is distorted already: crop only
            postprocess(tmp, os.path.join(a["out"], name), rng, f, 0.0 if lens_clip else k1,
                        overscan)
            os.remove(tmp)
        if lens_clip:
            os.remove(lens_clip)
        row = [name, "corridor" if corridor else "room", str(W), str(H), "%.6f" % f,
               "%.6f" % ((W - 1) / 2.0), "%.6f" % ((H - 1) / 2.0), "%.6f" % k1, "%.4f" % f35]
        row += ["%.9f" % R[i][j] for i in range(3) for j in range(3)]
        rows.append(",".join(row))
        print("calib_rooms: wrote %s (f %.1f px, k1 %.3f, %s)" % (name, f, k1,
                                                                   "corridor" if corridor
                                                                   else "room"), flush=True)
    with open(truth + ".tmp", "w") as fh:
        fh.write("name,kind,width,height,f_px,cx,cy,k1,f35,"
                 "r00,r01,r02,r10,r11,r12,r20,r21,r22\n")
        fh.write("\n".join(rows) + "\n")
    os.replace(truth + ".tmp", truth)


if __name__ == "__main__":
    main()
