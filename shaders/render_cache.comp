#version 450
// render_cache.comp - the rendering procedure (paper §4.1) with the irradiance cache:
// a scatter event covered by cache entries is shaded from the extrapolated irradiance
// (Eq. 7, 8, 11); a miss requests a new entry under object-space locking (§5.1).
#extension GL_GOOGLE_include_directive : require
#define PICVR_CACHE 1
#include "render_main.glsl"
