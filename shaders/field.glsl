// field.glsl - the light field (paper 002 carried to volumes; docs/field.md): radiance
// propagated through a grid of cells along D global directions, iterated for multiple
// scattering, and images marched through the stored result.  Shared by the field's
// kernels (field_classify, field_light, field_scatter, field_render; host/field.c).
//
// The grid: n cells per axis over the volume's box, cell c's values held at its centre
// (box_min + (c + 1/2) cell).  Each cell keeps
//   cells[2c]      (sigma_t, albedo rgb): the classified medium, the transfer function
//                  applied first (the cell's mean extinction and its extinction-weighted
//                  albedo, never the extinction of a mean density);
//   cells[2c + 1]  (g, g1, f, active): the first lobe's asymmetry (sigma_s-weighted mean),
//                  the phase function's mean cosine g1 and second Legendre moment f (both
//                  lobes, picvr_scattering's second included); 1 where a cell of its
//                  5 x 5 x 5 neighbourhood holds medium (only those are ever read), else 0;
//   light_t[l cells + c]  (tau, tau' rgb): light l's optical depth from the cell's
//                  centre, exact along the line through the constant cells, through the
//                  true medium and through the delta-M scaled one (below).  Optical
//                  depth, not transmittance, is what the image interpolates: it is
//                  linear across a homogeneous region lit along an axis, so there the
//                  interpolation (and its extrapolation to the grid's faces) is exact;
//   field[3c + k]  (phi, F) of channel k: the fluence of the scattered light (and the
//                  background's) and its first moment.
// The radiance scattered into direction o is taken from the two bands as
// (phi + 3 g F . o) / 4 pi, clamped at 0 (a peaked field's two bands can go negative).
//
// delta-M (Wiscombe 1977): the phase function's forward peak f = its second moment counts
// as light that was not scattered; the sweeps run in sigma' = sigma (1 - f a),
// a' = a (1 - f) / (1 - f a), g' = (g1 - f) / (1 - f).  Rule: 1 - f a >= 1 - f > 0, as
// |g| <= CM_HG_G_MAX.  The camera keeps the true medium.
#ifndef FIELD_GLSL_ONCE
#define FIELD_GLSL_ONCE 1
#include "specialization.glsl"
#include "scene.glsl"
#include "sampling_math.glsl"
#include "geometry.glsl"

layout(set = 1, binding = 0, std430) buffer FieldCells { vec4 cells[]; };
layout(set = 1, binding = 1, std430) buffer FieldLightT { vec4 light_t[]; };
layout(set = 1, binding = 2, std430) readonly buffer FieldIn { vec4 field_in[]; };
layout(set = 1, binding = 3, std430) buffer FieldOut { vec4 field_out[]; };
// Per pass: the largest change of any cell's phi and the largest phi (float bits; both
// >= 0, so their bits order as the floats do).
layout(set = 1, binding = 4, std430) buffer FieldChange { uint field_change[]; };
// Per cell the logarithm of the light it scatters toward the camera, per channel, and
// of the light it would scatter unshadowed (field_view.comp).
layout(set = 1, binding = 5, std430) buffer FieldView { vec4 field_view[]; };
#define FIELD_LN_FLOOR -100.0

// Push constants of every field kernel (host/field.c, picvr_field_push).
layout(push_constant) uniform FieldPush {
    uvec4 n;           // xyz cells per axis, w cells in all
    vec4 cell;         // xyz a cell's size (the volume's frame), w unused
    uint half_dirs;    // D / 2
    uint dir_begin;    // field_scatter: the directions k (0 .. D) of this dispatch
    uint dir_end;
    uint flags;        // FIELD_*
    uint pass_index;   // field_scatter: the slot of field_change it writes
    uint samples;      // field_classify: sample points per axis and cell
    float step;        // field_render: the ray-marching step (the volume's frame)
    uint prior;        // field_render: the samples the image counts as in each pixel
} fp;

#define FIELD_SOURCE 1u      // field_scatter: the previous pass is the source; field_view:
                             // the field holds scattered light (else it is a placeholder)
#define FIELD_DELTA_M 2u     // the sweeps run in the delta-M scaled medium
#define FIELD_ADD 4u         // add to field_out (a later dispatch of the same pass)
#define FIELD_LAST 8u        // the pass's last dispatch: it records the change
#define FIELD_MULTIPLE 16u   // more than one scatter event: the camera's view of the
                             // lights takes the scaled transmittance (the reference's rule)
// A camera ray stops where its transmittance falls below this, the rest of the medium
// taken as radiating the last step's light (field_render.comp).
#define FIELD_T_MIN 1e-3

ivec3 field_cell_of(uint c) {
    return ivec3(c % fp.n.x, (c / fp.n.x) % fp.n.y, c / (fp.n.x * fp.n.y));
}

uint field_index(ivec3 q) { return uint(q.x) + fp.n.x * (uint(q.y) + fp.n.y * uint(q.z)); }

