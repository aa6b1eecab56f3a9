/* render.c - picvr-render, the command-line renderer.
 *
 *   picvr-render --volume bonsai_256x256x256_uint8.raw.gz --tf ct-bonsai \
 *                --lights studio --time 20000 --out bonsai.png
 *
 * Loads a raw volume (volume_io) and an --env map (env_io), sets up a transfer
 * function, lights and an orbit camera from presets (presets), renders progressively
 * for a time or an exact number of iterations while showing the estimated error, and
 * writes PNG / PFM images, a per-round CSV log and a JSON summary (the statistics and
 * the configuration the library resolved).  `picvr-render --help` lists every option.
 *
 * Exit status: 0 success, 1 runtime error, 2 usage error, 130 interrupted (Ctrl-C
 * stops rendering early; the outputs are still written).
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "env_io.h"
#include "picvr.h"
#include "presets.h"
#include "render.h"
#include "picvr_io.h"

#define PROGRAM "picvr-render"
#define EXIT_USAGE 2
#define EXIT_INTERRUPTED 130

/* Progress display state; also the log callback's user data, so library messages
   do not get glued onto a half-drawn progress line. */
typedef struct progress {
    int enabled, tty, line_open;
    double start_ms, next_line_ms;
} progress;

static volatile sig_atomic_t interrupted = 0;

static void on_interrupt(int sig)
{
    (void)sig;
    interrupted = 1;
}

/* First Ctrl-C: finish the current round and write the outputs; a second one kills. */
static void install_interrupt_handler(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_interrupt;
    sa.sa_flags = SA_RESETHAND;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
}

/* ---- usage ------------------------------------------------------------------------- */

static void print_help(FILE *f)
{
    fprintf(f,
        "usage: " PROGRAM " [--volume] FILE [options]\n"
        "Progressive Monte-Carlo volume rendering with picvr.\n\n"
        "input\n"
        "  --volume FILE          the volume (required): NIfTI .nii[.gz], NRRD .nrrd/.nhdr,\n"
        "                         a DICOM folder (or one of its .dcm files), OpenVDB .vdb,\n"
        "                         or raw NAME_XxYxZ_TYPE.raw[.gz]; the file's geometry\n"
        "                         (spacing, orientation, origin) is applied\n"
        "  --grid NAME            the .vdb grid (default density, else the first float grid)\n"
        "  --dims X,Y,Z           voxel counts, if not in the file name\n"
        "  --type u8|u16|f32      voxel type, if not in the file name\n"
        "  --spacing X,Y,Z        world size of a voxel (default 1,1,1)\n"
        "  --range MIN,MAX        data values mapped to 0..1 (default: the type's range;\n"
        "                         the data's min..max for f32)\n"
        "  --range auto           from the data: its 0.5th and 99.5th percentiles (a CT's\n"
        "                         air and its densest tissue, whatever their units)\n"
        "look\n"
        "  --tf PRESET|FILE       transfer function: a preset below or a table file (see\n"
        "                         docs/medical.md); default from the file: ct-bone for CT\n"
        "                         in Hounsfield units, mr for other scans, cloud for .vdb,\n"
        "                         ramp for raw\n"
        "  --wl WIDTH,LEVEL       window and level in the data's units (HU for CT): the\n"
        "                         transfer function spans LEVEL -+ WIDTH/2\n"
        "  --clip-plane NX,NY,NZ,D  keep only where NX x + NY y + NZ z + D >= 0 (world;\n"
        "                         repeatable, up to 8)\n"
        "  --clip-box X0,Y0,Z0,X1,Y1,Z1  keep only that world box\n"
        "  --density D            override the preset's density factor D (per world unit)\n"
        "  --lights PRESET        light set-up (default studio)\n"
        "  --env FILE.hdr         a Radiance .hdr (RGBE) equirectangular map as the\n"
        "                         background, replacing the --lights preset's (its lights\n"
        "                         stay): row 0 the zenith (+y), the centre column along -z\n"
        "  --env-rotate DEG       turn the --env map about +y (default 0)\n"
        "  --env-intensity X      scale the --env map's radiance, X >= 0 (default 1)\n"
        "  --bounces N|unlimited  scatter events a path may have after its first: 0 single\n"
        "                         scattering (the paper's), unlimited: until Russian\n"
        "                         roulette ends it (default: the --tf preset's, 0 but\n"
        "                         for cloud: unlimited)\n"
        "  --g G                  Henyey-Greenstein g over the whole transfer function, in\n"
        "                         (-1, 1): 0 isotropic, > 0 forward (default: the preset's\n"
        "                         per point, 0 but for cloud: 0.8)\n"
        "  --phase-back G,W       a second HG lobe, g G in (-1, 1), weight W in [0, 1):\n"
        "                         phase = (1 - W) HG(g) + W HG(G) (default 0,0: one lobe)\n"
        "  --camera AZ,EL,DIST    orbit around the box centre: azimuth and elevation in\n"
        "                         degrees, distance as a factor of the distance at which\n"
        "                         the box just fills the view (default %g,%g,%g)\n"
        "  --fov DEG              vertical field of view (default %g)\n"
        "  --view NAME            a scan's view: anterior, posterior, left, right,\n"
        "                         superior, inferior (the patient's LPS frame; default\n"
        "                         anterior, then --camera's orbit, for a file with one)\n"
        "  --up +x|-x|+y|-y|+z|-z the world axis shown up (default +y; +z in a scan)\n"
        "  --exposure E           tone-mapping exposure for the PNG (default 1)\n"
        "rendering\n"
        "  --size WxH             image size (default 512x512)\n"
        "  --time MS              render for MS milliseconds (default 5000)\n"
        "  --iterations N         render exactly N iterations instead (deterministic)\n"
        "  --round MS             time per round between statistics (default 100)\n"
        "  --frames N             render N real-time frames instead, as an engine would:\n"
        "                         every pixel gets a sample each frame (no holes), then\n"
        "                         the rest of the budget goes by priority\n"
        "  --frame-ms MS          each frame's budget (default 16; a frame lasts at least\n"
        "                         one sample per pixel)\n"
        "  --orbit DEG            turn the camera's azimuth by DEG every frame (default 0:\n"
        "                         the frames refine one image)\n"
        "  --reuse on|off         temporal reuse: a moved camera keeps its samples,\n"
        "                         reprojected (default off)\n"
        "  --seed N               random seed (default 0)\n"
        "  --cache off|object|screen|auto  irradiance cache: off (plain Monte Carlo, the default\n"
        "                         for now), object- or screen-space locking, or auto\n"
        "                         (the cache where it measurably pays)\n"
        "  --priorities on|off    render the blocks with the largest expected error\n"
        "                         reduction first (Eq. 12; default on)\n"
        "  --sampling mis|free-flight|forced|auto  where camera rays gather light:\n"
        "                         delta tracking and equiangular sampling toward near\n"
        "                         lights by MIS (default), delta tracking alone (the\n"
        "                         paper's), MIS with a point forced into the medium too\n"
        "                         for the sun and distant lights (thin media), or\n"
        "                         whichever of mis and forced measurably pays\n"
        "  --transmittance residual|ratio|ray-marching  residual ratio tracking\n"
        "                         (default), ratio tracking (the paper's) or unbiased\n"
        "                         ray marching (thin media: less noise, more cost)\n"
        "  --render mc|field|field-mc  progressive Monte Carlo (default); the light\n"
        "                         field: one deterministic, noise-free image (the seed\n"
        "                         changes nothing; docs/field.md); or the field's image,\n"
        "                         then Monte Carlo from it; the last two not with --cache\n"
        "  --field-ratio N        voxels per field cell along each axis, 1..8 (default 8)\n"
        "  --field-directions D   the field's global directions, even, 8..1024 (default 32)\n"
        "  --field-step S         the field image's ray-marching step in voxels (default 2)\n"
        "  --shares CMIN,CMAX,UMIN,UMAX  device-time shares of cache-entry creation and\n"
        "                         update at hit rate 1 and 0 (paper §6; default\n"
        "                         0.05,0.15,0.01,0.02)\n"
        "  --warm MS              fill the cache for MS milliseconds first, creation at a\n"
        "                         0.85 share (as while a scene loads), then restart the\n"
        "                         image at the --shares (needs --cache object|screen)\n"
        "  --turns FILE,ID        take turns round by round with a second picvr-render\n"
        "                         given the same FILE and the other ID (0 or 1), so that\n"
        "                         two builds compared side by side share the machine's\n"
        "                         drift; FILE must hold 0 before either starts\n"
        "  --curvature on|off     shrink cache entries where the field bends within Delta\n"
        "                         (lit faces, shadow edges): less bias, far lower hit rate\n"
        "                         (default off: the paper's Eq. 9, 10 radii alone)\n"
        "  --medium on|off        place an entry's change along its normal axis within the\n"
        "                         medium, flat beyond a face (default on; off: the paper's\n"
        "                         Eq. 6, 7 literally, darker lit faces)\n"
        "  --samples N            Eq. 5's cap: at most N MIS samples per point of a new\n"
        "                         entry, a multiple of 128 (default 768; at most 768 on\n"
        "                         lavapipe, 8192 on a GPU): lower creates entries faster,\n"
        "                         noisier\n"
        "  --cache-param N=V      a number of picvr_cache_config by its name: gamma,\n"
        "                         epsilon, delta_voxels, radius_min_voxels,\n"
        "                         radius_max_voxels, update_threshold, lookup_event\n"
        "                         (repeatable; default Table 1's).  delta_voxels=1\n"
        "                         radius_max_voxels=4 cut a full cache's error 3x on the\n"
        "                         cloud; lookup_event=2 takes the multiply scattered cache\n"
        "                         at a path's second event (docs/cache.md)\n"
        "  --debug-view cache     show where the cache is: hits green, misses red, entry\n"
        "                         centres white (needs --cache object|screen)\n"
        "  --debug-view error     the cache's error where it is used: R the cached, G a\n"
        "                         plain estimate at the same scatter events (read it with\n"
        "                         --out-float); prints the error per hit\n"
        "  --device NAME          Vulkan device whose name contains NAME\n"
        "  --validation           enable the Khronos validation layer\n"
        "output\n"
        "  --out FILE             tone-mapped sRGB image, in the format its extension names:\n"
        "                         .png, .jpg (quality 95), .bmp or .tga\n"
        "  --alpha                keep the coverage (1 - transmittance) as alpha, .png and\n"
        "                         .tga (default: opaque RGB, the background included)\n"
        "  --out-float FILE       linear radiance: .exr (OpenEXR RGBA float), .pfm (RGB\n"
        "                         float) or .hdr (Radiance RGBE)\n"
        "  --log FILE.csv         statistics after every round\n"
        "  --json FILE            final statistics as JSON\n"
        "  --quiet                no progress on stderr (the summary still goes to stdout)\n"
        "  --help                 this text\n",
        PVP_DEFAULT_AZIMUTH, PVP_DEFAULT_ELEVATION, PVP_DEFAULT_DISTANCE, PVP_DEFAULT_FOV);
    fprintf(f, "\ntransfer functions (--tf)\n");
    for (size_t i = 0; pvp_tf_name(i); i++)
        fprintf(f, "  %-12s %s\n", pvp_tf_name(i), pvp_tf_description(i));
    fprintf(f, "\nlights (--lights), placed around the camera's view of the volume\n");
    for (size_t i = 0; pvp_lights_name(i); i++)
        fprintf(f, "  %-12s %s\n", pvp_lights_name(i), pvp_lights_description(i));
    fprintf(f, "\nExit status: 0 ok, 1 error, 2 usage error, 130 interrupted (outputs written).\n");
}

