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
 * them. Memory comes from the allocation hook (pr_alloc.h): PR_ENOMEM when
 * it fails, and what proto hands over is released with pr_free(). Both pr_buf and pr_reader keep the first error (sticky), so a
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
    X(FLAGS, -8, "unknown flag bits set")                                    \
    X(TYPE, -9, "unknown or unexpected message or value type")               \
    X(DATA, -10, "inconsistent content: bad reference, order or string")     \
    X(JOB, -11, "peer belongs to another job or disagrees on its size")

enum pr_errno {
#define PR_ERRNO_ENUM(name, value, msg) PR_E##name = (value),
    PR_ERRNO_MAP(PR_ERRNO_ENUM)
#undef PR_ERRNO_ENUM
};

/* Static message for code, never NULL. */
const char *pr_strerror(int code);

/* ------------------------------------------------------------ write buffer */

/* A growable byte buffer. Zero-initialised (PR_BUF_INIT) it is empty and
 * valid. The buffer owns data; pr_buf_free() releases it. err keeps the
 * first error: PR_ENOMEM after an allocation failure, PR_EINVAL after an
 * encoder refused its input; once set, further puts do nothing, so a
 * sequence of puts can be checked once at the end. */
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
/* Transfers ownership of the bytes to the caller (pr_free() them) and leaves
 * b empty. Returns NULL if b is empty or in error. */
uint8_t *pr_buf_take(pr_buf *b, size_t *len);

void pr_put_u8(pr_buf *b, uint8_t v);
void pr_put_u16(pr_buf *b, uint16_t v);
void pr_put_u32(pr_buf *b, uint32_t v);
void pr_put_u64(pr_buf *b, uint64_t v);
void pr_put_i64(pr_buf *b, int64_t v);
void pr_put_f64(pr_buf *b, double v); /* IEEE 754 binary64 bits */
void pr_put_bytes(pr_buf *b, const void *p, size_t n);
void pr_put_i32(pr_buf *b, int32_t v);

/* Bulk arrays: n elements back to back in little-endian order, with no
 * count and no per-element overhead (the count is a separate field, written
 * once for several parallel arrays). On a little-endian host these are one
 * memcpy, so large meshes encode at memory speed. */
void pr_put_u32_array(pr_buf *b, const uint32_t *v, size_t n);
void pr_put_i32_array(pr_buf *b, const int32_t *v, size_t n);
void pr_put_u64_array(pr_buf *b, const uint64_t *v, size_t n);
void pr_put_f64_array(pr_buf *b, const double *v, size_t n);

/* Strings on the wire ("str"): a u16 byte length, then that many bytes of
 * UTF-8 with no NUL and no control character (U+0000..U+001F, U+007F), so a
 * decoded string can be printed, used as a JSON key or passed to C string
 * functions as it is. */
#define PR_STR_MAX 65535u
/* Returns 0 if s[0..len) is a valid wire string, else PR_EDATA (bad UTF-8
 * or a forbidden character) or PR_ERANGE (longer than PR_STR_MAX). */
int pr_str_check(const char *s, size_t len);
/* Appends s[0..len) as a str. A string that fails pr_str_check is not
 * written; its error is stored in b->err as PR_EINVAL and returned. */
int pr_put_str(pr_buf *b, const char *s, size_t len);

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
int pr_get_i32(pr_reader *r, int32_t *out);
/* Bulk arrays written by pr_put_*_array; n is a count the caller already
 * validated (typically with pr_get_count). On failure the contents of out
 * are unspecified. */
int pr_get_u32_array(pr_reader *r, uint32_t *out, size_t n);
int pr_get_i32_array(pr_reader *r, int32_t *out, size_t n);
int pr_get_u64_array(pr_reader *r, uint64_t *out, size_t n);
int pr_get_f64_array(pr_reader *r, double *out, size_t n);
/* Reads a str of at most max bytes (max <= PR_STR_MAX) into out, which has
 * room for max + 1 bytes, and NUL-terminates it. *len gets its length (may
 * be NULL). PR_ERANGE if longer than max, PR_EDATA if not a valid string;
 * on error out is "" and the reader is failed. */
