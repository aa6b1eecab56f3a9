/* env_io.c - see env_io.h.  The checks before stb_image follow its Radiance decoder
 * (stbi__hdr_load) step by step: where it would read past the end of the data or spin
 * on a zero count, the file is refused here first. */
#include "env_io.h"

#include <errno.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb/stb_image.h>

#if defined(__GNUC__)
#define PVENV_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define PVENV_PRINTF(f, a)
#endif

/* Files are read whole; stb_image takes the size as an int. */
#define FIRST_READ_BYTES ((size_t)1 << 16)
#define MAX_READ_BYTES ((size_t)1 << 31)

static PVENV_PRINTF(3, 4) void set_error(char *err, size_t err_size, const char *fmt, ...)
{
    if (!err || err_size == 0) return;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err, err_size, fmt, ap);
    va_end(ap);
}

const char *pvenv_status_string(pvenv_status status)
{
    static const char *const NAMES[PVENV_STATUS_COUNT] = {
        "PVENV_OK",           "PVENV_ERROR_NULL_POINTER", "PVENV_ERROR_READ",
        "PVENV_ERROR_EMPTY",  "PVENV_ERROR_NOT_HDR",      "PVENV_ERROR_NO_SIZE_LINE",
        "PVENV_ERROR_BAD_SIZE", "PVENV_ERROR_CORRUPT",    "PVENV_ERROR_DECODE",
        "PVENV_ERROR_BLACK",
    };
    return (unsigned)status < PVENV_STATUS_COUNT ? NAMES[status] : "PVENV_ERROR_UNKNOWN";
}

void pvenv_free(float *rgb)
{
    stbi_image_free(rgb);
}

/* Whether the pixel data at p (n bytes) holds all width x height pixels as stb_image
   reads them: new-style RLE scanlines (2, 2, width; per component, runs of count - 128
   copies of one byte or counts 1..128 of literal bytes), else flat RGBE from there on.
   stb_image trusts its input here: past the end it reads zeros, and a zero count never
   advances its RLE loop (a truncated or corrupt file would hang it).  A scanline that
   does not start 2, 2 makes stb_image restart at texel (0, 0) and read the whole image
   flat from that scanline on, hence width * height texels from there. */
static int hdr_pixels_complete(const unsigned char *p, size_t n, uint32_t width, uint32_t height)
{
    size_t i = 0;
    if (width < 8 || width >= 32768) return n >= (size_t)width * height * 4;
    for (uint32_t y = 0; y < height; y++) {
        if (n - i < 4) return 0;
        if (p[i] != 2 || p[i + 1] != 2 || (p[i + 2] & 0x80)) /* flat from here to the end */
            return n - i >= (size_t)width * height * 4;
        if (((uint32_t)p[i + 2] << 8 | p[i + 3]) != width) return 0;
        i += 4;
        for (int k = 0; k < 4; k++)
            for (uint32_t x = 0; x < width;) {
                if (i >= n) return 0;
                uint32_t count = p[i++], run = count > 128;
                if (run) count -= 128;
                if (count == 0 || count > width - x || n - i < (run ? 1 : count)) return 0;
                i += run ? 1 : count;
                x += count;
            }
    }
    return 1;
}

/* Where the size line starts (0: nowhere): after the line that ends the header, which
   is the first line past the magic one that is empty or starts with a NUL byte.  That
   is how stb_image reads it: line by line as C strings, up to the first empty one (a
   line "\0..." ends the header too: taking only a blank line for its end would let
   stb_image decode other bytes than those checked, and hang on a crafted file). */
static size_t size_line_start(const unsigned char *data, size_t size)
{
    const unsigned char *nl = size ? memchr(data, '\n', size) : NULL; /* the magic line */
    while (nl) {
        size_t i = (size_t)(nl - data) + 1; /* the next line */
        if (i >= size) return 0;
        nl = memchr(data + i, '\n', size - i);
        if (nl && (data[i] == '\n' || data[i] == '\0')) return (size_t)(nl - data) + 1;
    }
    return 0;
}

/* Whether stb_image, which reads the size line with strtol rather than sscanf, either
   refuses it or reads height h and width w from it too: numbers that overflow an
   unsigned int (wrapped by sscanf, clamped by strtol) would make it decode the pixels
   for another size than the one checked. */
static int stb_reads_size(const char *size_line, unsigned h, unsigned w)
{
    char *end;
    if (strncmp(size_line, "-Y ", 3)) return 1;
    long y = strtol(size_line + 3, &end, 10);
    while (*end == ' ') end++;
    if (strncmp(end, "+X ", 3)) return 1;
    long x = strtol(end + 3, NULL, 10);
    return y == (long)h && x == (long)w;
}

/* Sets the outputs of a failed call and returns status. */
static pvenv_status fail(pvenv_status status, float **rgb, uint32_t *width, uint32_t *height)
{
    if (rgb) *rgb = NULL;
    if (width) *width = 0;
    if (height) *height = 0;
    return status;
}