/* ---- options ----------------------------------------------------------------------- */

static const pvc_option OPTIONS[] = {
    {"validation", 0}, {"quiet", 0}, {"alpha", 0}, {"help", 0},
    {"volume", 1}, {"dims", 1}, {"type", 1}, {"spacing", 1}, {"range", 1}, {"tf", 1},
    {"density", 1}, {"lights", 1}, {"size", 1}, {"time", 1}, {"iterations", 1},
    {"round", 1}, {"seed", 1}, {"cache", 1}, {"priorities", 1}, {"curvature", 1},
    {"sampling", 1}, {"transmittance", 1}, {"render", 1}, {"field-ratio", 1}, {"field-directions", 1},
    {"field-step", 1},
    {"medium", 1}, {"samples", 1}, {"cache-param", 1}, {"shares", 1}, {"warm", 1},
    {"turns", 1}, {"debug-view", 1}, {"device", 1}, {"exposure", 1}, {"camera", 1},
    {"fov", 1}, {"out", 1}, {"out-float", 1}, {"log", 1}, {"json", 1}, {"bounces", 1},
    {"g", 1}, {"phase-back", 1}, {"env", 1}, {"env-rotate", 1}, {"env-intensity", 1},
    {"frames", 1}, {"frame-ms", 1}, {"orbit", 1}, {"reuse", 1}, {"wl", 1}, {"view", 1},
    {"up", 1}, {"clip-plane", 1}, {"clip-box", 1}, {"grid", 1}, {NULL, 0}};

static int positive_all(const float *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!(v[i] > 0.0f)) return 0;
    return 1;
}

/* Whether value is one of the names name(0), name(1), ...; if not, says so and lists
   them. */
static int known_preset(const char *option, const char *value, const char *(*name)(size_t))
{
    for (size_t i = 0; name(i); i++)
        if (!strcmp(value, name(i))) return 1;
    pvc_fail("unknown --%s '%s'; presets:", option, value);
    for (size_t i = 0; name(i); i++) fprintf(stderr, " %s", name(i));
    fputc('\n', stderr);
    return 0;
}

/* --turns FILE,ID with ID 0 or 1. */
static int parse_turns(const char *value, render_options *o)
{
    const char *comma = strrchr(value, ',');
    size_t len = comma ? (size_t)(comma - value) : 0;
    if (!(len > 0 && len < sizeof o->turns_path && (!strcmp(comma + 1, "0") || !strcmp(comma + 1, "1"))))
        return 0;
    memcpy(o->turns_path, value, len);
    o->turns_path[len] = '\0';
    o->turns_id = (unsigned)(comma[1] - '0');
    return 1;
}

/* --shares CMIN,CMAX,UMIN,UMAX, each in (0, 1). */
static int parse_shares(const char *value, float shares[4])
{
    float s[4];
    if (!pvc_parse_floats(value, 4, s)) return 0;
    for (int k = 0; k < 4; k++)
        if (!(s[k] > 0.0f && s[k] < 1.0f)) return 0;
    memcpy(shares, s, sizeof s);
    return 1;
}

/* --camera AZ,EL,DIST with DIST > 0. */
static int parse_camera(const char *value, render_options *o)
{
    float c[3];
    if (!pvc_parse_floats(value, 3, c) || !(c[2] > 0.0f)) return 0;
    o->azimuth = c[0];
    o->elevation = c[1];
    o->distance = c[2];
    return 1;
}

