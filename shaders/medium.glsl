// medium.glsl - the medium: the data value at a point (the volume texture, normalized by
// Scene.value_map), the transfer function's albedo and opacity, and the extinction
// sigma_t(x) = D * opacity(v(x)) per world unit that every tracking loop samples.
#ifndef MEDIUM_GLSL_ONCE
#define MEDIUM_GLSL_ONCE 1
#include "scene.glsl"
#include "clip.glsl"

vec4 transfer(float v) {
    return texture(tf_tex, (clamp(v, 0.0, 1.0) * (TF_SIZE - 1.0) + 0.5) / TF_SIZE);
}

float data_value(vec3 x) {
    float texel = texture(volume_tex, (x - scene.box_min) / scene.box_size).r;
    return clamp(texel * scene.value_map.x + scene.value_map.y, 0.0, 1.0);
}

float sigma_t(vec3 x) { return scene.density * transfer(data_value(x)).a; }

// sigma_t with nothing outside the volume's box, as the tracking loops see it (they
// clip every ray to the box).  sigma_t alone reads the texture clamped to its edge, so
// a probe beyond a face of a volume whose border voxels are dense would find medium
// there: the cache's probes around an entry (its normal, Delta and medium fractions)
// use this one.
float sigma_t_in_box(vec3 x) {
    vec3 hi = scene.box_min + scene.box_size;
    return all(greaterThanEqual(x, scene.box_min)) && all(lessThanEqual(x, hi)) && inside_clip(x) ? sigma_t(x) : 0.0;
}

vec3 albedo_at(vec3 x) { return transfer(data_value(x)).rgb; }

#endif
