/* test_main.c - runs the whole picvr test suite as one cmocka group.
 *
 * Run from build/: PICVR_VALIDATION=1 PICVR_DATA=../../shared/data ./picvr-tests
 * PICVR_TEST_FILTER=<glob> runs only the matching tests (cmocka_set_test_filter). */
#include "test_util.h"

#include <stdlib.h>

#define TU_ENTRY(name) cmocka_unit_test_setup_teardown(name, tu_setup, tu_teardown),

int main(void) {
    const struct CMUnitTest tests[] = {TU_ALL_TESTS(TU_ENTRY)};
    const char *filter = getenv("PICVR_TEST_FILTER");
    if (filter && *filter) cmocka_set_test_filter(filter);
    return cmocka_run_group_tests_name("picvr", tests, NULL, NULL);
}