/* --phase-back G,W with G in (-1, 1), W in [0, 1). */
static int parse_phase_back(const char *value, float back[2])
{
    float v[2];
    if (!pvc_parse_floats(value, 2, v) || !(v[0] > -1.0f && v[0] < 1.0f) ||
        !(v[1] >= 0.0f && v[1] < 1.0f))
        return 0;
    memcpy(back, v, sizeof v);
    return 1;
}

/* --up: a signed world axis. */
static int parse_axis(const char *value, float axis[3])
{
    if (!value || (value[0] != '+' && value[0] != '-') || !value[1] || value[2] || value[1] < 'x' || value[1] > 'z')
        return 0;
    memset(axis, 0, 3 * sizeof *axis);
    axis[value[1] - 'x'] = value[0] == '+' ? 1.0f : -1.0f;
    return 1;
}

/* --clip-plane NX,NY,NZ,D (a normal that is not 0), appended. */
static int parse_clip_plane(const char *value, picvr_clip *clip)
{
    float p[4];
    if (clip->plane_count >= PICVR_MAX_CLIP_PLANES) {
        pvc_fail("at most %d --clip-plane", PICVR_MAX_CLIP_PLANES);
        return 0;
    }
    if (!pvc_parse_floats(value, 4, p) || (p[0] == 0.0f && p[1] == 0.0f && p[2] == 0.0f)) return 0;
    memcpy(clip->planes[clip->plane_count++], p, sizeof p);
    return 1;
}

/* --clip-box X0,Y0,Z0,X1,Y1,Z1 with X0 <= X1, ... */
static int parse_clip_box(const char *value, picvr_clip *clip)
{
    float b[6];
    if (!pvc_parse_floats(value, 6, b) || !(b[0] <= b[3] && b[1] <= b[4] && b[2] <= b[5])) return 0;
    clip->use_box = 1;
    memcpy(clip->box_min, b, 3 * sizeof *b);
    memcpy(clip->box_max, b + 3, 3 * sizeof *b);
    return 1;
}

/* Each apply_*_option: 1 applied, 0 a bad value, -1 not an option of its group. */

/* The input and the look: volume layout, density, camera. */
static int apply_scene_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "volume")) {
        o->volume_path = value;
        return 1;
    }
    if (!strcmp(name, "dims")) return o->have_dims = pvc_parse_u32s(value, 3, 1, PICVR_IO_MAX_DIM, o->dims);
    if (!strcmp(name, "type")) return o->have_type = picvr_io_parse_type(value, &o->type) == PICVR_IO_OK;
    if (!strcmp(name, "spacing"))
        return o->have_spacing = pvc_parse_floats(value, 3, o->spacing) && positive_all(o->spacing, 3);
    if (!strcmp(name, "range") && !strcmp(value, "auto")) {   /* the last --range wins */
        o->have_range = 0;
        return o->range_auto = 1;
    }
    if (!strcmp(name, "range")) {
        o->range_auto = 0;
        return o->have_range = pvc_parse_floats(value, 2, o->range) && o->range[0] < o->range[1];
    }
    if (!strcmp(name, "density"))
        return o->have_density = pvc_parse_float(value, &o->density) && o->density >= 0.0f;
    if (!strcmp(name, "camera")) return parse_camera(value, o);
    if (!strcmp(name, "grid")) {
        o->grid = value;
        return 1;
    }
    if (!strcmp(name, "wl"))
        return o->have_wl = pvc_parse_floats(value, 2, o->wl) && o->wl[0] > 0.0f;
    if (!strcmp(name, "view")) {
        float f[3], u[3];
        o->view = value;
        if (pvp_patient_view(value, f, u) == PVP_OK) return 1;
        pvc_fail("unknown --view '%s': anterior, posterior, left, right, superior, inferior", value);
        return 0;
    }
    if (!strcmp(name, "up")) return o->have_up = parse_axis(value, o->up);
    if (!strcmp(name, "clip-plane")) return parse_clip_plane(value, &o->clip);
    if (!strcmp(name, "clip-box")) return parse_clip_box(value, &o->clip);
    if (!strcmp(name, "fov")) return pvc_parse_float(value, &o->fov) && o->fov > 0.0f && o->fov <= 179.0f;
    return -1;
}

/* Scattering and the environment map. */
static int apply_light_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "bounces")) return o->have_bounces = pvc_parse_bounces(value, &o->bounces);
    if (!strcmp(name, "g"))
        return o->have_g = pvc_parse_float(value, &o->g) && o->g > -1.0f && o->g < 1.0f;
    if (!strcmp(name, "phase-back")) return parse_phase_back(value, o->phase_back);
    if (!strcmp(name, "env")) {
        o->env_path = value;
        return 1;
    }
    if (!strcmp(name, "env-rotate"))
        return o->have_env_rotate = pvc_parse_float(value, &o->env_rotate);
    if (!strcmp(name, "env-intensity"))
        return o->have_env_intensity =
                   pvc_parse_float(value, &o->env_intensity) && o->env_intensity >= 0.0f;
    return -1;
}

/* The cache and the scheduler. */
static int apply_cache_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "cache")) return pvc_parse_cache_mode(value, &o->cache);
    if (!strcmp(name, "priorities")) return pvc_parse_switch(value, &o->priorities);
    if (!strcmp(name, "sampling")) return pvc_parse_distance_sampling(value, &o->distance_sampling);
    if (!strcmp(name, "transmittance")) return pvc_parse_transmittance(value, &o->transmittance);
    if (!strcmp(name, "render")) return pvc_parse_render_mode(value, &o->render_mode);
    if (!strcmp(name, "field-ratio")) return pvc_parse_u32(value, 1, 8, &o->field_ratio);
    if (!strcmp(name, "field-step"))
        return pvc_parse_float(value, &o->field_step) && o->field_step >= 0.125f && o->field_step <= 64.0f;
    if (!strcmp(name, "field-directions"))
        return pvc_parse_u32(value, 8, 1024, &o->field_directions) && o->field_directions % 2 == 0;
    if (!strcmp(name, "curvature")) return pvc_parse_switch(value, &o->curvature);
    if (!strcmp(name, "medium")) return pvc_parse_switch(value, &o->medium);
    if (!strcmp(name, "samples")) return pvc_parse_u32(value, 1, PICVR_CACHE_MAX_SAMPLES, &o->max_samples);
    if (!strcmp(name, "cache-param")) return pvp_cache_param_set(&o->params, value) == PVP_OK;
    if (!strcmp(name, "shares")) return parse_shares(value, o->shares);
    if (!strcmp(name, "warm")) return pvc_parse_double(value, &o->warm_ms) && o->warm_ms > 0.0;
    return -1;
}

