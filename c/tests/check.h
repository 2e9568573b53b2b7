/* A tiny test harness: CHECK counts failures and names the line; main returns the count. */
#ifndef NURIMC_TEST_CHECK_H
#define NURIMC_TEST_CHECK_H

#include <stdio.h>

static int check_failures;

#define CHECK(cond)                                                                                                    \
    do {                                                                                                               \
        if (!(cond)) {                                                                                                 \
            check_failures++;                                                                                          \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);                                   \
        }                                                                                                              \
    } while (0)

#define CHECK_EQ(a, b)                                                                                                 \
    do {                                                                                                               \
        long check_a_ = (long)(a), check_b_ = (long)(b);                                                               \
        if (check_a_ != check_b_) {                                                                                    \
            check_failures++;                                                                                          \
            fprintf(stderr, "%s:%d: CHECK_EQ failed: %s == %ld, %s == %ld\n", __FILE__, __LINE__, #a, check_a_, #b,    \
                    check_b_);                                                                                         \
        }                                                                                                              \
    } while (0)

static int check_report(const char *name) {
    if (check_failures) {
        fprintf(stderr, "%s: %d checks failed\n", name, check_failures);
        return 1;
    }
    printf("%s: all checks passed\n", name);
    return 0;
}

#endif
