#version 450
// render.comp - the rendering procedure (paper §3, §4.1) without the irradiance cache.
#extension GL_GOOGLE_include_directive : require
#include "render_main.glsl"