/* The run: size, length, seed, device, debug views. */
static int apply_run_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "size")) {
        if (pvc_parse_size(value, PICVR_MAX_IMAGE_SIZE, &o->width, &o->height)) return 1;
        pvc_fail("--size %s: WIDTHxHEIGHT, each 1..%u (picvr's largest image)", value, (unsigned)PICVR_MAX_IMAGE_SIZE);
        return 0;
    }
    if (!strcmp(name, "time")) return o->have_time = pvc_parse_double(value, &o->time_ms) && o->time_ms > 0.0;
    if (!strcmp(name, "iterations")) return pvc_parse_u32(value, 1, UINT32_MAX, &o->iterations);
    if (!strcmp(name, "round")) return pvc_parse_double(value, &o->round_ms) && o->round_ms > 0.0;
    if (!strcmp(name, "frames")) return pvc_parse_u32(value, 1, 1000000, &o->frames);
    if (!strcmp(name, "frame-ms"))
        return (o->have_frame_ms = pvc_parse_double(value, &o->frame_ms)) && o->frame_ms >= 0.0 && o->frame_ms <= 60000.0;
    if (!strcmp(name, "orbit")) return o->have_orbit = pvc_parse_float(value, &o->orbit_deg);
    if (!strcmp(name, "reuse")) return pvc_parse_switch(value, &o->reuse);
    if (!strcmp(name, "seed")) return pvc_parse_u32(value, 0, UINT32_MAX, &o->seed);
    if (!strcmp(name, "turns")) return parse_turns(value, o);
    if (!strcmp(name, "device")) {
        o->device = value;
        return 1;
    }
    if (!strcmp(name, "debug-view")) {
        o->debug_view = value;
        return !strcmp(value, "cache") || !strcmp(value, "error") || !strcmp(value, "image");
    }
    return -1;
}

/* The outputs and the flags (value NULL). */
static int apply_output_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "validation")) o->validation = 1;
    else if (!strcmp(name, "quiet")) o->quiet = 1;
    else if (!strcmp(name, "alpha")) o->png_alpha = 1;
    else if (!strcmp(name, "exposure")) return pvc_parse_float(value, &o->exposure) && o->exposure > 0.0f;
    else if (!strcmp(name, "out")) {
        o->out_png = value;
        if (!(pvc_has_extension(value, ".png") || pvc_has_extension(value, ".jpg") ||
              pvc_has_extension(value, ".jpeg") || pvc_has_extension(value, ".bmp") || pvc_has_extension(value, ".tga"))) {
            pvc_fail("--out %s: the extension names no format written (.png, .jpg, .bmp, .tga)", value);
            return 0;
        }
    } else if (!strcmp(name, "out-float")) {
        o->out_pfm = value;
        if (!(pvc_has_extension(value, ".pfm") || pvc_has_extension(value, ".hdr") || pvc_has_extension(value, ".exr"))) {
            pvc_fail("--out-float %s: the extension names no format written (.exr, .pfm, .hdr)", value);
            return 0;
        }
    }
    else if (!strcmp(name, "log")) o->log_path = value;
    else if (!strcmp(name, "json")) o->json_path = value;
    else return -1;
    return 1;
}

/* Applies one option of OPTIONS; returns 0 and prints why on a bad value. */
static int apply_option(void *target, const char *name, const char *value)
{
    render_options *o = target;
    if (!strcmp(name, "tf")) {   /* a preset, else a file */
        o->tf_name = value;
        o->have_tf = 1;
        pvp_tf tf;
        if (pvp_tf_preset(value, &tf) == PVP_OK || access(value, R_OK) == 0) return 1;
        return known_preset(name, value, pvp_tf_name);
    }
    if (!strcmp(name, "lights")) {
        o->lights_name = value;
        return known_preset(name, value, pvp_lights_name);
    }
    static const pvc_group_fn groups[] = {apply_scene_option, apply_light_option,
                                          apply_cache_option, apply_run_option,
                                          apply_output_option};
    return pvc_apply_by_group(groups, sizeof groups / sizeof groups[0], o, name, value);
}

static void set_defaults(render_options *o)
{
    memset(o, 0, sizeof *o);
    o->tf_name = "ramp";
    o->lights_name = "studio";
    o->width = o->height = 512;
    o->time_ms = 5000.0;
    o->round_ms = 100.0;
    o->frame_ms = 16.0;
    o->exposure = 1.0f;
    o->azimuth = PVP_DEFAULT_AZIMUTH;
    o->elevation = PVP_DEFAULT_ELEVATION;
    o->distance = PVP_DEFAULT_DISTANCE;
    o->fov = PVP_DEFAULT_FOV;
    o->env_intensity = 1.0f;
}

/* The rules between options; returns 0 after saying which one is broken. */
static int options_consistent(const render_options *o)
{
    if (!o->volume_path) {
        pvc_fail("--volume FILE is required (see --help)");
        return 0;
    }
    if (o->have_time && o->iterations) {
        pvc_fail("give --time or --iterations, not both");
        return 0;
    }
    if (o->frames && (o->have_time || o->iterations)) {
        pvc_fail("give --frames, --time or --iterations, one of them");
        return 0;
    }
    if (!o->frames && (o->have_frame_ms || o->have_orbit)) {
        pvc_fail("--frame-ms and --orbit apply to --frames N");
        return 0;
    }
    if (o->render_mode >= PICVR_RENDER_FIELD && o->cache != PICVR_CACHE_NONE && o->cache != PICVR_CACHE_DEFAULT) {
        pvc_fail("--render field renders without the cache: leave --cache out");
        return 0;
    }
    if (o->render_mode == PICVR_RENDER_FIELD && (o->have_time || o->iterations > 1)) {
        pvc_fail("--render field makes one deterministic image: leave --time and --iterations out");
        return 0;
    }
    if (o->warm_ms > 0.0 && o->cache != PICVR_CACHE_OBJECT_SPACE && o->cache != PICVR_CACHE_SCREEN_SPACE) {
        pvc_fail("--warm fills the cache: give --cache object or --cache screen");
        return 0;
    }
    if (o->png_alpha && o->out_png && !pvc_has_extension(o->out_png, ".png") && !pvc_has_extension(o->out_png, ".tga")) {
        pvc_fail("--alpha needs an image format with alpha: --out FILE.png or FILE.tga");
        return 0;
    }
    if (o->view && o->have_up) {
        pvc_fail("--view sets the up axis: give --view or --up");
        return 0;
    }
    if (o->have_wl && (o->have_range || o->range_auto)) {
        pvc_fail("give --wl (physical units) or --range (stored values), not both");
        return 0;
    }
    if ((o->have_env_rotate || o->have_env_intensity) && !o->env_path) {
        pvc_fail("--env-rotate and --env-intensity apply to a map: give --env FILE");
        return 0;
    }
    return 1;
}

/* Returns -1 to go on rendering, else the exit status (0 after --help, 2 on errors). */
static int parse_options(int argc, char **argv, render_options *o)
{
    set_defaults(o);
    int status = pvc_parse_options_positional(argc, argv, OPTIONS, "volume", apply_option, o, print_help);
    if (status < 0 && !options_consistent(o)) return EXIT_USAGE;
    return status;   /* the transfer function, its bounces and window come with the volume */
}

/* ---- volume ---------------------------------------------------------------------------- */

/* The file names a format whose header (or series) gives the layout. */
static int layout_in_header(const char *path)
{
    return picvr_io_is_nrrd(path) || picvr_io_is_nifti(path) || picvr_io_is_vdb(path) || picvr_io_is_dicom(path);
}

