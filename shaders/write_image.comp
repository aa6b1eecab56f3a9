#version 450
// write_image.comp - the image for picvr_write_image (host/gpu_image.c): the running
// mean of the accumulation (plane 0: linear radiance and coverage) encoded for an
// application's VkImage.  kind 0 and 1: 8 bits per channel as picvr_read_rgba8 writes
// them (colour 1 - exp(-exposure L), sRGB-encoded; alpha the coverage), RGBA or BGRA
// order; kind 2: half floats, linear.  (Float32 images are copied from plane 0 as is.)
layout(local_size_x = 256) in;

layout(set = 0, binding = 0, std430) readonly buffer Mean { vec4 mean_rgba[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Encoded { uint words[]; };
layout(push_constant) uniform Push { uint pixel_count; uint kind; float exposure; uint pad; } pc;

// The sRGB transfer function on [0, 1], 8 bits, rounded to nearest.
// Rule: NaN and values <= 0 encode as 0 (never produced, never trusted), >= 1 as 255.
uint srgb8(float x) {
    if (!(x > 0.0)) return 0u;
    if (x >= 1.0) return 255u;
    float s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1.0 / 2.4) - 0.055;
    return min(uint(s * 255.0 + 0.5), 255u);
}

// Rule: half floats hold at most 65504; larger radiance saturates there (never Inf),
// NaN and negative values (never produced) become 0.
float half_safe(float x) { return x > 0.0 ? min(x, 65504.0) : 0.0; }

void main() {
    uint i = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * 256u + gl_LocalInvocationID.x;
    if (i >= pc.pixel_count) return;
    vec4 m = mean_rgba[i];
    if (pc.kind == 2u) {
        words[2u * i] = packHalf2x16(vec2(half_safe(m.r), half_safe(m.g)));
        words[2u * i + 1u] = packHalf2x16(vec2(half_safe(m.b), half_safe(min(m.a, 1.0))));
        return;
    }
    uvec3 c = uvec3(srgb8(1.0 - exp(-pc.exposure * m.r)), srgb8(1.0 - exp(-pc.exposure * m.g)),
                    srgb8(1.0 - exp(-pc.exposure * m.b)));
    uint a = m.a > 0.0 ? uint(min(m.a, 1.0) * 255.0 + 0.5) : 0u;
    if (pc.kind == 1u) c = c.bgr;
    words[i] = c.x | (c.y << 8) | (c.z << 16) | (a << 24);
}
