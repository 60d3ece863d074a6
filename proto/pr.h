/*
 * pr.h -- pdr's wire formats (libpdrproto).
 *
 * Everything on the wire is little-endian and written field by field: no
 * struct is ever copied to or from a buffer. Writers append to a growable
 * pr_buf; readers walk a pr_reader that checks every length against the
 * bytes that remain before it reads, so a malformed message yields an error
 * code, never an out-of-bounds read, and a count in a message can never make
 * a reader allocate more than the message could hold. The byte layouts are
 * specified in proto/PROTOCOL.md.
 *
 * Errors: functions return 0 or a negative PR_E* code; pr_strerror() names
 * them. Both pr_buf and pr_reader keep the first error (sticky), so a
 * sequence of puts or gets can be checked once at the end.
 */
#ifndef PR_H
#define PR_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------ error codes */

#define PR_ERRNO_MAP(X)                                                      \
    X(OK, 0, "success")                                                      \
    X(NOMEM, -1, "out of memory")                                            \
    X(INVAL, -2, "invalid argument")                                         \
    X(TRUNC, -3, "message truncated: a field runs past the end")             \
    X(MAGIC, -4, "bad magic: not a pdr frame")                               \
    X(VERSION, -5, "peer speaks another protocol version")                   \
    X(RANGE, -6, "a count or value is out of its allowed range")             \
    X(TRAILING, -7, "unexpected bytes after the end of the message")         \
    X(FLAGS, -8, "unknown flag bits set")

enum pr_errno {
#define PR_ERRNO_ENUM(name, value, msg) PR_E##name = (value),
    PR_ERRNO_MAP(PR_ERRNO_ENUM)
#undef PR_ERRNO_ENUM
};

/* Static message for code, never NULL. */
const char *pr_strerror(int code);

/* ------------------------------------------------------------ write buffer */

/* A growable byte buffer. Zero-initialised (PR_BUF_INIT) it is empty and
 * valid. The buffer owns data; pr_buf_free() releases it. After an
 * allocation failure err is PR_ENOMEM and further puts do nothing. */
typedef struct pr_buf {
    uint8_t *data; /* owned; NULL while cap == 0 */
    size_t len;    /* bytes written */
    size_t cap;    /* bytes allocated */
    int err;       /* first error, 0 if none */
} pr_buf;

#define PR_BUF_INIT {NULL, 0, 0, 0}

void pr_buf_free(pr_buf *b);
/* Empties b but keeps its memory for reuse; also clears err. */
void pr_buf_reset(pr_buf *b);
/* Makes room for n more bytes; returns 0 or PR_ENOMEM (also stored). */
int pr_buf_reserve(pr_buf *b, size_t n);
/* Transfers ownership of the bytes to the caller (free() them) and leaves
 * b empty. Returns NULL if b is empty or in error. */
uint8_t *pr_buf_take(pr_buf *b, size_t *len);

void pr_put_u8(pr_buf *b, uint8_t v);
void pr_put_u16(pr_buf *b, uint16_t v);
void pr_put_u32(pr_buf *b, uint32_t v);
void pr_put_u64(pr_buf *b, uint64_t v);
void pr_put_i64(pr_buf *b, int64_t v);
void pr_put_f64(pr_buf *b, double v); /* IEEE 754 binary64 bits */
void pr_put_bytes(pr_buf *b, const void *p, size_t n);

/* Little-endian stores into caller memory (no bounds: caller checked). */
void pr_store_u16(uint8_t *p, uint16_t v);
void pr_store_u32(uint8_t *p, uint32_t v);
void pr_store_u64(uint8_t *p, uint64_t v);
uint16_t pr_load_u16(const uint8_t *p);
uint32_t pr_load_u32(const uint8_t *p);
uint64_t pr_load_u64(const uint8_t *p);

/* ----------------------------------------------------------------- reader */

/* A cursor over bytes it does not own. Every get checks the remaining
 * length first; on failure it stores PR_ETRUNC (or the given error), leaves
 * *out zeroed and makes every later get fail too. */
typedef struct pr_reader {
    const uint8_t *p; /* next byte */
    size_t left;      /* bytes remaining */
    int err;          /* first error, 0 if none */
} pr_reader;

void pr_reader_init(pr_reader *r, const void *data, size_t len);
int pr_get_u8(pr_reader *r, uint8_t *out);
int pr_get_u16(pr_reader *r, uint16_t *out);
int pr_get_u32(pr_reader *r, uint32_t *out);
int pr_get_u64(pr_reader *r, uint64_t *out);
int pr_get_i64(pr_reader *r, int64_t *out);
int pr_get_f64(pr_reader *r, double *out);
int pr_get_bytes(pr_reader *r, void *out, size_t n);
/* Points *out at the next n bytes (still owned by the message) and skips
 * them. */
int pr_get_view(pr_reader *r, const uint8_t **out, size_t n);
/* Reads a u32 element count and checks, before anything is allocated, that
 * count <= max and that count * elem_size bytes remain in the message.
 * Returns 0, PR_ETRUNC or PR_ERANGE. */
int pr_get_count(pr_reader *r, uint32_t max, size_t elem_size, uint32_t *out);
/* Records err as the reader's error if it has none yet; returns r->err. */
int pr_reader_fail(pr_reader *r, int err);
/* Returns 0 if the reader consumed the whole message without error,
 * PR_ETRAILING if bytes remain, or the stored error. */
int pr_reader_finish(const pr_reader *r);

/* ----------------------------------------------------------- frame header */

/* Every message between PEs starts with this fixed 24-byte header:
 *
 *   off size field
 *     0    4 magic "PDR" 0xA7
 *     4    1 protocol version (PR_VERSION)
 *     5    1 flags (PR_FLAG_*; unknown bits are refused)
 *     6    2 handler id
 *     8    4 sender rank
 *    12    4 payload length in bytes (the payload follows the header)
 *    16    8 sequence number (per sender, per destination, from 0)
 */
#define PR_VERSION 1
#define PR_HEADER_SIZE 24
#define PR_MAGIC0 0x50 /* 'P' */
#define PR_MAGIC1 0x44 /* 'D' */
#define PR_MAGIC2 0x52 /* 'R' */
#define PR_MAGIC3 0xA7 /* not ASCII, so text is never taken for a frame */

/* Flag bits. PR_FLAG_CONTROL marks runtime-internal messages (hello,
 * termination token, collectives) as opposed to user active messages. */
#define PR_FLAG_CONTROL 0x01u
#define PR_FLAG_KNOWN (PR_FLAG_CONTROL)

/* Largest payload a frame may announce (1 GiB). */
#define PR_MAX_PAYLOAD (UINT32_C(1) << 30)

typedef struct pr_header {
    uint8_t flags;        /* PR_FLAG_* */
    uint16_t handler;     /* handler id on the receiver */
    uint32_t sender;      /* rank of the sending PE */
    uint32_t payload_len; /* bytes after the header */
    uint64_t seq;         /* sequence number */
} pr_header;

/* Writes h into out[0..PR_HEADER_SIZE). Returns PR_EINVAL if a field is out
 * of range (unknown flags, payload too long). */
int pr_header_encode(const pr_header *h, uint8_t out[PR_HEADER_SIZE]);
/* Appends the encoded header to b. */
int pr_header_put(pr_buf *b, const pr_header *h);
/* Parses the header at the start of buf (len bytes). Checks magic, version
 * (PR_EVERSION for a peer with another version), flags and payload limit;
 * does not require the payload to be present. */
int pr_header_decode(pr_header *h, const void *buf, size_t len);

#ifdef __cplusplus
}
#endif
#endif /* PR_H */
