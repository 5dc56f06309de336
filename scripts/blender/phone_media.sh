#!/usr/bin/env bash
# This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
# Turns frames rendered by track_ball_clip.py into phone-like test media:
#   OUT/clip.mp4       landscape, temporal sensor noise (luma and chroma), H.264 High profile
#                      at a phone's bit rate per pixel (~2 Mbit/s at 640x360, like ~18 Mbit/s
#                      at 1920x1080), GOP 30 with B-frames, yuv420p
#   OUT/portrait.mp4   the same coded stream with a display matrix of -90 degrees (how
#                      phones store portrait video); players show it 360x640
#   OUT/first_mask.png the ball's visible pixels on frame 0 (object-index pass)
#   OUT/truth.csv      copied from the render
# Usage: scripts/blender/phone_media.sh RENDER_DIR OUT_DIR [bitrate, default 2M]
set -euo pipefail
src=$1
out=$2
rate=${3:-2M}
mkdir -p "$out"
ffmpeg -loglevel error -y -framerate 30 -start_number 0 -i "$src/frame_%04d.png" \
    -vf "noise=c0s=7:c0f=t+u:c1s=5:c1f=t+u:c2s=5:c2f=t+u,format=yuv420p" \
    -c:v libx264 -profile:v high -preset medium -b:v "$rate" -maxrate "$rate" -bufsize 4M \
    -g 30 -bf 2 -movflags +faststart "$out/clip.mp4"
# The display matrix: ffmpeg 5's mov muxer writes it from the legacy "rotate" tag; 270 gives a
# matrix of -90 degrees (ffprobe: rotation -90), as a phone held upright stores it: players
# turn the coded frames 90 degrees clockwise.
ffmpeg -loglevel error -y -i "$out/clip.mp4" -c copy -metadata:s:v:0 rotate=270 "$out/portrait.mp4"
cp "$src/mask_0000.png" "$out/first_mask.png"
cp "$src/truth.csv" "$out/truth.csv"
ls -l "$out"
