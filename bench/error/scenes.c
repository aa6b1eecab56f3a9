/* scenes.c - picvr-bench-error's scenes: the conditions it compares, the scene file
 * (bench/scenes.txt: datasets, light set-ups, camera), a scene's identity (its name
 * and the key of its reference folder), a fresh context set up for a scene and a
 * condition, and the plain renderer's fingerprint that keys the references.
 */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_error.h"
#include "cli.h"
#include "picvr.h"
#include "presets.h"
#include "picvr_io.h"

static uint64_t fnv1a_bytes(const void *data, size_t size)
{
    const unsigned char *p = data;
    uint64_t h = 1469598103934665603ull;
    for (size_t i = 0; i < size; i++) h = (h ^ p[i]) * 1099511628211ull;
    return h;
}

static uint64_t fnv1a(const char *s) { return fnv1a_bytes(s, strlen(s)); }

/* ---- conditions ------------------------------------------------------------------------- */

/* plain is the paper's MCVR baseline: no cache, no priorities. */
const condition CONDITIONS[N_CONDITIONS] = {
    {"plain", PICVR_CACHE_NONE, PICVR_SWITCH_OFF},
    {"object", PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_ON},
    {"object-noprio", PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_OFF},
    {"screen", PICVR_CACHE_SCREEN_SPACE, PICVR_SWITCH_ON},
    {"screen-noprio", PICVR_CACHE_SCREEN_SPACE, PICVR_SWITCH_OFF},
    {"plain-prio", PICVR_CACHE_NONE, PICVR_SWITCH_ON},
    {"auto", PICVR_CACHE_AUTO, PICVR_SWITCH_ON},
    /* the multiply scattered cache looked up at a path's second scatter event */
    {"object-k2", PICVR_CACHE_OBJECT_SPACE, PICVR_SWITCH_ON, 2},
};

const condition *find_condition(const char *name)
{
    for (int i = 0; i < N_CONDITIONS; i++)
        if (!strcmp(CONDITIONS[i].name, name)) return &CONDITIONS[i];
    return NULL;
}

/* ---- scene file ---------------------------------------------------------------------------- */

static int parse_scene_line(char *line, scene_file *sf, int lineno)
{
    char *tok = strtok(line, " \t\r\n");
    if (!tok || tok[0] == '#') return 1;
    if (!strcmp(tok, "dataset")) {
        if (sf->n_datasets >= MAX_DATASETS) return 0;
        dataset_spec *d = &sf->datasets[sf->n_datasets];
        char *name = strtok(NULL, " \t\r\n"), *file = strtok(NULL, " \t\r\n");
        char *tf = strtok(NULL, " \t\r\n"), *sp = strtok(NULL, " \t\r\n");
        if (!name || !file || !tf || !sp || !(atof(sp) > 0)) {
            pvc_fail("scene file line %d: dataset NAME FILE TF SPACING", lineno);
            return 0;
        }
        snprintf(d->name, sizeof d->name, "%s", name);
        snprintf(d->file, sizeof d->file, "%s", file);
        snprintf(d->tf, sizeof d->tf, "%s", tf);
        d->spacing = (float)atof(sp);
        sf->n_datasets++;
    } else if (!strcmp(tok, "lights")) {
        for (char *l; (l = strtok(NULL, " \t\r\n")) && sf->n_lights < MAX_LIGHTS;)
            snprintf(sf->lights[sf->n_lights++], NAME_LEN, "%s", l);
    } else if (!strcmp(tok, "camera")) {
        for (int i = 0; i < 4; i++) {
            char *v = strtok(NULL, " \t\r\n");
            if (!v) { pvc_fail("scene file line %d: camera AZ EL DIST FOV", lineno); return 0; }
            sf->camera[i] = (float)atof(v);
        }
    } else {
        pvc_fail("scene file line %d: unknown keyword %s", lineno, tok);
        return 0;
    }
    return 1;
}

