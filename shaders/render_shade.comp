#version 450
// render_shade.comp - the shading kernel (render_shade.glsl) as plain Monte Carlo and the
// cache's misses at the first scatter event take it.
#extension GL_GOOGLE_include_directive : require
#include "render_shade.glsl"