int pr_get_str(pr_reader *r, size_t max, char *out, size_t *len);
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
/* Like pr_header_decode, but accepts any version and stores it in *version
 * instead of refusing it. The header layout is the same in every protocol
 * version, so this is how a PE reads a peer's hello before the two have
 * agreed on a version, and how it names the peer's version in an error.
 * Flag bits are checked only for PR_VERSION (another version may define
 * more); *version is set as soon as the magic matched. Returns PR_EVERSION
 * only for version 0, which no protocol uses. */
int pr_header_decode_any(pr_header *h, const void *buf, size_t len,
                         uint8_t *version);

/* ------------------------------------------------------- message envelope */

/* Every payload starts with a one-byte message type, then the body of that
 * type (PROTOCOL.md, "Message envelope"). The handler id in the frame
 * header says which function runs; the type says how the bytes are laid
 * out, so a handler never parses a body of the wrong kind. Values are never
 * reused; 0 is never a valid type. */
enum pr_msg_type {
    PR_MSG_HELLO = 0x01,   /* pr_hello: versions, job, rank, size */
    PR_MSG_STATS = 0x02,   /* pr_stats: named counters and timings */
    PR_MSG_SUBMESH = 0x03, /* pr_submesh: one PE's part of the mesh */
    /* 0x10..0x1f are reserved for the cavity messages of the parallel
     * refinement (request, partial reply, conflict, commit, ack, abort). */
};
#define PR_MSG_CAVITY_FIRST 0x10
#define PR_MSG_CAVITY_LAST 0x1f

/* Name of a message type ("hello", ...), or NULL if t is not defined. */
const char *pr_msg_name(int t);
/* Appends the envelope's type byte; the body follows. */
void pr_msg_begin(pr_buf *b, uint8_t type);
/* Returns the type byte of payload (0..255), or PR_ETRUNC if it is empty. */
int pr_msg_type(const void *payload, size_t len);
/* Starts reading payload as a message of the given type: initialises r,
 * consumes the type byte and returns 0, PR_ETRUNC (empty payload) or
 * PR_ETYPE (another type), failing r on error. */
int pr_msg_open(pr_reader *r, const void *payload, size_t len, uint8_t type);

/* ------------------------------------------------- hello and negotiation */

/* Protocol versions this build can speak. PR_VERSION is the one its frames
 * carry until negotiation picks another. */
#define PR_VERSION_MIN 1
#define PR_VERSION_MAX 1

/* The hello every PE sends to every peer before real traffic. Its layout
 * (and the frame header's) is the same in all protocol versions, so two PEs
 * of different builds can always read each other's hello and say why they
 * cannot talk. */
typedef struct pr_hello {
    uint8_t version;     /* version of the sender's own frames */
    uint8_t version_min; /* lowest version the sender speaks */
    uint8_t version_max; /* highest version the sender speaks */
    uint64_t job;        /* job id, the same on every PE of a job */
    uint32_t rank;       /* sender's rank, < size */
    uint32_t size;       /* number of PEs in the job, >= 1 */
} pr_hello;

/* Fills h with this build's versions and the given job, rank and size. */
void pr_hello_init(pr_hello *h, uint64_t job, uint32_t rank, uint32_t size);
/* Appends a hello message (envelope and body). PR_EINVAL if h is not
 * consistent (versions out of order, rank >= size). */
int pr_hello_put(pr_buf *b, const pr_hello *h);
/* Decodes a hello message. PR_EDATA for versions out of order or
 * rank >= size. */
int pr_hello_decode(pr_hello *h, const void *payload, size_t len);
/* Decides whether this PE (local) can talk to a peer (remote). On success
 * returns 0 and stores in *version the highest version both speak. On a
 * mismatch returns PR_EVERSION (no common version) or PR_EJOB (another job
 * id, another job size, or the peer claims this PE's rank), and if msg is
 * not NULL writes a one-line explanation naming both sides into
 * msg[0..msgsize), e.g. "rank 3 speaks protocol versions 2..3, this PE
 * speaks 1..1: run the same pdr build on every host". */
int pr_negotiate(const pr_hello *local, const pr_hello *remote,
                 uint8_t *version, char *msg, size_t msgsize);

/* ------------------------------------------------------------ global ids */

