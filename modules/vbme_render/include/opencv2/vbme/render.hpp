// This file is part of vbme, licensed under the Apache License 2.0 (see LICENSE).
#ifndef OPENCV_VBME_RENDER_HPP
#define OPENCV_VBME_RENDER_HPP

/**
@defgroup vbme_render vbme_render: the deterministic Embree path tracer

A physically based, multi-threaded, bitwise-deterministic path tracer built on Embree
@cite Wald2014: the scene file's room box, proxies, objects and lights become Embree geometry
(RenderScene), rendered through the scene's pinhole camera (PinholeCamera) by path tracing with
next-event estimation and multiple importance sampling (Renderer), with Owen-scrambled Sobol
samples that are a pure function of (pixel, sample, dimension, seed) (SobolSampler), BSDFs for
the scene materials (Bsdf), lights (Emitter, EnvironmentMap), textures (Texture), and float
OpenEXR / preview output (film.hpp), and differential rendering with compositing into footage
@cite Debevec1998 (DifferentialRenderer, projectObjectCoverage, compositeDifferential). See
doc/vbme_render.md and doc/vbme_render_differential.md.
*/

#include "opencv2/vbme/core.hpp"
#include "opencv2/vbme/render/bsdf.hpp"
#include "opencv2/vbme/render/camera.hpp"
#include "opencv2/vbme/render/differential.hpp"
#include "opencv2/vbme/render/environment.hpp"
#include "opencv2/vbme/render/film.hpp"
#include "opencv2/vbme/render/integrator.hpp"
#include "opencv2/vbme/render/lights.hpp"
#include "opencv2/vbme/render/sampler.hpp"
#include "opencv2/vbme/render/scene.hpp"
#include "opencv2/vbme/render/texture.hpp"
#include "opencv2/vbme/render/room_texture.hpp"
#include "opencv2/vbme/render/albedo.hpp"
#include "opencv2/vbme/render/light_estimation.hpp"
#include "opencv2/vbme/render/relighting.hpp"
#include "opencv2/vbme/render/placement.hpp"

#endif
