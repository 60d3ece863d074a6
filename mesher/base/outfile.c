/* base/outfile.c -- temp-file-and-rename output. */
#include "config.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "base/outfile.h"
#include "base/pdr_util.h"

static void outfile_release(outfile *of)
{
    pr_free(of->path);
    pr_free(of->tmp);
    of->f = NULL;
    of->path = of->tmp = NULL;
    of->set = NULL;
}

int outfile_open(outfile *of, const char *path, pdr_diag *diag)
{
    return outfile_open_in(of, NULL, path, diag);
}

int outfile_open_in(outfile *of, outset *set, const char *path, pdr_diag *diag)
{
    memset(of, 0, sizeof *of);
    if (set && set->n >= OUTSET_MAX) {
        pdr_diag_add(diag, path, 0, "too many files in one output set");
        return PDR_ELIMIT;
    }
    size_t n = strlen(path);
    of->path = pr_malloc(n + 1);
    of->tmp = pr_malloc(n + 16);
    if (!of->path || !of->tmp) {
        outfile_release(of);
        pdr_diag_add(diag, path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    memcpy(of->path, path, n + 1);
    /* Same directory as the destination, so rename() stays atomic; a name
     * nobody has (O_EXCL), made with mode 0666 for the umask to apply as
     * to any file (mkstemp's 0600 would need the umask read back, which
     * sets it, and output files may be opened by several threads). */
    uint64_t x = ((uint64_t)(uintptr_t)of ^ (uint64_t)getpid() << 32 ^
                  (uint64_t)(pdr_now() * 1e9)) | 1;
    int fd = -1, err = EEXIST;
    for (int attempt = 0; attempt < 100 && fd < 0 && err == EEXIST; attempt++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        snprintf(of->tmp, n + 16, "%s.tmp.%06x", path, (unsigned)(x & 0xFFFFFF));
        fd = open(of->tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
        err = fd < 0 ? errno : 0;
    }
    if (fd < 0 || !(of->f = fdopen(fd, "w"))) {
        if (fd >= 0) {
            err = errno;
            close(fd);
            unlink(of->tmp);
        }
        pdr_diag_add(diag, path, 0, "cannot create: %s", strerror(err));
        outfile_release(of);
        return PDR_EIO;
    }
    of->set = set;
    return 0;
}

int outfile_commit(outfile *of, pdr_diag *diag)
{
    int failed = ferror(of->f);
    int err = failed ? EIO : 0;
    if (fflush(of->f) != 0 || fsync(fileno(of->f)) != 0) {
        failed = 1;
        err = errno;
    }
    if (fclose(of->f) != 0 && !failed) {
        failed = 1;
        err = errno;
    }
    of->f = NULL;
    if (!failed && of->set) {
        /* The set renames it with the others (room checked at open). */
        outset *set = of->set;
        set->path[set->n] = of->path;
        set->tmp[set->n] = of->tmp;
        set->n++;
        of->path = of->tmp = NULL;
        of->set = NULL;
        return 0;
    }
    if (!failed && rename(of->tmp, of->path) != 0) {
        failed = 1;
        err = errno;
    }
    if (failed) {
        unlink(of->tmp);
        pdr_diag_add(diag, of->path, 0, "write failed: %s", strerror(err));
    }
    outfile_release(of);
    return failed ? PDR_EIO : 0;
}

int outset_commit(outset *set, pdr_diag *diag)
{
    int rc = 0;
    for (size_t i = 0; i < set->n; i++) {
        if (!rc && rename(set->tmp[i], set->path[i]) != 0) {
            pdr_diag_add(diag, set->path[i], 0, "write failed: %s", strerror(errno));
            rc = PDR_EIO;
        }
        if (rc)
            unlink(set->tmp[i]);
        pr_free(set->path[i]);
        pr_free(set->tmp[i]);
        set->path[i] = set->tmp[i] = NULL;
    }
    set->n = 0;
    return rc;
}

int outset_move(outset *set, outset *from)
{
    if (set->n + from->n > OUTSET_MAX)
        return PDR_ELIMIT;
    for (size_t i = 0; i < from->n; i++) {
        set->path[set->n] = from->path[i];
        set->tmp[set->n] = from->tmp[i];
        set->n++;
        from->path[i] = from->tmp[i] = NULL;
    }
    from->n = 0;
    return 0;
}

void outset_abort(outset *set)
{
    for (size_t i = 0; i < set->n; i++) {
        unlink(set->tmp[i]);
        pr_free(set->path[i]);
        pr_free(set->tmp[i]);
        set->path[i] = set->tmp[i] = NULL;
    }
    set->n = 0;
}

void outfile_abort(outfile *of)
{
    if (of->f)
        fclose(of->f);
    if (of->tmp)
        unlink(of->tmp);
    outfile_release(of);
}
