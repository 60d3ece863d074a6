/* pr_stats.c -- the statistics blob: named f64/i64/u64 values, gathered
 * from every PE to rank 0 and merged there (PROTOCOL.md, "Statistics"). */
#include "config.h"

#include <stdlib.h>
#include <string.h>

#include "pr.h"
#include "pr_alloc.h"
#include "pr_int.h"

/* Smallest encoded entry: a 1-byte name (2 + 1), type, value. */
#define STAT_MIN_SIZE (2 + 1 + 1 + 8)

static int type_ok(uint8_t t)
{
    return t == PR_STAT_F64 || t == PR_STAT_I64 || t == PR_STAT_U64;
}

static int name_ok(const char *name, size_t len)
{
    return len >= 1 && len <= PR_STAT_NAME_MAX && pr_str_check(name, len) == 0;
}

void pr_stats_clear(pr_stats *s)
{
    pr_free(s->item);
    s->item = NULL;
    s->n = s->cap = 0;
}

/* Index of the first item whose name is >= name (binary search). Names
 * hold no NUL, so strcmp order is bytewise order. */
static uint32_t lower_bound(const pr_stats *s, const char *name)
{
    uint32_t lo = 0, hi = s->n;
    while (lo < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (strcmp(s->item[mid].name, name) < 0)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

const pr_stat *pr_stats_find(const pr_stats *s, const char *name)
{
    uint32_t i = lower_bound(s, name);
    return i < s->n && strcmp(s->item[i].name, name) == 0 ? &s->item[i] : NULL;
}

static int grow(pr_stats *s, uint32_t need)
{
    if (need <= s->cap)
        return 0;
    uint32_t cap = s->cap ? s->cap : 16;
    while (cap < need)
        cap *= 2;
    pr_stat *p = pr_realloc(s->item, (size_t)cap * sizeof *p);
    if (!p)
        return PR_ENOMEM;
    s->item = p;
    s->cap = cap;
    return 0;
}

static int add(pr_stats *s, const char *name, const pr_stat *value)
{
    size_t len = strlen(name);
    if (!name_ok(name, len))
        return PR_EINVAL;
    uint32_t i = lower_bound(s, name);
    if (i < s->n && strcmp(s->item[i].name, name) == 0)
        return PR_EINVAL;
    if (s->n >= PR_MAX_STATS)
        return PR_ERANGE;
    if (grow(s, s->n + 1))
        return PR_ENOMEM;
    memmove(&s->item[i + 1], &s->item[i], (s->n - i) * sizeof *s->item);
    s->item[i] = *value;
    memcpy(s->item[i].name, name, len + 1);
    s->n++;
    return 0;
}

int pr_stats_add_f64(pr_stats *s, const char *name, double v)
{
    pr_stat x = {.type = PR_STAT_F64, .v.f64 = v};
    return add(s, name, &x);
}

int pr_stats_add_i64(pr_stats *s, const char *name, int64_t v)
{
    pr_stat x = {.type = PR_STAT_I64, .v.i64 = v};
    return add(s, name, &x);
}

int pr_stats_add_u64(pr_stats *s, const char *name, uint64_t v)
{
    pr_stat x = {.type = PR_STAT_U64, .v.u64 = v};
    return add(s, name, &x);
}

/* The 64 bits that carry x's value on the wire. */
static uint64_t value_bits(const pr_stat *x)
{
    switch (x->type) {
    case PR_STAT_F64:
        return pr__f64_bits(x->v.f64);
    case PR_STAT_I64:
        return (uint64_t)x->v.i64;
    default:
        return x->v.u64;
    }
}

static void set_value_bits(pr_stat *x, uint64_t u)
{
    switch (x->type) {
    case PR_STAT_F64:
        x->v.f64 = pr__bits_f64(u);
        break;
    case PR_STAT_I64:
        x->v.i64 = (int64_t)u;
        break;
    default:
        x->v.u64 = u;
        break;
    }
}

int pr_stats_put(pr_buf *b, const pr_stats *s)
{
    if (b->err)
        return b->err;
    /* A pr_stats built with pr_stats_add is always valid; one filled by
     * hand is checked here so that a bad blob never leaves this PE. */
    if (s->n > PR_MAX_STATS)
        return pr__buf_fail(b, PR_EINVAL);
    for (uint32_t i = 0; i < s->n; i++) {
        const pr_stat *x = &s->item[i];
        size_t len = strnlen(x->name, sizeof x->name);
        if (len > PR_STAT_NAME_MAX || !name_ok(x->name, len) ||
            !type_ok(x->type) ||
            (i > 0 && strcmp(s->item[i - 1].name, x->name) >= 0))
            return pr__buf_fail(b, PR_EINVAL);
    }
    pr_msg_begin(b, PR_MSG_STATS);
    pr_put_u8(b, PR_STATS_FORMAT);
    pr_put_u32(b, s->rank);
    pr_put_u32(b, s->n);
    for (uint32_t i = 0; i < s->n; i++) {
        const pr_stat *x = &s->item[i];
        pr_put_str(b, x->name, strlen(x->name));
        pr_put_u8(b, x->type);
        pr_put_u64(b, value_bits(x));
    }
    return b->err;
}

int pr_stats_decode(pr_stats *out, const void *payload, size_t len)
{
    pr_reader r;
    uint8_t format;
    uint32_t n;
    if (out->n || out->item)
        return PR_EINVAL;
    out->rank = 0;
    if (pr_msg_open(&r, payload, len, PR_MSG_STATS) ||
        pr_get_u8(&r, &format))
        return r.err;
    if (format != PR_STATS_FORMAT)
        return pr_reader_fail(&r, PR_ETYPE);
    pr_get_u32(&r, &out->rank);
    if (pr_get_count(&r, PR_MAX_STATS, STAT_MIN_SIZE, &n))
        return r.err;
    if (grow(out, n)) {
        pr_reader_fail(&r, PR_ENOMEM);
        goto fail;
    }
    for (uint32_t i = 0; i < n; i++) {
        pr_stat *x = &out->item[i];
        size_t name_len;
        uint64_t bits;
        if (pr_get_str(&r, PR_STAT_NAME_MAX, x->name, &name_len))
            goto fail;
        if (name_len == 0 ||
            (i > 0 && strcmp(out->item[i - 1].name, x->name) >= 0)) {
            pr_reader_fail(&r, PR_EDATA);
            goto fail;
        }
        if (pr_get_u8(&r, &x->type) || pr_get_u64(&r, &bits))
            goto fail;
        if (!type_ok(x->type)) {
            pr_reader_fail(&r, PR_ETYPE);
            goto fail;
        }
        set_value_bits(x, bits);
        out->n = i + 1;
    }
    if (pr_reader_finish(&r)) {
        pr_reader_fail(&r, PR_ETRAILING);
        goto fail;
    }
    return 0;
fail:
    pr_stats_clear(out);
    out->rank = 0;
    return r.err;
}

/* a + b into *sum for two values of type t; PR_ERANGE on integer
 * overflow. */
static int add_values(uint8_t t, const pr_stat *a, const pr_stat *b,
                      pr_stat *sum)
{
    switch (t) {
    case PR_STAT_F64:
        sum->v.f64 = a->v.f64 + b->v.f64;
        return 0;
    case PR_STAT_I64: {
        int64_t x = a->v.i64, y = b->v.i64;
        if ((y > 0 && x > INT64_MAX - y) || (y < 0 && x < INT64_MIN - y))
            return PR_ERANGE;
        sum->v.i64 = x + y;
        return 0;
    }
    default:
        if (a->v.u64 > UINT64_MAX - b->v.u64)
            return PR_ERANGE;
        sum->v.u64 = a->v.u64 + b->v.u64;
        return 0;
    }
}

int pr_stats_merge(pr_stats *acc, const pr_stats *in)
{
    /* Merge the two sorted lists into a new array and swap it in at the
     * end, so acc is untouched when anything fails. */
    size_t cap = (size_t)acc->n + in->n;
    pr_stat *m = cap ? pr_malloc(cap * sizeof *m) : NULL;
    if (cap && !m)
        return PR_ENOMEM;
    uint32_t i = 0, j = 0, k = 0;
    int rc = 0;
    while (i < acc->n || j < in->n) {
        int c = i == acc->n  ? 1
                : j == in->n ? -1
                             : strcmp(acc->item[i].name, in->item[j].name);
        if (c < 0) {
            m[k++] = acc->item[i++];
        } else if (c > 0) {
            if (!type_ok(in->item[j].type)) {
                rc = PR_ETYPE;
                break;
            }
            m[k++] = in->item[j++];
        } else {
            if (acc->item[i].type != in->item[j].type) {
                rc = PR_ETYPE;
                break;
            }
            m[k] = acc->item[i];
            rc = add_values(m[k].type, &acc->item[i], &in->item[j], &m[k]);
            if (rc)
                break;
            k++, i++, j++;
        }
    }
    if (!rc && k > PR_MAX_STATS)
        rc = PR_ERANGE;
    if (rc) {
        pr_free(m);
        return rc;
    }
    pr_free(acc->item);
    acc->item = m;
    acc->n = k;
    acc->cap = k; /* at least k items are allocated */
    return 0;
}
