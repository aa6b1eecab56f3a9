#version 450
// render_track.comp - the rendering procedure's tracking kernel without the cache
// (render_track.glsl): scatter events are queued for shading.
#extension GL_GOOGLE_include_directive : require
#include "render_track.glsl"
