/* base/outfile.c -- temp-file-and-rename output. */
#include "config.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pr_alloc.h"
#include "base/outfile.h"

static void outfile_release(outfile *of)
{
    pr_free(of->path);
    pr_free(of->tmp);
    of->f = NULL;
    of->path = of->tmp = NULL;
}

int outfile_open(outfile *of, const char *path, pdr_diag *diag)
{
    memset(of, 0, sizeof *of);
    size_t n = strlen(path);
    of->path = pr_malloc(n + 1);
    of->tmp = pr_malloc(n + 16);
    if (!of->path || !of->tmp) {
        outfile_release(of);
        pdr_diag_add(diag, path, 0, "out of memory");
        return PDR_ENOMEM;
    }
    memcpy(of->path, path, n + 1);
    /* Same directory as the destination, so rename() stays atomic. */
    snprintf(of->tmp, n + 16, "%s.tmp.XXXXXX", path);
    int fd = mkstemp(of->tmp);
    if (fd < 0 || !(of->f = fdopen(fd, "w"))) {
        int err = errno;
        if (fd >= 0) {
            close(fd);
            unlink(of->tmp);
        }
        pdr_diag_add(diag, path, 0, "cannot create: %s", strerror(err));
        outfile_release(of);
        return PDR_EIO;
    }
    /* mkstemp makes the file 0600; give it the usual umask-based mode. */
    mode_t mask = umask(0);
    umask(mask);
    fchmod(fd, 0666 & ~mask);
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

void outfile_abort(outfile *of)
{
    if (of->f)
        fclose(of->f);
    if (of->tmp)
        unlink(of->tmp);
    outfile_release(of);
}
