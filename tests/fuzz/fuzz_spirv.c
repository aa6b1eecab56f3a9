/* fuzz_spirv.c - libFuzzer harness for the kernel pruning (host/spirv.c,
 * picvr_spirv_prune), which parses SPIR-V before a pipeline variant is made.
 *
 * Input: 8 bytes that choose the specialization constants' values (constant i gets
 * bit i of the first word for the booleans, the byte (i mod 4) of the second word for
 * the integers), then the module's words.  picvr's own kernels are trusted input, but
 * the parser must hold on any words: every call returns without a sanitizer report,
 * and on success the copy keeps the header (the bound included), is no longer than
 * the input and differs from it only where a call became OpUndef or was dropped.
 */
#include <vulkan/vulkan.h>

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "picvr.h"

static void *picvr_host_alloc(const picvr_allocator *a, size_t n) {
    (void)a;
    return malloc(n ? n : 1);
}

static void picvr_host_free(const picvr_allocator *a, void *p) {
    (void)a;
    free(p);
}

#include "host/spirv.c"

static void check(int cond, const char *what) {
    if (!cond) {
        fprintf(stderr, "fuzz_spirv: invariant violated: %s\n", what);
        abort();
    }
}

#define SPECS 24u

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 8) return 0;
    uint32_t sel[2], value[SPECS];
    memcpy(sel, data, 8);
    VkSpecializationMapEntry entry[SPECS];
    for (uint32_t i = 0; i < SPECS; i++) {
        value[i] = (i & 1) ? (sel[1] >> (8 * (i % 4))) & 0xffu : (sel[0] >> i) & 1u;
        entry[i].constantID = i;
        entry[i].offset = 4 * i;
        entry[i].size = 4;
    }
    VkSpecializationInfo spec = {SPECS, entry, sizeof value, value};
    size_t words = (size - 8) / 4;
    uint32_t *code = (uint32_t *)malloc(words ? words * 4 : 4);   /* aligned, exactly sized: ASan sees overreads */
    if (!code) abort();
    memcpy(code, data + 8, words * 4);
    picvr_allocator alloc;
    memset(&alloc, 0, sizeof alloc);
    uint32_t *out = NULL;
    size_t out_words = 0;
    long pruned = picvr_spirv_prune(&alloc, code, words, &spec, &out, &out_words);
    if (pruned < 0) {
        check(out == NULL && out_words == 0, "a failure leaves no output");
    } else {
        check(out != NULL && out_words <= words && out_words >= 5, "the copy's size");
        check(memcmp(out, code, 5 * sizeof(uint32_t)) == 0, "the header kept");
        check(pruned > 0 || (out_words == words && memcmp(out, code, words * 4) == 0), "nothing pruned, nothing changed");
        free(out);
    }
    free(code);
    return 0;
}