/* Layout from --dims/--type where given, the rest from the file name. */
static int resolve_layout(const render_options *o, picvr_io_layout *layout)
{
    char err[512];
    if (layout_in_header(o->volume_path)) {   /* the header gives the layout (render: NULL) */
        if (o->have_dims || o->have_type) {
            pvc_fail("%s: --dims and --type come from the file's header", o->volume_path);
            return 0;
        }
        return 1;
    }
    if (!(o->have_dims && o->have_type)) {
        if (picvr_io_parse_name(o->volume_path, layout, err, sizeof err) != PICVR_IO_OK) {
            pvc_fail("%s", err);
            return 0;
        }
    } else if (picvr_io_parse_name(o->volume_path, layout, err, sizeof err) != PICVR_IO_OK) {
        memset(layout, 0, sizeof *layout);   /* a name without a layout: --dims and --type say it all */
    }
    /* Rule: --dims that disagree with the file name's (a permutation renders sheared
       slabs, the same byte count and no error) are refused. */
    if (o->have_dims && layout->dims[0] && memcmp(layout->dims, o->dims, sizeof o->dims)) {
        pvc_fail("--dims %u,%u,%u disagree with the file name's %ux%ux%u", o->dims[0], o->dims[1], o->dims[2],
                 layout->dims[0], layout->dims[1], layout->dims[2]);
        return 0;
    }
    if (o->have_dims) memcpy(layout->dims, o->dims, sizeof layout->dims);
    if (o->have_type) layout->type = o->type;
    if (picvr_io_layout_bytes(layout, NULL, err, sizeof err) != PICVR_IO_OK) {
        pvc_fail("%s", err);
        return 0;
    }
    return 1;
}

/* ---- environment map ----------------------------------------------------------------- */

/* --env: linear RGB texels, rows top to bottom (malloc'd by env_io: pvenv_free). */
typedef struct env_map {
    float *rgb;
    uint32_t width, height;
} env_map;

/* Loads --env (cli/env_io.h: a Radiance .hdr, "-Y H +X W", of at most
   PICVR_MAX_ENV_SIZE texels a side, not all black).  0 after reporting why not. */
static int load_env(const char *path, env_map *env)
{
    char err[8192];
    pvenv_status status = pvenv_load_hdr(path, &env->rgb, &env->width, &env->height,
                                         err, sizeof err);
    if (status == PVENV_ERROR_READ) pvc_fail("%s", err);  /* "cannot read PATH: ..." */
    else if (status != PVENV_OK) pvc_fail("--env %s", err);  /* "--env PATH: ..." */
    return status == PVENV_OK;
}

/* ---- progress and logging ------------------------------------------------------------- */

static void end_progress_line(progress *p)
{
    if (p->line_open) fputs("\r\033[K", stderr);
    p->line_open = 0;
}

static void log_message(picvr_log_level level, const char *message, void *user)
{
    end_progress_line(user);
    fprintf(stderr, "picvr %s: %s\n", pvc_log_level_name(level), message);
}

/* A redrawn bar on a terminal; otherwise about one line per second, so a captured
   log shows the error against time. */
static void show_progress(progress *p, double fraction, const picvr_stats *s)
{
    if (!p->enabled) return;
    double t = pvc_now_ms();
    double elapsed = (t - p->start_ms) / 1e3;
    if (p->tty) {
        char bar[31];
        int filled = (int)(fraction * 30.0 + 0.5);
        for (int i = 0; i < 30; i++) bar[i] = i < filled ? '#' : '.';
        bar[30] = '\0';
        fprintf(stderr, "\r%3.0f%% [%s] %6.1f s  %7u it  rel.err %.4f\033[K",
                fraction * 100.0, bar, elapsed, s->iterations, s->est_rel_error);
        p->line_open = 1;
    } else if (t >= p->next_line_ms) {
        fprintf(stderr, PROGRAM ": %7.1f s  %7u iterations  est_error %.5g  "
                "est_rel_error %.5g\n", elapsed, s->iterations, s->est_error,
                s->est_rel_error);
        p->next_line_ms = t + 1000.0;
    }
    fflush(stderr);
}

static int write_log_row(FILE *log, unsigned round, const picvr_stats *s)
{
    if (!log) return 1;
    fprintf(log, "%u,%.3f,%u,%.9g,%.9g,%.9g,%.9g,%u,%u,%.4f,%.4f,%.4f,%.4f,%.4f,%u\n", round,
            s->elapsed_ms, s->iterations, s->est_error, s->est_rel_error, s->samples_per_second,
            s->cache_hit_rate, s->cache_entries, s->cache_refs, s->fraction_render,
            s->fraction_create, s->fraction_update, s->target_create, s->target_update,
            s->cache_entries_capped);
    /* Flushed per row so `tail -f` works and a crash keeps what was measured. */
    return fflush(log) == 0;
}

/* ---- rendering ------------------------------------------------------------------------ */

/* --turns FILE,ID: two picvr-render processes (two builds, say) render in turns, one
   round each, so that the drift of a shared machine falls on both alike and their
   iterations per second of rendering time make a paired ratio.  FILE holds a counter:
   ID 0 renders while it is even, ID 1 while it is odd; only the process whose turn it
   is writes it (a new file renamed over it, which is atomic).  A partner that has not
   passed the turn for 30 s has finished (or died): the process goes on alone. */
typedef struct turns {
    const char *path;        /* NULL: no turns */
    unsigned id;
    int alone;
    long seen;               /* the counter turn_wait last read: turn_pass writes seen + 1 */
} turns;

static long read_turn(const char *path)
{
    long v = -1;
    FILE *f = fopen(path, "r");
    if (f) {
        if (fscanf(f, "%ld", &v) != 1) v = -1;
        fclose(f);
    }
    return v;
}

static void turn_wait(turns *t)
{
    if (!t->path || t->alone) return;
    double start = pvc_now_ms();
    for (;;) {
        long v = read_turn(t->path);
        if (v >= 0 && (unsigned long)v % 2 == t->id) {
            t->seen = v;
            return;
        }
        if (pvc_now_ms() - start > 30000.0) {
            fprintf(stderr, "picvr-render: --turns: no turn for 30 s, going on alone\n");
            t->alone = 1;
            return;
        }
        struct timespec ms = {0, 1000000};
        nanosleep(&ms, NULL);
    }
}

static void turn_pass(turns *t)
{
    if (!t->path || t->alone) return;
    char tmp[4096];
    snprintf(tmp, sizeof tmp, "%s.%u", t->path, t->id);
    FILE *f = fopen(tmp, "w");
    int ok = f && fprintf(f, "%ld\n", t->seen + 1) > 0;
    if (f && fclose(f) != 0) ok = 0;
    if (!ok || rename(tmp, t->path) != 0) {
        fprintf(stderr, "picvr-render: --turns: cannot write %s (%s), going on alone\n", t->path, strerror(errno));
        t->alone = 1;
    }
}

typedef struct render_state {
    picvr_context *ctx;
    FILE *log;
    progress *progress;
    unsigned round;
    picvr_stats stats;
    turns turns;
} render_state;

/* Statistics, the CSV row and the progress display after one round. */
static int finish_round(render_state *r, double fraction)
{
    if (!pvc_check(picvr_get_stats(r->ctx, &r->stats), "picvr_get_stats")) return 0;
    r->round++;
    if (!write_log_row(r->log, r->round, &r->stats)) {
        pvc_fail("writing the log: %s", strerror(errno));
        return 0;
    }
    show_progress(r->progress, fraction, &r->stats);
    return 1;
}

/* A budget too short for every pixel to receive a sample would leave an image with
   black holes (at a large size, an almost black one).  Rather than write that, the
   render goes on, round by round, until the pass completes, and says how long past the
   budget it ran.  An interrupt still stops it: that image is incomplete, as the summary
   line's pixels_unsampled says. */
