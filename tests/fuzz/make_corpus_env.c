/* make_corpus_env.c - writes the seed corpus of tests/fuzz/fuzz_env_io.c.
 *
 *     cc -std=c11 -I/usr/include -o /tmp/make_corpus_env tests/fuzz/make_corpus_env.c -lstb -lm
 *     /tmp/make_corpus_env tests/fuzz/corpus_env
 *
 * The seeds (committed, so `make fuzz` does not run this) are small Radiance files
 * that reach every branch of the checks in cli/env_io.c and of stb_image's
 * decoder: valid flat and RLE maps (one written by stb_image_write, which uses RLE for
 * widths 8..32767), a map whose second scanline switches to flat texels, truncated and
 * corrupt ones, bad size lines, headers that end in a line "\0..." (the regression
 * seed nul_header_hang.hdr hung stb_image behind the first version of the checks) and
 * other formats.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_image_write.h>

static const char *dir;

static void put(const char *name, const void *data, size_t size)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(data, 1, size, f) != size || fclose(f)) {
        perror(path);
        exit(1);
    }
}

/* A buffer being filled: header text, then bytes. */
static unsigned char buf[65536];
static size_t len;
static void text(const char *s) { memcpy(buf + len, s, strlen(s)); len += strlen(s); }
static void bytes(const unsigned char *b, size_t n) { memcpy(buf + len, b, n); len += n; }
static void rep(const unsigned char *b, size_t n, int times) { while (times--) bytes(b, n); }

#define HEAD "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s DIR\n", argv[0]);
        return 2;
    }
    dir = argv[1];
    static const unsigned char one[4] = {128, 128, 128, 129};          /* 1.0 flat */
    static const unsigned char rle_row[12] = {2, 2, 0, 8, 136, 128, 136, 128, 136, 128, 136, 129};

    /* valid: 4x2 flat (width < 8 is never RLE), the same with the #?RGBE magic */
    len = 0; text(HEAD "-Y 2 +X 4\n"); rep(one, 4, 8); put("flat_4x2.hdr", buf, len);
    size_t flat_len = len;
    len = 0; text("#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n"); rep(one, 4, 8);
    put("rgbe_magic.hdr", buf, len);
    /* valid: 8x2 RLE, one run of 8 per component and row */
    len = 0; text(HEAD "-Y 2 +X 8\n"); rep(rle_row, 12, 2); put("rle_runs_8x2.hdr", buf, len);
    size_t rle_len = len;
    /* valid: 16x2 written by stb_image_write (RLE runs and literals) */
    float px[16 * 2 * 3];
    for (int i = 0; i < 16 * 2; i++)
        for (int c = 0; c < 3; c++) px[i * 3 + c] = i < 6 ? 0.5f : (float)(i * (c + 1)) / 7.0f;
    char path[512];
    snprintf(path, sizeof path, "%s/stbi_write_16x2.hdr", dir);
    if (!stbi_write_hdr(path, 16, 2, 3, px)) return 1;
    /* valid: scanline 0 RLE, then flat texels: stb_image restarts at texel 0 and reads
       all 8x2 texels flat from there */
    len = 0; text(HEAD "-Y 2 +X 8\n"); bytes(rle_row, 12); rep(one, 4, 16);
    put("rle_then_flat.hdr", buf, len);
    /* a long header line (stb_image cuts tokens at 1023 characters) */
    len = 0; text("#?RADIANCE\n# ");
    for (int i = 0; i < 1100; i++) text("x");
    text("\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 4\n"); rep(one, 4, 4);
    put("long_header_line.hdr", buf, len);

    /* truncated and corrupt pixel data */
    len = 0; text(HEAD "-Y 2 +X 8\n"); rep(rle_row, 12, 2);
    put("truncated_rle.hdr", buf, rle_len - 3);
    put("truncated_row.hdr", buf, rle_len - 12);
    len = 0; text(HEAD "-Y 2 +X 4\n"); rep(one, 4, 8);
    put("truncated_flat.hdr", buf, flat_len - 1);
    put("header_only.hdr", buf, 21);
    static const unsigned char zero_count[6] = {2, 2, 0, 8, 0, 128};
    len = 0; text(HEAD "-Y 2 +X 8\n"); rep(zero_count, 6, 2); put("zero_count.hdr", buf, len);
    static const unsigned char long_run[6] = {2, 2, 0, 8, 137, 128};   /* 9 > width */
    len = 0; text(HEAD "-Y 1 +X 8\n"); bytes(long_run, 6); put("run_too_long.hdr", buf, len);
    static const unsigned char bad_len[4] = {2, 2, 0, 9};
    len = 0; text(HEAD "-Y 1 +X 8\n"); bytes(bad_len, 4); rep(one, 4, 8);
    put("scanline_length.hdr", buf, len);

    /* size lines */
    len = 0; text(HEAD "+Y 2 +X 4\n"); rep(one, 4, 8); put("bottom_up.hdr", buf, len);
    len = 0; text(HEAD "-Y 2 -X 4\n"); rep(one, 4, 8); put("wrong_size_line.hdr", buf, len);
    len = 0; text(HEAD "-Y 0 +X 4\n"); put("zero_height.hdr", buf, len);
    len = 0; text(HEAD "-Y 1 +X 16385\n"); rep(one, 4, 8); put("too_wide.hdr", buf, len);
    /* sscanf and strtol read this differently (1 and 0 rows) */
    len = 0; text(HEAD "-Y -18446744073709551615 +X 4\n"); rep(one, 4, 4);
    put("size_overflow.hdr", buf, len);
    /* sscanf wraps it to 4, strtol does not: refused as ambiguous */
    len = 0; text(HEAD "-Y 1 +X 4294967300\n"); rep(one, 4, 4); put("size_wrap.hdr", buf, len);
    /* a header line "\0..." ends the header for stb_image, as a blank one does: a valid
       map, and a crafted one whose bytes after a later blank line form a valid map of
       their own, while for stb_image they are the literals of an RLE scanline that runs
       into the end of the file (where it read zero counts for ever: a hang) */
    len = 0; text("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n");
    bytes((const unsigned char *)"\0 nul\n", 6); text("-Y 1 +X 4\n"); rep(one, 4, 4);
    put("nul_header_end.hdr", buf, len);
    len = 0; text("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n");
    bytes((const unsigned char *)"\0\n", 2); text("-Y 1 +X 200\n");
    bytes((const unsigned char[5]){2, 2, 0, 200, 28}, 5); text("\n\n-Y 1 +X 4\n");
    rep(one, 4, 4);
    put("nul_header_hang.hdr", buf, len);
    /* no FORMAT line: stb_image refuses it */
    len = 0; text("#?RADIANCE\n\n-Y 1 +X 4\n"); rep(one, 4, 4); put("no_format.hdr", buf, len);

    /* other contents */
    len = 0; text(HEAD "-Y 1 +X 4\n"); rep((const unsigned char[4]){0, 0, 0, 0}, 4, 4);
    put("black.hdr", buf, len);
    put("empty.hdr", "", 0);
    put("text.hdr", "not an image\n", 13);
    put("map.exr", "v/1\001\002\000\000\000", 8);
    put("png.hdr", "\211PNG\r\n\032\n0000", 12);
    return 0;
}
