/*
 * replay_input.c -- runs the regression corpus of a target of
 * fuzz_input.h (proto's decoders through fuzz.h, the readers, control
 * frames, command line, cavity replies) without libFuzzer.
 *
 *   tests/fuzz/replay_<target> [-v] [FILE|DIR]...
 *
 * Feeds every file (of every directory) to the target's pdr_fuzz_run,
 * which aborts when the code under test breaks a promise; with no argument
 * the corpus is $top_srcdir/tests/corpus/<pdr_fuzz_corpus>. Hand-written
 * seeds are also held to their names: valid-* must be accepted, bad-*
 * refused, and so must proto's trunc-* and trailing (written by
 * 'tests/test_pr_golden --write-corpus'). Prints TAP; exit 0 pass, 1 fail, 99 harness error (no corpus,
 * unreadable file).
 */
#include "config.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz_input.h"

static int verbose;
static unsigned long n_inputs, n_accepted, n_wrong;

static uint8_t *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 4096;
    uint8_t *p = malloc(cap);
    *len = 0;
    while (p) {
        *len += fread(p + *len, 1, cap - *len, f);
        if (*len < cap)
            break;
        uint8_t *q = realloc(p, cap *= 2);
        if (!q)
            free(p);
        p = q;
    }
    if (p && ferror(f)) {
        free(p);
        p = NULL;
    }
    fclose(f);
    return p;
}

/* Runs one input; returns 0, or 99 if it cannot be read. */
static int run_file(const char *path)
{
    size_t len;
    uint8_t *data = read_all(path, &len);
    if (!data) {
        printf("Bail out! cannot read %s: %s\n", path, strerror(errno));
        return 99;
    }
    /* An exact-size copy, so that ASan sees any read past the end. */
    uint8_t *exact = malloc(len ? len : 1);
    if (!exact) {
        free(data);
        return 99;
    }
    memcpy(exact, data, len);
    free(data);
    int accepted = pdr_fuzz_run(exact, len);
    free(exact);

    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    const char *want = NULL;
    if (!strncmp(base, "valid-", 6) && !accepted)
        want = "accepted";
    else if ((!strncmp(base, "bad-", 4) || !strncmp(base, "trunc-", 6) ||
              !strcmp(base, "trailing")) &&
             accepted)
        want = "refused";
    if (want) {
        printf("# %s: should be %s, but was %s\n", path, want,
               accepted ? "accepted" : "refused");
        n_wrong++;
    }
    if (verbose)
        printf("# %s: %s\n", path, accepted ? "accepted" : "refused");
    n_inputs++;
    n_accepted += accepted != 0;
    return 0;
}

static int cmp_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Runs every regular file of dir, in name order so output repeats. */
static int run_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) {
        printf("Bail out! cannot open %s: %s\n", dir, strerror(errno));
        return 99;
    }
    char **names = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    int rc = 0;
    while ((e = readdir(d))) {
        if (e->d_name[0] == '.')
            continue;
        if (n == cap) {
            char **p = realloc(names, (cap = cap ? 2 * cap : 64) * sizeof *names);
            if (!p) {
                rc = 99;
                break;
            }
            names = p;
        }
        if (!(names[n] = malloc(strlen(dir) + strlen(e->d_name) + 2))) {
            rc = 99;
            break;
        }
        sprintf(names[n++], "%s/%s", dir, e->d_name);
    }
    closedir(d);
    if (n)
        qsort(names, n, sizeof *names, cmp_names);
    for (size_t i = 0; i < n; i++) {
        struct stat st;
        if (!rc && stat(names[i], &st) == 0 && S_ISREG(st.st_mode))
            rc = run_file(names[i]);
        free(names[i]);
    }
    free(names);
    return rc;
}

static int run_path(const char *path)
{
    struct stat st;
    if (stat(path, &st)) {
        printf("Bail out! %s: %s\n", path, strerror(errno));
        return 99;
    }
    return S_ISDIR(st.st_mode) ? run_dir(path) : run_file(path);
}

int main(int argc, char **argv)
{
    int first = 1, rc = 0, paths = 0;
    if (argc > 1 && !strcmp(argv[1], "-v"))
        verbose = 1, first = 2;
    printf("1..1\n");
    for (int i = first; i < argc && !rc; i++, paths++)
        rc = run_path(argv[i]);
    char dflt[4096];
    if (!paths) {
        const char *top = getenv("top_srcdir");
        snprintf(dflt, sizeof dflt, "%s/tests/corpus/%s", top ? top : ".",
                 pdr_fuzz_corpus);
        rc = run_path(dflt);
    }
    if (rc)
        return rc;
    if (n_inputs == 0) {
        printf("Bail out! no inputs: the corpus is empty\n");
        return 99;
    }
    if (n_wrong) {
        printf("not ok 1 - %s: %lu of %lu inputs not accepted or refused "
               "as their names say\n",
               pdr_fuzz_corpus, n_wrong, n_inputs);
        return 1;
    }
    printf("ok 1 - %s: %lu inputs, %lu accepted, no broken promise\n",
           pdr_fuzz_corpus, n_inputs, n_accepted);
    return 0;
}