static int complete_pass(render_state *r, double rendered, double round_ms)
{
    uint64_t holes = r->stats.pixels_unsampled;
    if (holes == 0 || interrupted) return 1;
    double budget = rendered;
    while (r->stats.pixels_unsampled > 0 && !interrupted) {
        turn_wait(&r->turns);
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(r->ctx, round_ms), "picvr_step")) return 0;
        rendered += pvc_now_ms() - t0;
        if (!finish_round(r, 1.0)) return 0;
        turn_pass(&r->turns);
    }
    end_progress_line(r->progress);
    fprintf(stderr, PROGRAM ": the budget ended with %llu of the pixels still without a sample: "
            "rendered %.1f s more, until %s\n", (unsigned long long)holes, (rendered - budget) / 1e3,
            interrupted ? "interrupted (the image is incomplete)" : "every pixel had one");
    return 1;
}

/* Rounds of picvr_step() until time_ms of rendering (time inside picvr_step), then on
   until every pixel holds a sample (complete_pass). */
static int render_for_time(render_state *r, double time_ms, double round_ms)
{
    double rendered = 0.0;
    while (rendered < time_ms && !interrupted) {
        double want = time_ms - rendered < round_ms ? time_ms - rendered : round_ms;
        turn_wait(&r->turns);
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(r->ctx, want), "picvr_step")) return 0;
        rendered += pvc_now_ms() - t0;
        if (!finish_round(r, rendered >= time_ms ? 1.0 : rendered / time_ms)) return 0;
        turn_pass(&r->turns);
    }
    return complete_pass(r, rendered, round_ms);
}

/* Fills the cache for o->warm_ms at PVP_WARM_CREATE_SHARE, then switches to the shares of
   `run` and restarts the image: picvr_set_scheduler and picvr_reset keep the cache. */
static int warm_up(render_state *r, const render_options *o, const picvr_scheduler_config *run)
{
    picvr_scheduler_config warm = *run;
    warm.create_min = warm.create_max = PVP_WARM_CREATE_SHARE;
    warm.update_min = warm.update_max = 0.02f;
    if (!pvc_check(picvr_set_scheduler(r->ctx, &warm), "picvr_set_scheduler")) return 0;
    double done = 0.0;
    while (done < o->warm_ms && !interrupted) {
        double want = o->warm_ms - done < o->round_ms ? o->warm_ms - done : o->round_ms;
        turn_wait(&r->turns);
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(r->ctx, want), "picvr_step")) return 0;
        done += pvc_now_ms() - t0;
        turn_pass(&r->turns);
    }
    picvr_stats st;
    if (!pvc_check(picvr_get_stats(r->ctx, &st), "picvr_get_stats")) return 0;
    end_progress_line(r->progress);
    if (!o->quiet)
        fprintf(stderr, "picvr-render: warm-up %.1f s: %u cache entries, hit rate %.3f\n", done / 1e3,
                st.cache_entries, st.cache_hit_rate);
    return pvc_check(picvr_set_scheduler(r->ctx, run), "picvr_set_scheduler") &&
           pvc_check(picvr_reset(r->ctx), "picvr_reset");
}

/* Exactly `total` iterations, in chunks sized to take about round_ms each (the same
   seed and iteration count give the same image however they are chunked). */
static int render_iterations(render_state *r, uint32_t total, double round_ms)
{
    uint32_t done = 0, chunk = 1;
    while (done < total && !interrupted) {
        uint32_t n = total - done < chunk ? total - done : chunk;
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step_iterations(r->ctx, n), "picvr_step_iterations")) return 0;
        double per_iteration = (pvc_now_ms() - t0) / n;
        done += n;
        if (!finish_round(r, (double)done / total)) return 0;
        /* Grow at most 4x per round so one fast measurement cannot overshoot. */
        double ideal = per_iteration > 0.0 ? round_ms / per_iteration : 4.0 * chunk;
        double limit = 4.0 * chunk;
        chunk = (uint32_t)(ideal < 1.0 ? 1.0 : ideal > limit ? limit : ideal);
    }
    return 1;
}

/* --frames: N frames of frame_ms each (picvr_step with scheduler.frames on), the camera
   turned by orbit_deg between them; each frame's time inside picvr_step and the image's
   statistics after it. */
static int render_frames_loop(render_state *r, const render_options *o, render_frames *out)
{
    float box_min[3], box_max[3];
    if (!pvc_check(picvr_volume_box(r->ctx, box_min, box_max), "picvr_volume_box")) return 0;
    out->items = calloc(o->frames, sizeof *out->items);
    if (!out->items) {
        pvc_fail("out of memory for %u frames", o->frames);
        return 0;
    }
    for (uint32_t i = 0; i < o->frames && !interrupted; i++) {
        if (i > 0 && o->orbit_deg != 0.0f) {
            picvr_camera cam;
            float az = fmodf(o->azimuth + (float)i * o->orbit_deg, 360.0f);
            pvp_status ps = pvp_orbit_camera(box_min, box_max, az, o->elevation, o->distance, o->fov,
                                             o->width, o->height, &cam);
            if (ps != PVP_OK) {
                pvc_fail("camera: %s", pvp_status_string(ps));
                return 0;
            }
            if (!pvc_check(picvr_set_camera(r->ctx, &cam), "picvr_set_camera")) return 0;
        }
        double t0 = pvc_now_ms();
        if (!pvc_check(picvr_step(r->ctx, o->frame_ms), "picvr_step")) return 0;
        render_frame *f = &out->items[out->length++];
        f->ms = pvc_now_ms() - t0;
        if (!finish_round(r, (double)(i + 1) / o->frames)) return 0;
        f->pixels_unsampled = r->stats.pixels_unsampled;
        /* Rule: Eq. 5's estimate needs two samples in a pixel; with one everywhere the
           frame's error is unknown (NaN, null in the JSON), not 0. */
        f->est_rel_error = r->stats.iterations_mean > 1.0 ? r->stats.est_rel_error : NAN;
        f->samples_per_pixel = r->stats.iterations_mean;
    }
    return 1;
}

/* ---- scene set-up ----------------------------------------------------------------------- */

/* Loads the volume file into host memory, with --spacing applied; says what the reader
   noticed (tilt, dropped volumes, ...). */
static int load_volume(const render_options *o, const picvr_io_layout *layout, picvr_io_volume *vol)
{
    char err[512];
    picvr_io_status st = o->grid || picvr_io_is_vdb(o->volume_path)
                       ? picvr_io_load_vdb(o->volume_path, o->grid, vol, err, sizeof err)
                       : picvr_io_load(o->volume_path, layout, vol, err, sizeof err);
    if (st != PICVR_IO_OK) {
        pvc_fail("%s", err);
        return 0;
    }
    if (o->have_spacing) memcpy(vol->spacing, o->spacing, sizeof vol->spacing);
    if (vol->warning[0] && !o->quiet) fprintf(stderr, PROGRAM ": %s: %s\n", o->volume_path, vol->warning);
    return 1;
}

/* The data's physical values (stored * value_scale + value_offset) at the lo and hi
   quantiles; 0 when the volume has no finite value. */
static int physical_percentiles(const picvr_io_volume *vol, double lo_frac, double hi_frac, double *lo, double *hi)
{
    double a, b;
    if (picvr_io_percentile_range(vol, lo_frac, hi_frac, &a, &b) != PICVR_IO_OK) return 0;
    a = a * vol->value_scale + vol->value_offset;
    b = b * vol->value_scale + vol->value_offset;
    *lo = a < b ? a : b;
    *hi = a < b ? b : a;
    return 1;
}