pvenv_status pvenv_parse_hdr(const unsigned char *data, size_t size, float **rgb,
                             uint32_t *width, uint32_t *height, char *err, size_t err_size)
{
    static const unsigned char EXR_MAGIC[4] = {0x76, 0x2f, 0x31, 0x01};
    if (!rgb || !width || !height || (!data && size)) {
        set_error(err, err_size, "no data or no output given");
        return fail(PVENV_ERROR_NULL_POINTER, rgb, width, height);
    }
    fail(PVENV_OK, rgb, width, height);
    size_t start, line;
    pvenv_status status = PVENV_OK;
    const char *why = NULL;
    char size_line[64] = "";
    unsigned w = 0, h = 0;
    /* The pixels start after the line that ends the header and the size line. */
    line = start = size_line_start(data, size);
    while (start && start < size && data[start] != '\n') start++;
    if (start && start < size && start - line < sizeof size_line) {
        memcpy(size_line, data + line, start - line);
        size_line[start++ - line] = '\0';
    }
    if (size == 0)
        status = PVENV_ERROR_EMPTY, why = "the file is empty";
    else if (size >= 4 && !memcmp(data, EXR_MAGIC, 4))
        status = PVENV_ERROR_NOT_HDR, why = "OpenEXR is not supported: convert it to a Radiance .hdr";
    else if (!(size >= 11 && !memcmp(data, "#?RADIANCE\n", 11)) &&
             !(size >= 7 && !memcmp(data, "#?RGBE\n", 7)))
        status = PVENV_ERROR_NOT_HDR, why = "not a Radiance .hdr (RGBE) file";
    else if (sscanf(size_line, "-Y %u +X %u", &h, &w) != 2)
        status = PVENV_ERROR_NO_SIZE_LINE,
        why = "no size line \"-Y H +X W\" after the header (truncated, or rows not top to bottom)";
    else if (w < 1 || h < 1 || w > PVENV_MAX_SIZE || h > PVENV_MAX_SIZE)
        status = PVENV_ERROR_BAD_SIZE;
    else if (size > INT_MAX || !hdr_pixels_complete(data + start, size - start, w, h))
        status = PVENV_ERROR_CORRUPT, why = "the pixel data is truncated or corrupt";
    else if (!stb_reads_size(size_line, h, w))
        status = PVENV_ERROR_DECODE, why = "its size line is ambiguous";
    if (status == PVENV_ERROR_BAD_SIZE) {
        set_error(err, err_size, "its size is out of 1..%u texels a side", (unsigned)PVENV_MAX_SIZE);
        return status;
    }
    if (why) {
        set_error(err, err_size, "%s", why);
        return status;
    }
    int x = 0, y = 0, comp;
    float *texels = stbi_loadf_from_memory(data, (int)size, &x, &y, &comp, 3);
    if (!texels) {
        set_error(err, err_size, "stb_image cannot decode it: %s", stbi_failure_reason());
        return PVENV_ERROR_DECODE;
    }
    if ((unsigned)x != w || (unsigned)y != h) {
        stbi_image_free(texels);
        set_error(err, err_size, "its size line is ambiguous");
        return PVENV_ERROR_DECODE;
    }
    size_t n = (size_t)w * h * 3, i = 0;
    while (i < n && texels[i] == 0.0f) i++;
    if (i == n) {
        stbi_image_free(texels);
        set_error(err, err_size, "every texel is black");
        return PVENV_ERROR_BLACK;
    }
    *rgb = texels;
    *width = w;
    *height = h;
    return PVENV_OK;
}

/* The whole file (malloc'd) and its size; NULL after setting *why (errno's text, or
   "too large" from MAX_READ_BYTES on). */
static unsigned char *read_file(const char *path, size_t *size, const char **why)
{
    errno = 0;
    FILE *f = fopen(path, "rb");
    size_t cap = FIRST_READ_BYTES, n = 0;
    unsigned char *buf = f ? malloc(cap) : NULL, *grown;
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap || ferror(f)) break;
        grown = cap < MAX_READ_BYTES ? realloc(buf, cap *= 2) : NULL;
        if (!grown) free(buf);
        buf = grown;
    }
    if (f && buf && ferror(f)) {
        free(buf);
        buf = NULL;
    }
    if (!buf) *why = errno ? strerror(errno) : "too large";
    if (f) fclose(f);
    *size = n;
    return buf;
}

pvenv_status pvenv_load_hdr(const char *path, float **rgb, uint32_t *width,
                            uint32_t *height, char *err, size_t err_size)
{
    if (!path || !rgb || !width || !height) {
        set_error(err, err_size, "no file name or output given");
        return fail(PVENV_ERROR_NULL_POINTER, rgb, width, height);
    }
    fail(PVENV_OK, rgb, width, height);
    size_t size = 0;
    const char *why = NULL;
    unsigned char *data = read_file(path, &size, &why);
    if (!data) {
        set_error(err, err_size, "cannot read %s: %s", path, why);
        return PVENV_ERROR_READ;
    }
    char reason[256] = "";
    pvenv_status status = pvenv_parse_hdr(data, size, rgb, width, height, reason, sizeof reason);
    free(data);
    if (status != PVENV_OK) set_error(err, err_size, "%s: %s", path, reason);
    return status;
}