int read_scene_file(const char *path, scene_file *sf)
{
    memset(sf, 0, sizeof *sf);
    sf->camera[0] = PVP_DEFAULT_AZIMUTH;
    sf->camera[1] = PVP_DEFAULT_ELEVATION;
    sf->camera[2] = PVP_DEFAULT_DISTANCE;
    sf->camera[3] = PVP_DEFAULT_FOV;
    FILE *f = fopen(path, "r");
    if (!f) { pvc_fail("cannot read %s: %s", path, strerror(errno)); return 0; }
    char line[2048];
    int ok = 1;
    for (int n = 1; ok && fgets(line, sizeof line, f); n++) ok = parse_scene_line(line, sf, n);
    fclose(f);
    return ok;
}

/* ---- scenes -------------------------------------------------------------------------------- */

void scene_init(scene *s, const dataset_spec *ds, const char *lights,
                       const options *o, const float camera[4])
{
    memset(s, 0, sizeof *s);
    s->ds = ds;
    s->lights = lights;
    s->width = o->width;
    s->height = o->height;
    memcpy(s->camera, camera, sizeof s->camera);
    snprintf(s->id, sizeof s->id, "%s_%s_%ux%u", ds->name, lights, s->width, s->height);
}

/* Whether a scene's transfer function names a file (".tf", pvp_tf_load) rather than a
   preset. */
static int tf_is_file(const char *tf)
{
    size_t n = strlen(tf);
    return n > 3 && !strcmp(tf + n - 3, ".tf");
}

/* The hash of a transfer-function file's bytes (0 when it cannot be read), so that a
   reference follows the file's content, not only its name. */
static uint64_t tf_file_hash(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    char buf[8192];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    return fnv1a_bytes(buf, n);
}

/* The key of the scene's reference folder: the scene description and the plain
   renderer's fingerprint (with a transfer-function file, its content's hash too). */
void scene_key(scene *s, uint64_t fingerprint)
{
    char tf[NAME_LEN + 24];
    if (tf_is_file(s->ds->tf))
        snprintf(tf, sizeof tf, "%s#%016llx", s->ds->tf, (unsigned long long)tf_file_hash(s->ds->tf));
    else
        snprintf(tf, sizeof tf, "%s", s->ds->tf);
    snprintf(s->key, sizeof s->key,
             "picvr-bench-ref v3|plain=%016llx|%s|tf=%s|spacing=%g|lights=%s|%ux%u|"
             "camera=%g,%g,%g,%g", (unsigned long long)fingerprint, s->ds->file, tf,
             s->ds->spacing, s->lights, s->width, s->height, s->camera[0], s->camera[1],
             s->camera[2], s->camera[3]);
    snprintf(s->hash, sizeof s->hash, "%016llx", (unsigned long long)fnv1a(s->key));
}

int lights_have_background(const char *lights)
{
    size_t n = strlen(lights);
    return n > 3 && !strcmp(lights + n - 3, "-bg");
}

/* The light set-up's name without "-bg". */
void lights_base(const char *lights, char *out, size_t size)
{
    snprintf(out, size, "%s", lights);
    if (lights_have_background(lights)) out[strlen(out) - 3] = 0;
}

/* ---- contexts --------------------------------------------------------------------------- */

static void log_message(picvr_log_level level, const char *message, void *user)
{
    (void)user;
    if (level >= PICVR_LOG_WARNING) fprintf(stderr, "\npicvr: %s\n", message);
}

int orbit(const scene *s, const session *ss, float azimuth, picvr_camera *cam)
{
    pvp_status ps = pvp_orbit_camera(ss->box_min, ss->box_max, azimuth, s->camera[1],
                                     s->camera[2], s->camera[3], s->width, s->height, cam);
    if (ps != PVP_OK) pvc_fail("camera: %s", pvp_status_string(ps));
    return ps == PVP_OK;
}

static int set_look(const scene *s, session *ss)
{
    pvp_tf tf;
    pvp_lights lights;
    char err[256] = "";
    pvp_status ps = tf_is_file(s->ds->tf) ? pvp_tf_load(s->ds->tf, &tf, err, sizeof err)
                                          : pvp_tf_preset(s->ds->tf, &tf);
    if (ps != PVP_OK) { pvc_fail("tf %s: %s %s", s->ds->tf, pvp_status_string(ps), err); return 0; }
    ps = pvp_lights_preset(s->lights, ss->box_min, ss->box_max, &ss->camera, &lights);
    if (ps != PVP_OK) { pvc_fail("lights %s: %s", s->lights, pvp_status_string(ps)); return 0; }
    /* the scattering the preset is made for (cloud: unlimited bounces) */
    picvr_scattering scattering = {tf.max_bounces, 0.0f, 0.0f};
    return pvc_check(picvr_set_transfer_function(ss->ctx, tf.points, tf.count, tf.density),
                 "picvr_set_transfer_function") &&
           pvc_check(picvr_set_scattering(ss->ctx, &scattering), "picvr_set_scattering") &&
           pvc_check(picvr_set_lights(ss->ctx, lights.lights, lights.count, &lights.background),
                 "picvr_set_lights");
}

