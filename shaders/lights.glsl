// lights.glsl - the lights (picvr_set_lights; packed by host/lights.c): a ray's nearest
// area light, their radiance and solid-angle pdfs, the power heuristic of MIS and the
// choice of one light by power.
#ifndef LIGHTS_GLSL_ONCE
#define LIGHTS_GLSL_ONCE 1
#include "scene.glsl"

#define PDF_CAP 1e18   // a light whose solid-angle pdf exceeds this acts as a delta light

// Nearest hit of the ray with any sphere or rect light in (0, tmax): the light's
// index or -1; *t_hit is its distance.  Area lights are opaque emitters.
int nearest_area_light(vec3 x, vec3 w, float tmax, out float t_hit) {
    int hit = -1;
    t_hit = tmax;
    for (uint i = 0u; i < scene.light_count; i++) {
        Light l = scene.lights[i];
        int type = l.type;
        if (type == LIGHT_SPHERE) {
            // Numerically stable ray/sphere test (Haines et al., Ray Tracing Gems
            // ch. 7): the discriminant from the closest-approach vector, not b^2 - c,
            // which loses r^2 against |oc|^2 for distant lights in float.
            float r = l.size;
            vec3 oc = x - l.pos;
            float b = dot(oc, w);
            vec3 f = oc - b * w;
            float disc = r * r - dot(f, f);
            if (disc < 0.0) continue;
            float s = sqrt(disc);
            float c = dot(oc, oc) - r * r;
            float q = b < 0.0 ? s - b : -b - s;   // -b - sign(b) s: no cancellation
            float r1 = q, r2 = q != 0.0 ? c / q : 0.0;
            float t = c > 0.0 ? min(r1, r2) : max(r1, r2);   // outside: near hit; inside: exit
            if (t > 0.0 && t < t_hit) { t_hit = t; hit = int(i); }
        } else if (type == LIGHT_RECT) {
            vec3 n = cross(l.edge_u, l.edge_v);
            float denom = dot(n, w);
            if (abs(denom) < 1e-30) continue;
            float t = dot(l.pos - x, n) / denom;
            if (t <= 0.0 || t >= t_hit) continue;
            // Parallelogram coordinates in the dual basis (edges need not be
            // perpendicular): q = su U + sv V with |n|^2 = dot(n, U x V).
            vec3 q = x + w * t - l.pos;
            float nn = dot(n, n);
            float su = dot(q, cross(l.edge_v, n)) / nn;
            float sv = dot(q, cross(n, l.edge_u)) / nn;
            if (abs(su) <= 0.5 && abs(sv) <= 0.5) { t_hit = t; hit = int(i); }
        }
    }
    return hit;
}

// Radiance leaving area light i toward -w at its hit point (rects are one-sided).
vec3 area_light_radiance(uint i, vec3 w) {
    Light l = scene.lights[i];
    if (l.type == LIGHT_RECT && dot(cross(l.edge_u, l.edge_v), w) >= 0.0) return vec3(0.0);
    return l.radiance;
}

// Solid-angle pdf of light i's sampling strategy for direction w from x, with the
// hit distance t (sphere, rect).  Capped at PDF_CAP.
float light_pdf(uint i, vec3 x, vec3 w, float t) {
    Light l = scene.lights[i];
    int type = l.type;
    if (type == LIGHT_SPHERE) {
        vec3 oc = l.pos - x;
        float d2 = dot(oc, oc), r2 = l.size * l.size;
        if (d2 <= r2) return INV_4PI;                 // inside: uniform sphere sampling
        float sin2 = r2 / d2;
        float omc = sin2 / (1.0 + sqrt(max(0.0, 1.0 - sin2)));  // 1 - cos, no cancellation
        return min(1.0 / (2.0 * PI * max(omc, 1e-30)), PDF_CAP);
    }
    if (type == LIGHT_RECT) {
        vec3 n = normalize(cross(l.edge_u, l.edge_v));
        float cos_l = abs(dot(n, w));
        return min(t * t / max(l.area * cos_l, 1e-30), PDF_CAP);
    }
    if (type == LIGHT_DIRECTIONAL) return min(1.0 / (2.0 * PI * max(l.size, 1e-30)), PDF_CAP);
    return 0.0;
}

// Power-heuristic MIS weight of a strategy with pdf a against one with pdf b, written
// as a / (a^2 + b^2) * a so that neither huge nor tiny pdfs overflow.
float power_weight(float a, float b) {
    if (a <= 0.0) return 0.0;
    float r = b / a;
    return 1.0 / (1.0 + r * r);
}

// Picks one light (or the background, index MAX_LIGHTS) by the precomputed
// power-proportional probabilities.
uint select_light(float u) {
    for (uint i = 0u; i < scene.light_count; i++)
        if (u < scene.lights[i].cdf) return i;
    return uint(MAX_LIGHTS);
}

#endif
