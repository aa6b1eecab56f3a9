/* test_main.c - runs the whole picvr test suite as one cmocka group.
 *
 * Run from build/: PICVR_VALIDATION=1 PICVR_DATA=../../shared/data ./picvr-tests
 * PICVR_TEST_FILTER=GLOB[,GLOB...] runs only the tests whose name matches one of the
 * globs, PICVR_TEST_SKIP=GLOB[,GLOB...] leaves out those matching one (fnmatch(3)):
 * `make test-asan` gives the sanitizers the API, hostile-input and reader tests this way. */
#include "test_util.h"

#include <fnmatch.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vulkan/vulkan.h>

#define TU_ENTRY(name) cmocka_unit_test_setup_teardown(name, tu_setup, tu_teardown),

/* Names the device the tests run on (the default choice, or PICVR_DEVICE), so that a
   log from another machine says what it tested. */
static void print_device(void) {
    picvr_config cfg = {0};
    picvr_context *ctx = NULL;
    picvr_stats st;
    if (picvr_create(&cfg, &ctx) != PICVR_OK) {
        printf("picvr-tests: no Vulkan device could be opened\n");
        return;
    }
    if (picvr_get_stats(ctx, &st) == PICVR_OK)
        printf("picvr-tests: device %s (%s)\n", st.device_name, picvr_device_type_string(st.device_type));
    picvr_destroy(ctx);
}

/* The suite creates and destroys a few hundred contexts, each with its own VkInstance.
   When the last instance goes, the loader unloads the driver, and the next one loads it
   again; NVIDIA's driver takes static TLS each time it is loaded and never gives it back,
   so after a few dozen contexts no driver loads at all (PICVR_ERROR_NO_DEVICE, measured
   on an H200, docs/gpu.md).  An instance held for the whole run keeps the
   driver loaded; it enables no layer and creates no device, so the tests see the same
   library.  PICVR_TEST_HOLD_INSTANCE=0 runs without it. */
static VkInstance hold_driver_loaded(void) {
    const char *env = getenv("PICVR_TEST_HOLD_INSTANCE");
    if (env && env[0] == '0') return VK_NULL_HANDLE;
    VkInstanceCreateInfo ci = {VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
    VkInstance instance = VK_NULL_HANDLE;
    if (vkCreateInstance(&ci, NULL, &instance) != VK_SUCCESS) return VK_NULL_HANDLE;
    return instance;
}

/* 1 if name matches one of the comma-separated globs of list. */
static int matches_any(const char *name, const char *list) {
    char glob[256];
    while (*list) {
        size_t n = strcspn(list, ",");
        if (n > 0 && n < sizeof glob) {
            memcpy(glob, list, n);
            glob[n] = '\0';
            if (fnmatch(glob, name, 0) == 0) return 1;
        }
        list += n;
        if (*list == ',') list++;
    }
    return 0;
}

int main(void) {
    static const struct CMUnitTest all[] = {TU_ALL_TESTS(TU_ENTRY)};
    static struct CMUnitTest tests[sizeof all / sizeof all[0]];
    const char *filter = getenv("PICVR_TEST_FILTER"), *skip = getenv("PICVR_TEST_SKIP");
    size_t count = 0;
    for (size_t i = 0; i < sizeof all / sizeof all[0]; i++)
        if ((!filter || !*filter || matches_any(all[i].name, filter)) && !(skip && *skip && matches_any(all[i].name, skip)))
            tests[count++] = all[i];
    if (count == 0) {
        printf("picvr-tests: no test matches PICVR_TEST_FILTER / PICVR_TEST_SKIP\n");
        return 1;
    }
    VkInstance held = hold_driver_loaded();
    print_device();
    int failed = _cmocka_run_group_tests("picvr", tests, count, NULL, NULL);
    printf("picvr-tests: %u partial skips\n", tu_partial_skips());
    if (held != VK_NULL_HANDLE) vkDestroyInstance(held, NULL);
    return failed;
}