/* A vertex's global id (DESIGN.md 5.1) is the rank of the PE that created
 * it and a counter of that PE: gid = rank << 44 | seq. 20 bits of rank
 * allow 1,048,576 PEs, 44 bits of counter about 1.7e13 vertices per PE.
 * Comparing gids as integers orders them by rank, then by creation.
 * PR_GID_NONE (all ones) is never a valid gid: the largest counter is
 * reserved for it. */
#define PR_GID_RANK_BITS 20
#define PR_GID_SEQ_BITS 44
#define PR_GID_RANK_MAX ((UINT32_C(1) << PR_GID_RANK_BITS) - 1)
#define PR_GID_SEQ_MAX ((UINT64_C(1) << PR_GID_SEQ_BITS) - 2)
#define PR_GID_NONE UINT64_MAX

/* Returns the gid of counter value seq on rank, or PR_GID_NONE if rank >
 * PR_GID_RANK_MAX or seq > PR_GID_SEQ_MAX. */
static inline uint64_t pr_gid_make(uint32_t rank, uint64_t seq)
{
    if (rank > PR_GID_RANK_MAX || seq > PR_GID_SEQ_MAX)
        return PR_GID_NONE;
    return (uint64_t)rank << PR_GID_SEQ_BITS | seq;
}
static inline uint32_t pr_gid_rank(uint64_t gid)
{
    return (uint32_t)(gid >> PR_GID_SEQ_BITS);
}
static inline uint64_t pr_gid_seq(uint64_t gid)
{
    return gid & ((UINT64_C(1) << PR_GID_SEQ_BITS) - 1);
}

/* ---------------------------------------------------------- mesh entities */

/* Mesh entities as they travel. proto does not know the mesher's own
 * structures; the mesher converts to and from these.
 *
 * Invariants, checked by every encoder (PR_EINVAL) and decoder:
 *   - a gid is never PR_GID_NONE (PR_ERANGE);
 *   - coordinates are finite (PR_ERANGE);
 *   - a tetrahedron's four vertices are distinct (PR_EDATA); their order is
 *     its orientation and is kept as it is;
 *   - face i of a tetrahedron is the face opposite its vertex i; its marker
 *     is PR_MARKER_NONE (-1, not a subfacet) or the index >= 0 of the input
 *     facet it lies on (PR_ERANGE below -1);
 *   - subsegment bit e marks edge e, numbered (0,1) (0,2) (0,3) (1,2)
 *     (1,3) (2,3) for e = 0..5; bits 6 and 7 are 0 (PR_ERANGE);
 *   - a face key's three gids are strictly ascending (PR_EDATA), so a face
 *     has exactly one key whatever tetrahedron it is seen from. */
#define PR_MARKER_NONE (-1)
#define PR_SUBSEG_MASK 0x3fu

typedef struct pr_vertex {
    uint64_t gid;
    double xyz[3];
    uint32_t flags; /* the mesher's vertex flags, opaque to proto */
} pr_vertex;

typedef struct pr_tet {
    uint64_t v[4];          /* vertex gids, in orientation order */
    int32_t face_marker[4]; /* marker of the face opposite v[i] */
    uint8_t subseg;         /* PR_SUBSEG_MASK bits: edges that are subsegments */
    uint32_t owner;         /* rank of the PE that owns it */
} pr_tet;

typedef struct pr_face_key {
    uint64_t gid[3]; /* strictly ascending */
} pr_face_key;

/* Encoded sizes of the fixed-size records. */
#define PR_VERTEX_SIZE 36
#define PR_TET_SIZE 53
#define PR_FACE_KEY_SIZE 24

int pr_vertex_put(pr_buf *b, const pr_vertex *v);
int pr_vertex_get(pr_reader *r, pr_vertex *v);
int pr_tet_put(pr_buf *b, const pr_tet *t);
int pr_tet_get(pr_reader *r, pr_tet *t);
/* Sorts three distinct gids into a key; PR_EINVAL if two are equal or one
 * is PR_GID_NONE. */
int pr_face_key_make(pr_face_key *k, uint64_t a, uint64_t b, uint64_t c);
int pr_face_key_put(pr_buf *b, const pr_face_key *k);
int pr_face_key_get(pr_reader *r, pr_face_key *k);

/* A face key list: count, then the keys (at most PR_MAX_FACE_KEYS). The
 * decoder allocates *keys (caller frees with pr_free(); NULL when n is 0). */
