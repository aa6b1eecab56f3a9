#version 450
// render_shade_cache.comp - the shading kernel (render_shade.glsl) with the multiply
// scattered cache looked up at a camera path's LOOKUP_EVENT-th scatter event
// (cache.lookup_event > 1, path_cache.glsl): the rendering variant's shading kernel then.
#extension GL_GOOGLE_include_directive : require
#define PICVR_CACHE_PATHS 1
#include "render_shade.glsl"
