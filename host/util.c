/* host/util.c - status names, logging, host allocation, the clock, small vector math.
 * Part of picvr_vk.c (included there, not compiled on its own); uses nothing of the
 * other parts. */

const char *picvr_status_string(picvr_status s) {
    static const char *names[PICVR_STATUS_COUNT] = {
        "PICVR_OK", "PICVR_ERROR_NULL_POINTER", "PICVR_ERROR_INVALID_ARGUMENT",
        "PICVR_ERROR_NON_FINITE", "PICVR_ERROR_INVALID_DIMENSIONS", "PICVR_ERROR_SIZE_OVERFLOW",
        "PICVR_ERROR_UNSUPPORTED_TYPE", "PICVR_ERROR_INVALID_TRANSFER_FUNCTION",
        "PICVR_ERROR_INVALID_LIGHT", "PICVR_ERROR_TOO_MANY_LIGHTS", "PICVR_ERROR_INVALID_CAMERA",
        "PICVR_ERROR_BUFFER_TOO_SMALL", "PICVR_ERROR_NOT_READY", "PICVR_ERROR_NO_DEVICE",
        "PICVR_ERROR_VULKAN", "PICVR_ERROR_OUT_OF_HOST_MEMORY", "PICVR_ERROR_OUT_OF_DEVICE_MEMORY",
        "PICVR_ERROR_DEVICE_LOST", "PICVR_ERROR_BUSY", "PICVR_ERROR_NO_STEP", "PICVR_ERROR_TIMEOUT"};
    if ((unsigned)s >= PICVR_STATUS_COUNT) return "PICVR_UNKNOWN_STATUS";
    return names[s];
}

/* Milliseconds of a monotonic clock where the platform declares one (POSIX's
   CLOCK_MONOTONIC: picvr_vk.c asks for it when compiled on its own), else of the wall
   clock (inside an application's file compiled as strict ISO C): budgets are wall time
   either way, and only differences are taken. */
/* The processors online; 0 where the system does not say. */
static long picvr_processors_online(void) {
#if defined(_SC_NPROCESSORS_ONLN)
    return sysconf(_SC_NPROCESSORS_ONLN);
#else
    return 0;
#endif
}

static double picvr_clock_ms(void) {
#if defined(CLOCK_MONOTONIC)
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
#elif defined(__unix__) || defined(__APPLE__)
    struct timeval tv;
    gettimeofday(&tv, NULL);
    return (double)tv.tv_sec * 1e3 + (double)tv.tv_usec * 1e-3;
#else
    struct timespec ts;
    timespec_get(&ts, TIME_UTC);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
#endif
}

static void picvr_log_message(picvr_context *ctx, picvr_log_level level, const char *fmt, ...) {
    if (level < ctx->config.log_level) return;
    char msg[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    if (ctx->config.log) ctx->config.log(level, msg, ctx->config.log_user);
    else fprintf(stderr, "picvr: %s\n", msg);
}

static void *picvr_host_alloc(const picvr_allocator *a, size_t n) {
    if (n == 0) n = 1;
    return a->alloc ? a->alloc(n, a->user) : malloc(n);
}

static void picvr_host_free(const picvr_allocator *a, void *p) {
    if (!p) return;
    if (a->free) a->free(p, a->user); else free(p);
}

static int picvr_finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static void picvr_cross3(const float a[3], const float b[3], float r[3]) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static double picvr_len3(const float a[3]) { return sqrt((double)a[0] * a[0] + (double)a[1] * a[1] + (double)a[2] * a[2]); }

static void picvr_normalize3(float v[3]) {
    double l = picvr_len3(v);
    for (int i = 0; i < 3; i++) v[i] = (float)(v[i] / l);
}

static void picvr_pack4(float d[4], const float s[3], float w) { d[0] = s[0]; d[1] = s[1]; d[2] = s[2]; d[3] = w; }

static double picvr_luminance(const float c[3]) { return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]; }

/* ---- the volume's placement: world = rot * local + shift (picvr_scene) ---- */

/* A world direction in the volume's frame: rot^T w (rot is orthonormal). */
static void picvr_dir_to_local(const picvr_scene *sc, const float w[3], float out[3]) {
    double r[3];
    for (int i = 0; i < 3; i++)
        r[i] = (double)sc->rot[i] * w[0] + (double)sc->rot[3 + i] * w[1] + (double)sc->rot[6 + i] * w[2];
    for (int i = 0; i < 3; i++) out[i] = (float)r[i];
}

/* A world point in the volume's frame: rot^T (w - shift). */
static void picvr_point_to_local(const picvr_scene *sc, const float w[3], float out[3]) {
    double d[3], r[3];
    for (int i = 0; i < 3; i++) d[i] = (double)w[i] - sc->shift[i];
    for (int i = 0; i < 3; i++) r[i] = sc->rot[i] * d[0] + sc->rot[3 + i] * d[1] + sc->rot[6 + i] * d[2];
    for (int i = 0; i < 3; i++) out[i] = (float)r[i];
}

/* The rule of every float in a config struct: zero means its default def[i], anything
   else must be finite (PICVR_ERROR_NON_FINITE) and >= 0 (PICVR_ERROR_INVALID_ARGUMENT). */
static picvr_status picvr_resolve_floats(float *const *f, const float *def, int n) {
    for (int i = 0; i < n; i++) {
        if (!isfinite(*f[i])) return PICVR_ERROR_NON_FINITE;
        if (*f[i] < 0.0f) return PICVR_ERROR_INVALID_ARGUMENT;
        if (*f[i] == 0.0f) *f[i] = def[i];
    }
    return PICVR_OK;
}
