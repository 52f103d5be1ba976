/* test.h - the smallest test harness that does the job.
 *
 * Each test file defines test functions with TEST(name), checks with CHECK
 * and CHECK_NEAR, and runs them from main with RUN(name); test_finish()
 * prints "FILE: N passed, N failed" and returns the exit status.  A test
 * "passes" when none of its checks failed.  Every tolerance is stated at the
 * check, with the reason beside it.
 */
#ifndef TEST_H
#define TEST_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int test_checks_failed_;
static int test_passed_, test_failed_;
static const char *test_current_ = "";

#define TEST(name) static void name(void)

#define CHECK(cond)                                                                    \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            test_checks_failed_++;                                                     \
            fprintf(stderr, "  FAIL %s (%s:%d): %s\n", test_current_, __FILE__,        \
                    __LINE__, #cond);                                                  \
        }                                                                              \
    } while (0)

#define CHECK_MSG(cond, ...)                                                           \
    do {                                                                               \
        if (!(cond)) {                                                                 \
            test_checks_failed_++;                                                     \
            fprintf(stderr, "  FAIL %s (%s:%d): %s: ", test_current_, __FILE__,        \
                    __LINE__, #cond);                                                  \
            fprintf(stderr, __VA_ARGS__);                                              \
            fputc('\n', stderr);                                                       \
        }                                                                              \
    } while (0)

/* |a - b| <= tol, with both values printed on failure. */
#define CHECK_NEAR(a, b, tol)                                                          \
    do {                                                                               \
        double a_ = (a), b_ = (b), t_ = (tol);                                         \
        if (!(fabs(a_ - b_) <= t_)) {                                                  \
            test_checks_failed_++;                                                     \
            fprintf(stderr, "  FAIL %s (%s:%d): %s = %.9g, %s = %.9g, tol %.3g\n",     \
                    test_current_, __FILE__, __LINE__, #a, a_, #b, b_, t_);            \
        }                                                                              \
    } while (0)

/* |a - b| <= rel·|b| */
#define CHECK_REL(a, b, rel) CHECK_NEAR(a, b, fabs((double)(b)) * (rel))

#define RUN(name)                                                                      \
    do {                                                                               \
        test_current_ = #name;                                                         \
        int before_ = test_checks_failed_;                                             \
        name();                                                                        \
        if (test_checks_failed_ == before_) {                                          \
            test_passed_++;                                                            \
            printf("ok   %s\n", #name);                                                \
        } else {                                                                       \
            test_failed_++;                                                            \
            printf("FAIL %s\n", #name);                                                \
        }                                                                              \
        fflush(stdout);                                                                \
    } while (0)

static inline int test_finish(const char *file)
{
    printf("%s: %d passed, %d failed\n", file, test_passed_, test_failed_);
    return test_failed_ ? 1 : 0;
}

#endif /* TEST_H */
