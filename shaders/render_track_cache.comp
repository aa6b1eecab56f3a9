#version 450
// render_track_cache.comp - the rendering procedure's tracking kernel with the cache
// (render_track.glsl): scatter events are queued for the lookup (render_lookup.comp).
#extension GL_GOOGLE_include_directive : require
#define PICVR_CACHE 1
#include "render_track.glsl"