/* Whether the volume is a CT in Hounsfield units (pvp_is_hounsfield), and why. */
static int is_hounsfield(const picvr_io_volume *vol, const char **why)
{
    double lo = 0.0, hi = 0.0;
    int have = physical_percentiles(vol, 0.005, 1.0, &lo, &hi);
    if (!strcmp(vol->modality, "CT")) *why = "a CT";
    else if (have && pvp_is_hounsfield(NULL, lo, hi)) *why = "values like Hounsfield units: air at the 0.5th percentile";
    else {
        *why = vol->modality[0] ? vol->modality : "no Hounsfield units";
        return 0;
    }
    return 1;
}

/* The transfer function: --tf's preset or file, else one chosen from the file (a CT in
   HU: ct-bone; another scan: mr; a .vdb cloud: cloud; raw: ramp).  --g and --bounces
   apply on top.  0 after saying why not. */
static int choose_tf(render_options *o, const picvr_io_volume *vol, pvp_tf *tf)
{
    const char *why = NULL;
    int hu = is_hounsfield(vol, &why);
    if (!o->have_tf) {
        o->tf_name = hu ? "ct-bone" : vol->patient_frame || vol->modality[0] ? "mr"
                   : picvr_io_is_vdb(o->volume_path) ? "cloud" : "ramp";
        if (!o->quiet && strcmp(o->tf_name, "ramp"))
            fprintf(stderr, PROGRAM ": --tf %s (%s)\n", o->tf_name, hu ? why : vol->patient_frame || vol->modality[0] ? "a scan" : "a cloud");
    }
    char err[512];
    pvp_status ps = pvp_tf_preset(o->tf_name, tf);
    if (ps == PVP_ERROR_UNKNOWN_NAME && (ps = pvp_tf_load(o->tf_name, tf, err, sizeof err)) != PVP_OK) {
        pvc_fail("--tf %s", err);
        return 0;
    }
    if (ps != PVP_OK) {
        pvc_fail("--tf %s: %s", o->tf_name, pvp_status_string(ps));
        return 0;
    }
    if (tf->needs_hu && !hu && !o->have_wl && !o->have_range && !o->range_auto) {
        pvc_fail("--tf %s is made for CT in Hounsfield units and %s has %s; give --wl WIDTH,LEVEL or "
                 "--range MIN,MAX, or another --tf", o->tf_name, o->volume_path, why);
        return 0;
    }
    if (!o->have_bounces) o->bounces = tf->max_bounces;
    for (uint32_t i = 0; o->have_g && i < tf->count; i++) tf->points[i].g = o->g;
    return 1;
}

/* picvr's value_min/max, stored values, from the physical window [lo, hi]: stored =
   (physical - offset) / scale.  0 for a scale that is 0, negative or not finite. */
static int window_to_stored(const picvr_io_volume *vol, double lo, double hi, picvr_volume_desc *desc)
{
    double s = vol->value_scale, a = (lo - vol->value_offset) / s, b = (hi - vol->value_offset) / s;
    if (!(s > 0.0) || !isfinite(a) || !isfinite(b) || !(a < b) || fabs(a) > 3e38 || fabs(b) > 3e38) return 0;
    desc->value_min = (float)a;
    desc->value_max = (float)b;
    return 1;
}

/* The data values the transfer function spans: --range, --range auto, --wl, else the
   transfer function's own window (physical values, the data's percentiles, or the
   type's range). */
static int value_window(const render_options *o, const picvr_io_volume *vol, const pvp_tf *tf, picvr_volume_desc *desc)
{
    double lo, hi;
    const char *what = NULL;
    if (o->have_range) {
        desc->value_min = o->range[0];
        desc->value_max = o->range[1];
        return 1;
    }
    if (o->range_auto || tf->window_kind == PVP_WINDOW_PERCENTILE) {
        double f0 = o->range_auto ? 0.005 : tf->window[0], f1 = o->range_auto ? 0.995 : tf->window[1];
        if (picvr_io_percentile_range(vol, f0, f1, &lo, &hi) != PICVR_IO_OK) {
            pvc_fail("%s: the volume has no finite value", o->range_auto ? "--range auto" : o->tf_name);
            return 0;
        }
        desc->value_min = (float)lo;
        desc->value_max = (float)hi;
        if (!o->quiet) fprintf(stderr, PROGRAM ": value range %g,%g (the data's %g and %g quantiles)\n", lo, hi, f0, f1);
        return 1;
    }
    if (o->have_wl) {
        lo = (double)o->wl[1] - 0.5 * o->wl[0];
        hi = (double)o->wl[1] + 0.5 * o->wl[0];
        what = "--wl";
    } else if (tf->window_kind == PVP_WINDOW_VALUE) {
        lo = tf->window[0];
        hi = tf->window[1];
        what = o->tf_name;
    } else {
        return 1;   /* the type's range (picvr's default) */
    }
    if (!window_to_stored(vol, lo, hi, desc)) {
        pvc_fail("%s: the window %g..%g cannot be mapped through the file's rescale (slope %g)", what, lo, hi, vol->value_scale);
        return 0;
    }
    return 1;
}

static int upload_volume(picvr_context *ctx, const render_options *o, const picvr_io_volume *vol, const pvp_tf *tf)
{
    picvr_volume_desc desc;
    double shear = 0.0;
    picvr_io_to_desc_sheared(vol, &desc, &shear);
    if (shear > 0.0 && !o->quiet)
        fprintf(stderr, PROGRAM ": %s: slices sheared by %.2f degrees (gantry tilt): rendered without tilt correction\n",
                o->volume_path, shear);
    if (!value_window(o, vol, tf, &desc)) return 0;
    return pvc_check(picvr_upload_volume(ctx, &desc), "picvr_upload_volume");
}

/* The camera's frame: --view (the patient's), else --up with a front across it, else a
   scan's anterior view, else +z front and +y up. */
static void view_frame(const render_options *o, const picvr_io_volume *vol, float front[3], float up[3])
{
    static const float y_up[3] = {0, 1, 0}, z_front[3] = {0, 0, 1}, minus_y[3] = {0, -1, 0};
    if (o->view && pvp_patient_view(o->view, front, up) == PVP_OK) return;
    if (o->have_up) {
        memcpy(up, o->up, sizeof o->up);
        memcpy(front, o->up[2] != 0.0f ? minus_y : z_front, sizeof z_front);   /* across up */
        return;
    }
    if (vol->patient_frame && pvp_patient_view("anterior", front, up) == PVP_OK) return;
    memcpy(front, z_front, sizeof z_front);
    memcpy(up, y_up, sizeof y_up);
}

/* Camera from the orbit parameters, then the presets built around the volume's box,
   the scattering, and env (if any) as the background. */