#define PR_MAX_FACE_KEYS (UINT32_C(1) << 25)
int pr_face_keys_put(pr_buf *b, const pr_face_key *keys, uint32_t n);
int pr_face_keys_get(pr_reader *r, pr_face_key **keys, uint32_t *n);

/* ---------------------------------------------------- vertex and tet tables */

/* Bulk forms for many entities at once, stored as parallel arrays (one per
 * field) both in memory and on the wire, so that encoding and decoding are
 * a few long sequential copies. These are the building blocks of the
 * submesh and of the cavity messages (a "tetrahedra with their vertices"
 * list is a vertex table and a tetrahedron table).
 *
 * Invariants, beyond the entity ones above:
 *   - the gids of a vertex table are strictly ascending, so a table has no
 *     duplicate vertex, this is checked in one pass, and a gid is found by
 *     binary search (pr_vtable_find);
 *   - a tetrahedron table refers to vertices by index into the vertex table
 *     sent with it (every index < its vertex count, PR_EDATA), which halves
 *     the bytes of gid references and is what an array-based mesh stores;
 *   - a face marker is PR_MARKER_NONE or < the facet count given to the
 *     table's put and get (PR_FACETS_ANY when no count is known). */
#define PR_MAX_VERTICES (UINT32_C(1) << 25)
#define PR_MAX_TETS (UINT32_C(1) << 25)
#define PR_FACETS_ANY UINT32_MAX

typedef struct pr_vtable {
    uint32_t n;      /* number of vertices */
    uint64_t *gid;   /* [n], strictly ascending */
    double *xyz;     /* [3n], x y z of vertex 0, then of vertex 1, ... */
    uint32_t *flags; /* [n], opaque to proto */
} pr_vtable;

typedef struct pr_ttable {
    uint32_t n;      /* number of tetrahedra */
    uint32_t *v;     /* [4n], vertex indices of tetrahedron t at 4t..4t+3 */
    int32_t *marker; /* [4n], marker of the face opposite v[4t+i] */
    uint8_t *subseg; /* [n], PR_SUBSEG_MASK bits */
} pr_ttable;

/* Appends count and arrays. PR_EINVAL (stored in b->err) if t breaks an
 * invariant; nothing is written then. */
int pr_vtable_put(pr_buf *b, const pr_vtable *t);
/* Reads a vertex table into t, which the caller owns and releases with
 * pr_vtable_clear (also on error, when t is left empty). */
int pr_vtable_get(pr_reader *r, pr_vtable *t);
void pr_vtable_clear(pr_vtable *t);
/* Index of gid in t, or -1. O(log n). */
int64_t pr_vtable_find(const pr_vtable *t, uint64_t gid);

int pr_ttable_put(pr_buf *b, const pr_ttable *t, uint32_t n_vertices,
                  uint32_t n_facets);
int pr_ttable_get(pr_reader *r, pr_ttable *t, uint32_t n_vertices,
                  uint32_t n_facets);
void pr_ttable_clear(pr_ttable *t);

/* ---------------------------------------------------------------- submesh */

/* One PE's part of the mesh, as rank 0 scatters it after partitioning
 * (DESIGN.md 5.1): every tetrahedron of the part, every vertex they use,
 * and the interface faces, where the neighbour across a face lives on
 * another PE. All tetrahedra belong to rank (so no per-tetrahedron owner is
 * sent); parts that go to the same PE are sent as one submesh.
 *
 * Invariants (checked by pr_submesh_put and pr_submesh_decode):
 *   - rank < size; every vertex gid's rank < size;
 *   - the vertex and tetrahedron tables' invariants, with n_facets;
 *   - an interface face is named by 4 * t + i (face i of tetrahedron t),
 *     t < tet.n; the names are strictly ascending (no face twice);
 *   - its remote PE is < size and != rank. */
#define PR_MAX_IFACES (UINT32_C(1) << 25)

typedef struct pr_iftable {
    uint32_t n;       /* number of interface faces */
    uint32_t *face;   /* [n], 4 * tetrahedron + face, strictly ascending */
    uint32_t *remote; /* [n], rank of the PE on the other side */
} pr_iftable;

