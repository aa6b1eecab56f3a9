/* test_main.c - runs the whole picvr test suite as one cmocka group.
 *
 * Run from build/: PICVR_VALIDATION=1 PICVR_DATA=../../shared/data ./picvr-tests
 * PICVR_TEST_FILTER=<glob> runs only the matching tests (cmocka_set_test_filter). */
#include "test_util.h"

#include <stdio.h>
#include <stdlib.h>

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

int main(void) {
    const struct CMUnitTest tests[] = {TU_ALL_TESTS(TU_ENTRY)};
    print_device();
    const char *filter = getenv("PICVR_TEST_FILTER");
    if (filter && *filter) cmocka_set_test_filter(filter);
    return cmocka_run_group_tests_name("picvr", tests, NULL, NULL);
}
