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
#include <sys/wait.h>
#include <unistd.h>

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

/* RUN in a child process of its own, for tests that fork (the hemi-cube's
 * workers) after an earlier test in the same program started threads
 * (Embree's TBB workers): a fork copies a lock such a thread may hold, and
 * under ASan (whose allocator takes no lock around fork in GCC 12) the
 * child can wait on it forever.  A fresh child holds one thread only.  The
 * child leaves by _exit, so no copied atexit handler waits for a thread
 * that is not there. */
#define RUN_ISOLATED(name)                                                             \
    do {                                                                               \
        fflush(stdout);                                                                \
        fflush(stderr);                                                                \
        pid_t pid_ = fork();                                                           \
        if (pid_ == 0) {                                                               \
            test_current_ = #name;                                                     \
            name();                                                                    \
            fflush(stdout);                                                            \
            fflush(stderr);                                                            \
            _exit(test_checks_failed_ ? 1 : 0);                                        \
        }                                                                              \
        int st_ = 0;                                                                   \
        int ok_ = pid_ > 0 && waitpid(pid_, &st_, 0) == pid_ && WIFEXITED(st_) &&      \
                  WEXITSTATUS(st_) == 0;                                               \
        if (ok_) {                                                                     \
            test_passed_++;                                                            \
            printf("ok   %s\n", #name);                                                \
        } else {                                                                       \
            test_failed_++;                                                            \
            printf("FAIL %s%s\n", #name, pid_ < 0 ? " (fork failed)" : "");            \
        }                                                                              \
        fflush(stdout);                                                                \
    } while (0)

static inline int test_finish(const char *file)
{
    printf("%s: %d passed, %d failed\n", file, test_passed_, test_failed_);
    return test_failed_ ? 1 : 0;
}

#endif /* TEST_H */
