/*
 * pr_sample.h -- sample messages for proto's tests, fuzz targets and
 * benchmark: the fixed values the golden files pin, seeded random valid
 * messages for the property tests, a synthetic grid submesh for the
 * benchmark, and one decode-and-re-encode check per decoder, shared by the
 * fuzz targets and the unit tests.
 */
#ifndef PR_SAMPLE_H
#define PR_SAMPLE_H

#include <stddef.h>
#include <stdint.h>

#include "pr.h"

/* The decoders, one per fuzz target and golden file. */
enum prs_kind {
    PRS_HEADER,    /* 24-byte frame header (pr_header_decode) */
    PRS_HELLO,     /* hello message (pr_hello_decode) */
    PRS_STATS,     /* statistics message (pr_stats_decode) */
    PRS_SUBMESH,   /* submesh message (pr_submesh_decode) */
    PRS_VERTEX,    /* one vertex record (pr_vertex_get) */
    PRS_TET,       /* one tetrahedron record (pr_tet_get) */
    PRS_FACE_KEYS, /* a face key list (pr_face_keys_get) */
    PRS_NKINDS
};

/* "header", "hello", ... (the file and fuzz target names). */
const char *prs_name(int kind);
/* Kind named name, or -1. */
int prs_kind(const char *name);

/* Appends the fixed sample of kind to b (the golden value). */
int prs_fixed(int kind, pr_buf *b);

/* Decodes data as kind. Returns the decoder's error (< 0) if it refused the
 * input; 0 if it accepted it and every check passed: re-encoding the
 * decoded value gives back exactly the input (the encoding is canonical),
 * and the decoded value's accessors agree with it. Returns 1, after
 * printing why on stderr, if an accepted input breaks one of these: that is
 * a bug, which the fuzz targets turn into a crash. */
int prs_check(int kind, const uint8_t *data, size_t len);

/* A small seeded generator (splitmix64), so property tests are repeatable. */
typedef struct prs_rng {
    uint64_t s;
} prs_rng;
uint64_t prs_next(prs_rng *r);
/* Uniform in [0, n), n > 0. */
uint64_t prs_below(prs_rng *r, uint64_t n);

/* Random valid values. Each fills *out with arrays the caller releases
 * with the matching prs_*_free. */
void prs_random_hello(prs_rng *r, pr_hello *out);
void prs_random_stats(prs_rng *r, pr_stats *out); /* pr_stats_clear */
void prs_random_submesh(prs_rng *r, pr_submesh *out);
void prs_random_vertex(prs_rng *r, pr_vertex *out);
void prs_random_tet(prs_rng *r, pr_tet *out);
/* n random keys in *keys (free()). */
void prs_random_face_keys(prs_rng *r, pr_face_key **keys, uint32_t *n);
/* Frees the arrays of a submesh built by prs_random_submesh or
 * prs_grid_submesh (not one from pr_submesh_decode). */
void prs_submesh_free(pr_submesh *sm);

/* A structured grid of nx * ny * nz cubes, each split into 6 tetrahedra
 * around its main diagonal: rank 0 of 2, boundary faces marked by side
 * (facets 0..5), boundary edges marked as subsegments, the faces on the
 * x = nx side shared with rank 1. Returns 0 or PR_ENOMEM. */
int prs_grid_submesh(uint32_t nx, uint32_t ny, uint32_t nz, pr_submesh *out);

/* 1 if two submeshes (or stats, ...) hold the same values, else 0. */
int prs_submesh_equal(const pr_submesh *a, const pr_submesh *b);
int prs_stats_equal(const pr_stats *a, const pr_stats *b);

#endif /* PR_SAMPLE_H */