vec3 field_centre(ivec3 q) { return scene.box_min + (vec3(q) + 0.5) * fp.cell.xyz; }

// The k-th of the D / 2 directions over the upper hemisphere (z > 0): z uniform in
// (0, 1), so that each stands for an equal solid angle, azimuth by the golden angle
// (the reference's fref_direction).
vec3 field_direction(uint k) {
    float z = 1.0 - (float(k) + 0.5) / float(fp.half_dirs);
    float r = sqrt(max(0.0, 1.0 - z * z));
    float a = float(k) * 2.39996322972865332;   // pi (3 - sqrt 5)
    return vec3(r * cos(a), r * sin(a), z);
}

// Light i as seen from x: the unit direction toward it, its distance (1e30 for a
// directional light) and the irradiance it would give at x unshadowed, taken as a point
// (or a delta sun) of the same far-field intensity.  Rules: a distance below 1e-3 of a
// cell is taken as that (a large, finite value); a sphere light's as at least its radius;
// a rect lights only the side its normal faces (it is one-sided).
vec3 field_light_irradiance(uint i, vec3 x, out vec3 toward, out float dist) {
    Light l = scene.lights[i];
    if (l.type == LIGHT_DIRECTIONAL) {
        toward = l.pos;
        dist = 1e30;
        // a disk of angular radius theta (size = 1 - cos theta) gives pi sin^2 theta L
        return l.size > 0.0 ? l.radiance * (PI * l.size * (2.0 - l.size)) : l.radiance;
    }
    vec3 v = l.pos - x;
    float d = length(v);
    toward = d > 0.0 ? v / d : vec3(0.0, 0.0, 1.0);
    dist = d;
    float dmin = 1e-3 * min(fp.cell.x, min(fp.cell.y, fp.cell.z));
    float intensity_scale = 1.0;   // point: radiance holds the intensity
    if (l.type == LIGHT_SPHERE) {
        intensity_scale = PI * l.size * l.size;
        dmin = max(dmin, l.size);
    } else if (l.type == LIGHT_RECT) {
        vec3 nrm = cross(l.edge_u, l.edge_v);
        float nl = length(nrm);
        intensity_scale = nl > 0.0 ? l.area * max(dot(nrm / nl, -toward), 0.0) : 0.0;
    }
    d = max(d, dmin);
    return l.radiance * (intensity_scale / (d * d));
}

// The delta-M scaled medium of a cell (sigma_t, albedo) with second moment f: sigma'
// per channel and albedo' per channel.
void field_scaled(vec4 m, float f, out vec3 sigma, out vec3 albedo) {
    vec3 a = m.yzw;
    vec3 keep = 1.0 - f * a;                      // >= 1 - f > 0
    sigma = m.x * keep;
    albedo = a * (1.0 - f) / keep;
}

// A walk from x (inside the grid) along unit u through the cells, front to back: each
// call gives the next cell and the length of the ray within it, up to tmax (3D DDA).
struct FieldWalk { ivec3 q; ivec3 stp; vec3 t_next; vec3 t_delta; float t; bool done; };

FieldWalk field_walk_start(vec3 x, vec3 u) {
    FieldWalk w;
    vec3 p = (x - scene.box_min) / fp.cell.xyz;
    w.q = clamp(ivec3(floor(p)), ivec3(0), ivec3(fp.n.xyz) - 1);
    w.stp = ivec3(mix(vec3(-1.0), vec3(1.0), greaterThanEqual(u, vec3(0.0))));
    vec3 inv = safe_inverse(u);
    vec3 boundary = scene.box_min + (vec3(w.q) + vec3(greaterThan(w.stp, ivec3(0)))) * fp.cell.xyz;
    w.t_next = max((boundary - x) * inv, vec3(0.0));
    w.t_delta = abs(fp.cell.xyz * inv);
    w.t = 0.0;
    w.done = false;
    return w;
}

// The next cell and the ray's length in it; false once the walk has left the grid or
// passed tmax.
bool field_walk_next(inout FieldWalk w, float tmax, out uint cell, out float len) {
    cell = 0u;
    len = 0.0;
    if (w.done) return false;
    float te = min(w.t_next.x, min(w.t_next.y, w.t_next.z));
    cell = field_index(w.q);
    len = max(min(te, tmax) - w.t, 0.0);
    if (te >= tmax) { w.done = true; return true; }
    if (w.t_next.x <= w.t_next.y && w.t_next.x <= w.t_next.z) { w.q.x += w.stp.x; w.t_next.x += w.t_delta.x; }
    else if (w.t_next.y <= w.t_next.z) { w.q.y += w.stp.y; w.t_next.y += w.t_delta.y; }
    else { w.q.z += w.stp.z; w.t_next.z += w.t_delta.z; }
    w.t = te;
    w.done = any(lessThan(w.q, ivec3(0))) || any(greaterThanEqual(w.q, ivec3(fp.n.xyz)));
    return true;
}

#endif