/* A fresh context (empty cache) with the scene set up for condition c and a seed.
   create_share > 0: the creation procedure's share of the time, at every hit rate
   (t_c,min = t_c,max; the warm-up of --bias-warm); 0: the defaults of Table 1.
   cache: the cache's options (options.cache; NULL: the library's defaults); its mode
   is the condition's. */
int session_open(const scene *s, const picvr_io_volume *vol, const condition *c,
                        uint32_t seed, float create_share, const picvr_cache_config *cache,
                        session *ss)
{
    memset(ss, 0, sizeof *ss);
    picvr_config cfg = {0};
    cfg.seed = seed;
    cfg.log = log_message;
    if (cache) cfg.cache = *cache;
    cfg.cache.mode = c->mode;
    if (c->lookup_event) cfg.cache.lookup_event = c->lookup_event;
    cfg.scheduler.priorities = c->priorities;
    cfg.scheduler.create_min = cfg.scheduler.create_max = create_share;
    if (!pvc_check(picvr_create(&cfg, &ss->ctx), "picvr_create")) return 0;
    picvr_volume_desc desc;
    picvr_io_to_desc(vol, &desc);
    int ok = pvc_check(picvr_upload_volume(ss->ctx, &desc), "picvr_upload_volume") &&
             pvc_check(picvr_volume_box(ss->ctx, ss->box_min, ss->box_max), "picvr_volume_box") &&
             orbit(s, ss, s->camera[0], &ss->camera) &&
             pvc_check(picvr_set_camera(ss->ctx, &ss->camera), "picvr_set_camera") &&
             set_look(s, ss);
    if (!ok) { picvr_destroy(ss->ctx); ss->ctx = NULL; }
    return ok;
}

void session_close(session *ss)
{
    picvr_destroy(ss->ctx);
    ss->ctx = NULL;
}

/* Reads the linear image and reduces it to luminance (rows top to bottom). */
int read_luminance(picvr_context *ctx, uint32_t w, uint32_t h, float *rgba, float *lum)
{
    size_t n = (size_t)w * h;
    if (!pvc_check(picvr_read_rgba32f(ctx, rgba, n * 16), "picvr_read_rgba32f")) return 0;
    for (size_t i = 0; i < n; i++) lum[i] = (float)luminance(rgba + 4 * i);
    return 1;
}

/* The plain renderer's fingerprint for scene s: FNV-1a of the linear image of a short
   deterministic render (FINGERPRINT_ITERATIONS whole passes with picvr_step_iterations,
   seed FINGERPRINT_SEED; no time budget, so bit for bit the same on one machine and
   driver).  It keys the references, so that a change of the library that leaves the
   plain image bit-identical (a refactor) keeps them, while any change of that image, by
   the kernel or by the host side, makes new ones; another device or driver gets its own
   references.  Costs a few iterations per scene. */
int plain_fingerprint(const scene *s, const picvr_io_volume *vol, uint64_t *out)
{
    session ss;
    if (!session_open(s, vol, find_condition("plain"), FINGERPRINT_SEED, 0.0f, NULL, &ss)) return 0;
    size_t n = (size_t)s->width * s->height;
    float *rgba = malloc(n * 16);
    int ok = rgba != NULL &&
             pvc_check(picvr_step_iterations(ss.ctx, FINGERPRINT_ITERATIONS), "picvr_step_iterations") &&
             pvc_check(picvr_read_rgba32f(ss.ctx, rgba, n * 16), "picvr_read_rgba32f");
    if (!rgba) pvc_fail("out of memory");
    if (ok) *out = fnv1a_bytes(rgba, n * 16);
    free(rgba);
    session_close(&ss);
    return ok;
}
