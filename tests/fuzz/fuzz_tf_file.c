/* fuzz_tf_file.c - libFuzzer harness for the transfer-function file reader
 * (cli/presets.c, pvp_tf_load: picvr-render --tf FILE).
 *
 * The input is written as a file and read; every call must return a status without a
 * sanitizer report.  On success the table must be what picvr_set_transfer_function
 * takes: 2..PVP_MAX_TF_POINTS points, values in [0, 1] and non-decreasing, albedo in
 * [0, 1], opacity >= 0, g in (-1, 1), all finite; a VALUE window with lo < hi.  On
 * failure the table is zeroed and the message is a terminated string.
 */
#include "presets.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char path[256];

static void remove_file(void) { if (path[0]) unlink(path); }

static void check(int cond, const char *what) {
    if (!cond) {
        fprintf(stderr, "fuzz_tf_file: invariant violated: %s\n", what);
        abort();
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (!path[0]) {
        const char *t = getenv("TMPDIR");
        snprintf(path, sizeof path, "%s/pvp-tf-fuzz-%ld.tf", t && *t ? t : "/tmp", (long)getpid());
        atexit(remove_file);
    }
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    fclose(f);
    pvp_tf tf;
    char err[96];
    err[0] = 'x';
    pvp_status st = pvp_tf_load(path, &tf, err, sizeof err);
    if (st != PVP_OK) {
        check(st == PVP_ERROR_BAD_ARGUMENT, "a malformed file is BAD_ARGUMENT");
        check(memchr(err, '\0', sizeof err) != NULL, "the message is terminated");
        static const pvp_tf zero;
        check(memcmp(&tf, &zero, sizeof tf) == 0, "a refused table is zeroed");
        return 0;
    }
    check(tf.count >= 2 && tf.count <= PVP_MAX_TF_POINTS, "point count");
    for (uint32_t i = 0; i < tf.count; i++) {
        const picvr_tf_point *p = &tf.points[i];
        check(p->value >= 0.0f && p->value <= 1.0f, "value in [0, 1]");
        check(i == 0 || p->value >= tf.points[i - 1].value, "values non-decreasing");
        for (int c = 0; c < 3; c++) check(p->albedo[c] >= 0.0f && p->albedo[c] <= 1.0f, "albedo in [0, 1]");
        check(p->opacity >= 0.0f && isfinite(p->opacity), "opacity finite, >= 0");
        check(p->g > -1.0f && p->g < 1.0f, "g in (-1, 1)");
    }
    check(tf.density >= 0.0f && isfinite(tf.density), "density finite, >= 0");
    if (tf.window_kind == PVP_WINDOW_VALUE) check(tf.window[0] < tf.window[1], "value window lo < hi");
    return 0;
}
