# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
"""What the Blender clip scripts share: a hand-held camera (shake, easing, keyframes) and its
truth in vbme's conventions (cam_from_world in OpenCV axes, the camera-path YAML).

Imported by the scripts run with `blender -b -P script.py`, which put this folder on sys.path.
"""
import math
import random

import bpy
import mathutils

# Blender cameras look down -z with y up; OpenCV cameras look down +z with y down.
BL_TO_CV = mathutils.Matrix(((1, 0, 0), (0, -1, 0), (0, 0, -1)))


class HandShake:
    """Band-limited hand shake: per channel k, a sum of three sinusoids (periods 12..60 frames
    at 30 frames/s, random phases from @p seed), unit peak."""

    def __init__(self, seed, channels=6):
        rng = random.Random(seed)
        self.waves = [[(rng.uniform(0.5, 2.5), rng.uniform(0, 2 * math.pi)) for _ in range(3)]
                      for _ in range(channels)]

    def __call__(self, k, f):
        return sum(math.sin(2 * math.pi * f * a / 30.0 + p) for a, p in self.waves[k]) / 3.0


def smoothstep(a, b, f):
    """0 before frame a, 1 after frame b, a smooth ease in between."""
    u = min(1.0, max(0.0, (f - a) / (b - a)))
    return u * u * (3 - 2 * u)


def add_camera(scene, focal_px, width):
    """A pinhole camera of focal length @p focal_px pixels on a @p width pixel wide image."""
    cam_data = bpy.data.cameras.new("cam")
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 36.0
    cam_data.lens = focal_px * 36.0 / width
    cam_data.clip_start = 0.01
    cam = bpy.data.objects.new("cam", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    cam.rotation_mode = "XYZ"
    return cam


def animate_camera(cam, pose, frames, subframes=1):
    """Keyframes frames 0..frames-1 from pose(f) = (centre, yaw, pitch, roll), interpolated
    linearly between keys (what motion blur integrates over). With subframes > 1 the keys are
    every 1/subframes frame, so that the motion within the shutter is as smooth as a real
    camera's (keys on whole frames only change the velocity in the middle of every exposure:
    the blur is then lopsided and its centre is not the camera of the frame time)."""
    for k in range(subframes * (frames - 1) + 1):
        f = k / subframes if subframes > 1 else k
        c, yaw, pitch, roll = pose(f)
        cam.location = c
        # X by 90 degrees looks along +y; pitch tilts down; Z turns.
        cam.rotation_euler = (math.pi / 2 - pitch, roll, yaw)
        cam.keyframe_insert("location", frame=f)
        cam.keyframe_insert("rotation_euler", frame=f)
    for fc in cam.animation_data.action.fcurves:
        for kp in fc.keyframe_points:
            kp.interpolation = "LINEAR"


def intrinsics(focal_px, width, height):
    """K with the principal point at the image centre, pixel centres at integers (vbme)."""
    return [[focal_px, 0, (width - 1) / 2.0], [0, focal_px, (height - 1) / 2.0], [0, 0, 1]]


def cam_from_world(scene, cam, f):
    """(R, t) of frame f: cam_from_world in OpenCV axes."""
    scene.frame_set(f)
    mw = cam.matrix_world
    R_wc = mw.to_3x3().normalized()  # world_from_camera, Blender camera axes
    C = mw.to_translation()
    R = BL_TO_CV @ R_wc.transposed()
    return R, -(R @ C)


def flat(m):
    """A 3x3 matrix as a flow sequence's items, row by row."""
    return ", ".join("%.12g" % m[i][j] for i in range(3) for j in range(3))


def vec(v):
    """A vector as a flow sequence's items."""
    return ", ".join("%.12g" % x for x in v)


def write_camera_path(path, size, K, poses):
    """The vbme camera-path YAML: image_size, K, one frame entry per pose (source: sfm)."""
    with open(path, "w") as fh:
        fh.write("%YAML:1.0\n---\n")
        fh.write("image_size: [ %d, %d ]\n" % size)
        fh.write("K: [ %s ]\n" % vec([v for row in K for v in row]))
        fh.write("frames:\n")
        for f, (R, t) in enumerate(poses):
            fh.write("   - { index: %d, R: [ %s ], t: [ %s ], source: sfm }\n" %
                     (f, flat(R), vec(t)))


def write_scene_camera(fh, size, K, R, t):
    """The scene file's header: image_size and the frame-0 camera (sRGB response)."""
    fh.write("%YAML:1.0\n---\n")
    fh.write("image_size: [ %d, %d ]\n" % size)
    fh.write("camera:\n   K: [ %s ]\n   R: [ %s ]\n   t: [ %s ]\n   response: srgb\n" %
             (vec([v for row in K for v in row]), flat(R), vec(t)))
