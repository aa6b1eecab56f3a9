/* fuzz_env_io.c - libFuzzer harness for the Radiance .hdr loader in cli/env_io.c.
 *
 * Built by `make fuzz` with clang -fsanitize=fuzzer,address,undefined.  One input is
 * the whole contents of a .hdr file (the seeds in tests/fuzz/corpus_env are real files;
 * tests/fuzz/make_corpus_env.c writes them).  Each input is
 *
 *   1. parsed from memory by pvenv_parse_hdr, from libFuzzer's own buffer (exactly the
 *      input's size, so ASan sees any read past the end);
 *   2. written to a file and loaded by pvenv_load_hdr, with a full, a 5-byte or no
 *      error buffer (by the input's size modulo 3); both calls must agree: the same
 *      status, and on success the same size and bit-identical texels.
 *
 * stb_image's decoder is compiled into this harness (STB_IMAGE_IMPLEMENTATION below)
 * rather than taken from libstb, so it runs instrumented too: a file the checks in
 * env_io.c pass must not make it read out of bounds, use uninitialised texels or hang
 * (-timeout turns a hang into a failure).  Every call must return a status without a
 * sanitizer report; on failure the outputs are zeroed and the message is a terminated,
 * non-empty string; on success the size is within 1..PVENV_MAX_SIZE a side and all
 * width x height x 3 values are finite and >= 0, not all 0.  Files go to a private
 * directory under $TMPDIR.
 */
#include "env_io.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

static char dir[256];
static char path[300];

static void remove_dir(void)
{
    if (path[0]) unlink(path);
    if (dir[0]) rmdir(dir);
}

static void make_dir(void)
{
    if (dir[0]) return;
    const char *t = getenv("TMPDIR");
    snprintf(dir, sizeof dir, "%s/pvenv-fuzz-XXXXXX", t && *t ? t : "/tmp");
    if (!mkdtemp(dir)) abort();
    snprintf(path, sizeof path, "%s/map.hdr", dir);
    atexit(remove_dir);
}

static void check(int cond, const char *what)
{
    if (!cond) {
        fprintf(stderr, "fuzz_env_io: invariant violated: %s\n", what);
        abort();
    }
}

/* The outputs of one call: consistent with its status. */
static void check_result(pvenv_status st, const float *rgb, uint32_t w, uint32_t h,
                         const char *err, size_t err_size)
{
    check((unsigned)st < PVENV_STATUS_COUNT, "status in range");
    check(pvenv_status_string(st) != NULL, "status string");
    if (st != PVENV_OK) {
        check(rgb == NULL && w == 0 && h == 0, "a failed call zeroes its outputs");
        if (err && err_size > 0)
            check(memchr(err, 0, err_size) != NULL && (err_size == 1 || err[0] != 0),
                  "error message terminated and not empty");
        return;
    }
    check(rgb != NULL, "texels returned");
    check(w >= 1 && h >= 1 && w <= PVENV_MAX_SIZE && h <= PVENV_MAX_SIZE, "size within limits");
    size_t n = (size_t)w * h * 3, positive = 0;
    for (size_t i = 0; i < n; i++) {
        check(isfinite(rgb[i]) && rgb[i] >= 0.0f, "texels finite and >= 0");
        positive += rgb[i] > 0.0f;
    }
    check(positive > 0, "not every texel black");
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    make_dir();
    float *rgb = (float *)&rgb;  /* poisoned: the calls must set it */
    uint32_t w = 7, h = 7;
    char err[256];
    memset(err, 'x', sizeof err);
    pvenv_status st = pvenv_parse_hdr(data, size, &rgb, &w, &h, err, sizeof err);
    check_result(st, rgb, w, h, err, sizeof err);

    FILE *f = fopen(path, "wb");
    if (!f) abort();
    int written = fwrite(data, 1, size, f) == size;
    written &= fclose(f) == 0;
    if (!written) abort();
    float *rgb2 = (float *)&rgb2;
    uint32_t w2 = 7, h2 = 7;
    char err2[256];
    memset(err2, 'x', sizeof err2);
    size_t err2_size = size % 3 == 0 ? sizeof err2 : size % 3 == 1 ? 5 : 0;
    pvenv_status st2 = pvenv_load_hdr(path, &rgb2, &w2, &h2, err2_size ? err2 : NULL, err2_size);
    check_result(st2, rgb2, w2, h2, err2_size ? err2 : NULL, err2_size);
    check(st2 == st, "file and memory agree on the status");
    if (st == PVENV_OK) {
        check(w2 == w && h2 == h, "file and memory agree on the size");
        check(memcmp(rgb, rgb2, (size_t)w * h * 3 * sizeof *rgb) == 0,
              "file and memory agree on the texels");
    } else if (err2_size == sizeof err2) {
        /* "PATH: REASON" (REASON as from memory) */
        size_t pl = strlen(path);
        check(strncmp(err2, path, pl) == 0 && err2[pl] == ':' && strcmp(err2 + pl + 2, err) == 0,
              "the file's message is PATH: the memory's message");
    }
    pvenv_free(rgb);
    pvenv_free(rgb2);

    /* The argument checks. */
    check(pvenv_parse_hdr(NULL, 0, &rgb, &w, &h, NULL, 0) == PVENV_ERROR_EMPTY && rgb == NULL,
          "NULL data of size 0 is empty");
    check(pvenv_parse_hdr(size ? data : NULL, size, NULL, &w, &h, err, sizeof err) ==
              PVENV_ERROR_NULL_POINTER, "NULL output refused");
    return 0;
}
