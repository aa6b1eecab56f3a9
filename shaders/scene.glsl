// scene.glsl - the scene as every rendering and cache kernel reads it: the uniform block
// Scene (camera, volume box, density D, majorant grid, lights, background, clip planes,
// the cache's parameters), the volume and transfer-function textures and the majorant
// buffer (bindings 0-3), and the constants of their layout.  Host mirrors:
// picvr_gpu_scene and picvr_gpu_light in host/internal.h.  Names follow the paper:
// sigma_t (extinction), tau (optical depth).
#ifndef SCENE_GLSL_ONCE
#define SCENE_GLSL_ONCE 1

#define PI 3.14159265358979
#define INV_4PI 0.0795774715459477
#define TF_SIZE 4096.0
#define MAX_LIGHTS 32
#define GPU_CLIP_PLANES 14   // PICVR_GPU_CLIP_PLANES: PICVR_MAX_CLIP_PLANES + the clip box's 6

#define LIGHT_SPHERE 1
#define LIGHT_RECT 2
#define LIGHT_DIRECTIONAL 3
#define LIGHT_POINT 4

// One light, packed by host/lights.c (picvr_pack_light); host mirror picvr_gpu_light.
struct Light {
    vec3 pos;      int type;     // position (sphere/rect centre, point) or unit direction
                                 // toward the light (directional); LIGHT_*
    vec3 radiance; float pmf;    // radiance (area; directional: E / (pi sin^2 half angle)),
                                 // irradiance (delta directional) or intensity (point);
                                 // the probability of choosing this light
    vec3 edge_u;   float size;   // rect edge_u; sphere radius, or 1 - cos(half angle) for
                                 // directional (0: a delta light)
    vec3 edge_v;   float area;   // rect edge_v and area
    float cdf;     float eq_pmf;  // upper end of its interval; the probability of choosing
                                 // it for equiangular sampling (0: not served)
    float eq_cdf;  float unused0; // upper end of its equiangular interval
};

// The scene (host mirror: picvr_gpu_scene in host/internal.h; `make check-layout`
// compares every member's offset).  Each line is one 16-byte std140 slot.
layout(set = 0, binding = 0, std140) uniform Scene {
    vec3 cam_pos;    float tan_half_fov;      // tan(fov_y / 2)
    vec3 cam_fwd;    float aspect;            // width / height
    vec4 cam_right;                           // xyz; w unused
    vec4 cam_up;                              // xyz; w unused
    vec3 box_min;    float density;           // world box min; density factor D (Fig. 9)
    vec3 box_size;   float bound_radius;      // world box size; radius of its bounding sphere
    vec3 cell_size;  float min_spacing;       // world size of a majorant cell; smallest spacing
    uvec3 grid;      uint light_count;        // majorant grid dims; number of lights
    uvec4 image;                              // x width, y height
    uvec4 dims;                               // xyz voxel dims
    vec3 background; float background_pmf;    // rgb radiance; probability of choosing it
    vec4 value_map;                           // normalized value = clamp(texel * x + y, 0, 1)
    float gamma; float epsilon; float delta; float update_threshold;
                                              // Eq. 5's gamma, Eq. 10's epsilon, Delta (world),
                                              // §4.3's conflict threshold
    float radius_min; float radius_max;       // validity radius bounds (world)
    uint curvature_limit; uint medium_model;  // 1: on (cache_math.glsl, curvature_radius and
                                              // medium_fraction)
    uint max_entries; uint max_nodes; uint max_refs; uint max_requests; // pool capacities
    uint superpixel_side; uint superpixels_per_row; uint superpixel_count; // §5.2
    float probe_fraction;                     // the consistent blend's least probe
                                              // probability (cache_blend.glsl)
    uint debug_view; uint view_unused0; uint view_unused1; uint view_unused2; // VIEW_*
    vec3 light_log_k; float mono_channel;     // lights of one chromaticity k (host/lights.c,
                                              // picvr_light_chromaticity): ln(k_c / k_m)
                                              // (CM_LN_E_MIN - CM_LN_E_MAX where k_c = 0);
                                              // the channel m, also MONO_CHANNEL
    uint max_bounces; float back_g; float back_weight; uint vertex_cost;
                                              // picvr_scattering (0xffffffff: unlimited);
                                              // path-pool charge per path vertex (path.glsl)
    uint env_w; uint env_h; float forced_pmf; float env_unused1; // environment map texels;
                                              // the forced share of camera-ray strategy B
                                              // (distance.glsl, b_sample)
    Light lights[MAX_LIGHTS];
    vec4 env_basis[3];                        // rows (xyz) of the map's frame from the
                                              // volume's: the volume's orientation, then
                                              // the map's rotation about world +y
    vec4 clip[GPU_CLIP_PLANES];               // the volume's frame: keep dot(xyz, x) + w >= 0
    uint clip_count; uint clip_unused0; uint clip_unused1; uint clip_unused2;
} scene;

layout(set = 0, binding = 1) uniform sampler3D volume_tex;   // normalized data value
layout(set = 0, binding = 2) uniform sampler1D tf_tex;       // rgb albedo, a opacity
layout(set = 0, binding = 3, std430) readonly buffer Majorant { float majorant[]; }; // majorant.glsl

#endif