static int set_up_scene(picvr_context *ctx, const render_options *o, const env_map *env, const float front[3],
                        const float up[3], const pvp_tf *tf)
{
    float box_min[3], box_max[3];
    if (!pvc_check(picvr_volume_box(ctx, box_min, box_max), "picvr_volume_box")) return 0;

    picvr_camera cam;
    pvp_status ps = pvp_orbit_camera_frame(box_min, box_max, front, up, o->azimuth, o->elevation,
                                           o->distance, o->fov, o->width, o->height, &cam);
    if (ps != PVP_OK) {
        pvc_fail("camera: %s", pvp_status_string(ps));
        return 0;
    }
    if (!pvc_check(picvr_set_camera(ctx, &cam), "picvr_set_camera")) return 0;
    if (o->debug_view && !strcmp(o->debug_view, "cache") &&
        !pvc_check(picvr_set_view(ctx, PICVR_VIEW_CACHE), "picvr_set_view")) return 0;
    if (o->debug_view && !strcmp(o->debug_view, "error") &&
        !pvc_check(picvr_set_view(ctx, PICVR_VIEW_CACHE_ERROR), "picvr_set_view")) return 0;

    float density = o->have_density ? o->density : tf->density;
    if (!pvc_check(picvr_set_transfer_function(ctx, tf->points, tf->count, density),
               "picvr_set_transfer_function"))
        return 0;
    if ((o->clip.plane_count || o->clip.use_box) && !pvc_check(picvr_set_clip(ctx, &o->clip), "picvr_set_clip"))
        return 0;
    picvr_scattering scattering = {o->bounces, o->phase_back[0], o->phase_back[1]};
    if (!pvc_check(picvr_set_scattering(ctx, &scattering), "picvr_set_scattering")) return 0;

    pvp_lights lights;
    if ((ps = pvp_lights_preset(o->lights_name, box_min, box_max, &cam,
                                &lights)) != PVP_OK) {
        pvc_fail("--lights %s: %s", o->lights_name, pvp_status_string(ps));
        return 0;
    }
    if (env->rgb) {
        picvr_background *b = &lights.background;
        b->color[0] = b->color[1] = b->color[2] = 1.0f;
        b->intensity = o->env_intensity;
        b->environment = env->rgb;
        b->env_width = env->width;
        b->env_height = env->height;
        b->env_rotation = o->env_rotate * 3.14159265358979f / 180.0f;
    }
    return pvc_check(picvr_set_lights(ctx, lights.lights, lights.count, &lights.background),
                 "picvr_set_lights");
}

/* ---- main ------------------------------------------------------------------------------- */

/* The library's configuration from the options; zero fields are its defaults. */
static void library_config(const render_options *o, progress *prog, picvr_config *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->device_name = o->device;
    cfg->validation = o->validation ? PICVR_SWITCH_ON : PICVR_SWITCH_DEFAULT;
    cfg->cache = o->params;                     /* --cache-param; the rest below */
    cfg->cache.mode = o->cache;
    cfg->scheduler.priorities = o->priorities;
    cfg->scheduler.frames = o->frames ? PICVR_SWITCH_ON : PICVR_SWITCH_DEFAULT;
    cfg->scheduler.temporal_reuse = o->reuse;
    cfg->distance_sampling = o->distance_sampling;
    cfg->transmittance = o->transmittance;
    cfg->field.mode = o->render_mode;
    cfg->field.grid_ratio = o->field_ratio;
    cfg->field.directions = o->field_directions;
    cfg->field.step_voxels = o->field_step;
    cfg->cache.curvature_limit = o->curvature;
    cfg->cache.medium_model = o->medium;
    cfg->cache.max_samples = o->max_samples;
    cfg->scheduler.create_min = o->shares[0];   /* 0 (not given): the defaults */
    cfg->scheduler.create_max = o->shares[1];
    cfg->scheduler.update_min = o->shares[2];
    cfg->scheduler.update_max = o->shares[3];
    cfg->seed = o->seed;
    cfg->log = log_message;
    cfg->log_user = prog;
}

/* --log: the CSV file with its header row; 0 after reporting a failure. */
static int open_log(const char *path, FILE **log)
{
    *log = fopen(path, "w");
    int ok = *log && fputs("round,elapsed_ms,iterations,est_error,est_rel_error,"
                           "samples_per_second,hit_rate,cache_entries,cache_refs,fraction_render,"
                           "fraction_create,fraction_update,target_create,target_update,"
                           "cache_entries_capped\n", *log) >= 0;
    if (!ok) pvc_fail("cannot write %s: %s", path, strerror(errno));
    return ok;
}

/* The images, the --debug-view error figure, the JSON and the summary line. */
static int write_outputs(picvr_context *ctx, const render_options *o, const picvr_stats *stats,
                         const render_frames *frames)
{
    int ok = (!o->out_png || render_write_png(ctx, o)) && (!o->out_pfm || render_write_pfm(ctx, o)) &&
             (!o->debug_view || strcmp(o->debug_view, "error") || render_print_cache_error(ctx, o)) &&
             (!o->json_path || render_write_json(ctx, o, stats, frames));
    if (ok) render_print_summary(o, stats, interrupted);
    return ok;
}

static int render(render_options *o, const picvr_io_layout *layout)
{
    progress prog = {0};
    prog.enabled = !o->quiet;
    prog.tty = isatty(STDERR_FILENO);
    picvr_config cfg;
    library_config(o, &prog, &cfg);
    render_state r;
    memset(&r, 0, sizeof r);
    render_frames frames = {NULL, 0};
    r.progress = &prog;
    r.turns.path = o->turns_path[0] ? o->turns_path : NULL;
    r.turns.id = o->turns_id;
    /* The outputs first: a typo in a path must not cost the whole render. */
    int ok = (!o->out_png || pvc_check_writable(o->out_png)) && (!o->out_pfm || pvc_check_writable(o->out_pfm)) &&
             (!o->json_path || pvc_check_writable(o->json_path));
    ok = ok && (!o->log_path || open_log(o->log_path, &r.log));
    /* The files first: a bad file should not cost a Vulkan start-up.  The host copies
       are freed right after the upload (picvr keeps its own). */
    picvr_io_volume vol;
    memset(&vol, 0, sizeof vol);
    env_map env = {NULL, 0, 0};
    ok = ok && (!o->env_path || load_env(o->env_path, &env));
    ok = ok && load_volume(o, layout, &vol);
    pvp_tf tf;
    float front[3], up[3];
    ok = ok && choose_tf(o, &vol, &tf);
    if (ok) view_frame(o, &vol, front, up);
    ok = ok && pvc_check(picvr_create(&cfg, &r.ctx), "picvr_create");
    ok = ok && upload_volume(r.ctx, o, &vol, &tf);
    picvr_io_free(&vol);
    ok = ok && set_up_scene(r.ctx, o, &env, front, up, &tf);
    pvenv_free(env.rgb);  /* picvr keeps its own copy */
    if (ok) {
        install_interrupt_handler();
        if (o->warm_ms > 0.0) ok = warm_up(&r, o, &cfg.scheduler);
        prog.start_ms = prog.next_line_ms = pvc_now_ms();
        ok = ok && (o->frames ? render_frames_loop(&r, o, &frames)
                    : o->iterations ? render_iterations(&r, o->iterations, o->round_ms)
                    : o->render_mode == PICVR_RENDER_FIELD ? render_iterations(&r, 1, o->round_ms)
                                    : render_for_time(&r, o->time_ms, o->round_ms));
        end_progress_line(&prog);
    }
    ok = ok && write_outputs(r.ctx, o, &r.stats, &frames);
    free(frames.items);
    if (r.log && fclose(r.log) != 0 && ok) {
        pvc_fail("cannot write %s: %s", o->log_path, strerror(errno));
        ok = 0;
    }
    picvr_destroy(r.ctx);
    if (!ok) return EXIT_FAILURE;
    return interrupted ? EXIT_INTERRUPTED : EXIT_SUCCESS;
}

int main(int argc, char **argv)
{
    pvc_set_program(PROGRAM);
    render_options o;
    int status = parse_options(argc, argv, &o);
    if (status >= 0) return status;
    picvr_io_layout layout;
    if (!resolve_layout(&o, &layout)) return EXIT_USAGE;
    return render(&o, layout_in_header(o.volume_path) ? NULL : &layout);
}