typedef struct pr_submesh {
    uint32_t part;     /* partition part id (informational) */
    uint32_t rank;     /* PE that owns every tetrahedron here */
    uint32_t size;     /* number of PEs in the job */
    uint32_t n_facets; /* input facets: face markers are -1 or < n_facets */
    pr_vtable vert;
    pr_ttable tet;
    pr_iftable iface;
} pr_submesh;

/* Appends a submesh message (envelope and body). sm's arrays stay the
 * caller's. PR_EINVAL (also stored in b->err) if sm breaks an invariant. */
int pr_submesh_put(pr_buf *b, const pr_submesh *sm);
/* Decodes and validates a submesh message. On success *out is a new
 * submesh the caller owns and releases with pr_submesh_free; on error *out
 * is NULL. */
int pr_submesh_decode(const void *payload, size_t len, pr_submesh **out);
/* Frees a submesh made by pr_submesh_decode and sets *sm to NULL. */
void pr_submesh_free(pr_submesh **sm);
/* Entity views of a decoded (or valid) submesh; i must be in range. */
void pr_submesh_vertex(const pr_submesh *sm, uint32_t i, pr_vertex *v);
void pr_submesh_tet(const pr_submesh *sm, uint32_t i, pr_tet *t);
void pr_submesh_iface_key(const pr_submesh *sm, uint32_t j, pr_face_key *k);

/* -------------------------------------------------------------- statistics */

/* A statistics blob: a self-describing list of named values, so that the
 * runtime's time accounting and the mesher's Table 1 figures can be
 * gathered to rank 0 and merged without either side knowing the other's
 * names. Names are wire strings of 1..PR_STAT_NAME_MAX bytes, kept sorted
 * (bytewise) and unique in a pr_stats, and sent in that order, so a decoder
 * finds duplicates in one pass and a lookup is a binary search. */
#define PR_STAT_NAME_MAX 64
#define PR_MAX_STATS 4096
#define PR_STATS_FORMAT 1 /* version of the blob's own layout */

enum pr_stat_type {
    PR_STAT_F64 = 1, /* a measurement, e.g. seconds */
    PR_STAT_I64 = 2, /* a signed quantity */
    PR_STAT_U64 = 3, /* a counter */
};

typedef struct pr_stat {
    char name[PR_STAT_NAME_MAX + 1]; /* NUL-terminated */
    uint8_t type;                    /* enum pr_stat_type */
    union {
        double f64;
        int64_t i64;
        uint64_t u64;
    } v;
} pr_stat;

typedef struct pr_stats {
    uint32_t rank;  /* PE the values come from (or the merging PE) */
    uint32_t n;     /* number of values */
    uint32_t cap;   /* allocated */
    pr_stat *item;  /* [n], sorted by name; owned */
} pr_stats;

#define PR_STATS_INIT {0, 0, 0, NULL}

/* Frees s's items and leaves it empty (rank is kept). */
void pr_stats_clear(pr_stats *s);
/* Add a value. PR_EINVAL for a name that is not a valid wire string of
 * 1..PR_STAT_NAME_MAX bytes or already present, PR_ERANGE when s already
 * holds PR_MAX_STATS values, PR_ENOMEM. */
int pr_stats_add_f64(pr_stats *s, const char *name, double v);
int pr_stats_add_i64(pr_stats *s, const char *name, int64_t v);
int pr_stats_add_u64(pr_stats *s, const char *name, uint64_t v);
/* The value named name, or NULL. */
const pr_stat *pr_stats_find(const pr_stats *s, const char *name);
/* Appends a statistics message (envelope and body). */
int pr_stats_put(pr_buf *b, const pr_stats *s);
/* Decodes a statistics message into out, which must be empty (e.g.
 * PR_STATS_INIT); the caller releases it with pr_stats_clear, also after
 * an error. PR_ETYPE for an unknown value type or blob format, PR_EDATA for
 * a bad name or names out of order. */
int pr_stats_decode(pr_stats *out, const void *payload, size_t len);
/* Adds in's values into acc: values with the same name and type are summed
 * (u64 and i64 must not overflow: PR_ERANGE), new names are inserted.
 * PR_ETYPE if a name has another type in acc. acc is unchanged on error.
 * Per-PE figures that must not be summed (Table 1 reports the worst PE)
 * are kept by keeping each PE's blob. */
int pr_stats_merge(pr_stats *acc, const pr_stats *in);

#ifdef __cplusplus
}
#endif
#endif /* PR_H */
